//! Scan throughput: radar (thesis model) and laser on the thesis map, and the rays of the
//! peers benchmark (DESIGN §11) through forests of 1 000, 10 000 and 100 000 foliage spheres
//! at one density (radius 0.3-1.0 m, 10 000 over 200 × 200 m). Reported as rays per second on
//! one thread.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radarnav::peers::forest_scene;
use radarnav::sensor::{SensorConfig, Tracer, preset};
use radarnav::world::Band;
use radarnav::world::forest::ForestSpec;
use radarnav::{Pose, Scenario, World};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn bench_scans(c: &mut Criterion, group: &str, world: &World, pose: Pose, sensors: &[&str]) {
    let mut g = c.benchmark_group(group);
    for name in sensors {
        let config: SensorConfig = preset(name).expect("preset");
        g.throughput(Throughput::Elements(config.azimuth_count() as u64));
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut tracer = Tracer::default();
        g.bench_function(*name, |b| {
            b.iter(|| black_box(config.scan(world, &pose, 0.0, &mut rng, &mut tracer)))
        });
    }
    g.finish();
}

fn scans(c: &mut Criterion) {
    let s = Scenario::builtin("foliage-wall").expect("built-in");
    let pose = Pose::new(3.0, 4.0, 0.4, 0.0);
    let sensors = [
        "radar_thesis",
        "radar_thesis_n100",
        "hokuyo_utm30lx",
        "ground_truth",
    ];
    bench_scans(c, "foliage-wall", &s.world, pose, &sensors);
}

/// The peers benchmark's rays (`radarnav bench --export`): 20 random free poses × 360 level
/// rays at 0.4 m, 80 m range, as a laser (first hit) and as the 3 dB thesis radar.
fn forests(c: &mut Criterion) {
    for (count, side) in [(1_000, 63.25), (10_000, 200.0), (100_000, 632.5)] {
        let spec = ForestSpec {
            count,
            side,
            radius: (0.3, 1.0),
            clearing: 0.0,
            seed: 1,
        };
        let (world, rays) = forest_scene(&spec, 20, 360, 0.4);
        let mut g = c.benchmark_group(format!("forest-{count}"));
        g.throughput(Throughput::Elements(rays.len() as u64));
        for (name, band, budget) in [("laser", Band::Laser, 0.0), ("radar", Band::Radar, 3.0)] {
            let mut tracer = Tracer::default();
            g.bench_function(name, |b| {
                b.iter(|| {
                    rays.iter()
                        .map(|r| tracer.trace(&world, r, band, budget, 80.0).range)
                        .sum::<f64>()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, scans, forests);
criterion_main!(benches);
