//! Whole-simulation throughput: the foliage-wall mission (radar 360 rays at 4 Hz, UTM-30LX
//! 1081 rays at 40 Hz, 20 Hz steps) with its waypoints looping, without recording. Criterion
//! reports simulated seconds per wall second as "elements" per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radarnav::Scenario;
use radarnav::mission::MissionKind;
use radarnav::sim::{NoObserver, RunSettings, Simulation};
use std::hint::black_box;

fn simulate(c: &mut Criterion) {
    let s = Scenario::builtin("foliage-wall").expect("built-in");
    let mut mission = s.mission.clone().expect("mission");
    if let MissionKind::Waypoints(w) = &mut mission.kind {
        w.repeat = true;
    }
    let seconds = 60.0;
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    g.throughput(Throughput::Elements(seconds as u64));
    g.bench_function("foliage-wall-60s", |b| {
        b.iter(|| {
            let settings = RunSettings {
                duration: seconds,
                ..RunSettings::of(&s)
            };
            let ctl = mission.controller(0).expect("controller");
            let mut sim = Simulation::new(&s.world, &s.robots[0], ctl, settings).expect("sim");
            black_box(sim.run(&mut NoObserver).expect("infallible"))
        })
    });
    g.finish();
}

criterion_group!(benches, simulate);
criterion_main!(benches);
