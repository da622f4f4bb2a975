//! The radar signal's cost (DESIGN §7): one Navtech CTS350-X power image of foliage-wall
//! (target ≤ 25 ms on one core), and a multi-echo (`all`) scan of 360 azimuths against the
//! thesis scan of the same radar (target ≤ 2×), also with the thesis' side beams, and a
//! first-echo scan.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radarnav::sensor::image::power_image;
use radarnav::sensor::{ReturnMode, Tracer, preset};
use radarnav::{Pose, Scenario};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn signal(c: &mut Criterion) {
    let s = Scenario::builtin("foliage-wall").expect("built-in");
    let pose = Pose::new(3.0, 4.0, 0.4, 0.0);
    let mut g = c.benchmark_group("signal");
    g.sample_size(20);
    let navtech = preset("navtech_cts350x").expect("preset");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut tracer = Tracer::default();
    g.bench_function("navtech_cts350x-image", |b| {
        b.iter(|| {
            black_box(power_image(
                &navtech,
                &s.world,
                0.0,
                0,
                &|_| pose,
                &mut rng,
                &mut tracer,
            ))
        })
    });
    let thesis = preset("radar_thesis").expect("preset");
    let mut all = thesis.clone();
    all.signal.return_mode = ReturnMode::All;
    let mut first = thesis.clone();
    first.signal.return_mode = ReturnMode::First;
    // The thesis' side beams in `all` mode: uniform selection walks only the drawn ray.
    let mut sides = preset("radar_thesis_n100").expect("preset");
    sides.signal.return_mode = ReturnMode::All;
    g.throughput(Throughput::Elements(thesis.azimuth_count() as u64));
    for (name, config) in [
        ("radar_thesis-thesis", &thesis),
        ("radar_thesis-all", &all),
        ("radar_thesis-first", &first),
        ("radar_thesis_n100-all", &sides),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| black_box(config.scan(&s.world, &pose, 0.0, &mut rng, &mut tracer)))
        });
    }
    g.finish();
}

criterion_group!(benches, signal);
criterion_main!(benches);
