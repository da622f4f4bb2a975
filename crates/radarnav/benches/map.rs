//! Mapping throughput: scans inserted per second into a 0.05 m grid, for the thesis radar
//! (360 rays) and the UTM-30LX laser (1081 rays), from poses along the foliage-wall mission.
//! The scans are taken beforehand (placed at their true poses); only the insertion (cell walks and log-odds updates) is
//! timed. Criterion reports scans per second as "elements" per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radarnav::map::{MapConfig, Mapper};
use radarnav::sim::{NoObserver, Observer, RunSettings, ScanEvent, Simulation};
use radarnav::{Scan, Scenario};
use std::hint::black_box;

/// Every scan of the mission with the pose it was taken from.
#[derive(Default)]
struct Scans(Vec<(usize, Scan)>);

impl Observer for Scans {
    type Error = std::convert::Infallible;
    fn on_scan(&mut self, e: &ScanEvent<'_>) -> Result<(), Self::Error> {
        self.0.push((e.sensor, e.scan.clone()));
        Ok(())
    }
}

fn insert(c: &mut Criterion) {
    let s = Scenario::builtin("foliage-wall").expect("built-in");
    let robot = &s.robots[0];
    let mission = s.mission.clone().expect("mission");
    let ctl = mission.controller(0).expect("controller");
    let mut sim = Simulation::new(&s.world, robot, ctl, RunSettings::of(&s)).expect("sim");
    let mut scans = Scans::default();
    sim.run(&mut (&mut scans, NoObserver)).expect("infallible");
    let mut g = c.benchmark_group("map_insert");
    g.sample_size(20);
    for sensor in ["radar", "laser"] {
        let index = robot
            .sensors
            .iter()
            .position(|m| m.name == sensor)
            .expect("sensor");
        let mine: Vec<&Scan> = scans
            .0
            .iter()
            .filter(|x| x.0 == index)
            .map(|x| &x.1)
            .collect();
        let rays = mine[0].len();
        g.throughput(Throughput::Elements(mine.len() as u64));
        g.bench_function(format!("{sensor}-{rays}-rays-0.05m"), |b| {
            b.iter(|| {
                let mut m = Mapper::from_spec(sensor, robot, MapConfig::default()).expect("map");
                for scan in &mine {
                    m.insert_scan(scan, &scan.pose);
                }
                black_box(m.grid().width())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, insert);
criterion_main!(benches);
