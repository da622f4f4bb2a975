//! Scan throughput: radar (thesis model) and laser on the thesis map and on a forest of
//! 10 000 foliage spheres. Reported as rays per second on one thread.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radarnav::sensor::{SensorConfig, Tracer, preset};
use radarnav::world::forest::forest;
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
    // 10 000 spheres over 300 × 300 m: about one per 9 m².
    let f = forest(10_000, 300.0, 7);
    bench_scans(c, "forest-10k", &f, Pose::new(0.0, 0.0, 0.4, 0.0), &sensors);
}

criterion_group!(benches, scans);
criterion_main!(benches);
