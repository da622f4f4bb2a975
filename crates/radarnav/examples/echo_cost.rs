//! The cost of the radar's echo return modes against its thesis scan (DESIGN §7.3; target:
//! an `all` scan at most 2× a thesis scan), measured the way this shared machine allows:
//! blocks of 200 scans of each mode in turn, 60 rounds, and the median of each round's ratio,
//! so that the machine's drifting speed cancels out.
//!
//! `cargo run --release -p radarnav --example echo_cost` prints the medians;
//! `... --example echo_cost -- all [N]` (or `first`, `thesis`) scans N times (default
//! 100 000) in one mode, for a profiler or an instruction counter.

use radarnav::sensor::{ReturnMode, Tracer, preset};
use radarnav::{Pose, Scenario};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let s = Scenario::builtin("foliage-wall").expect("built-in");
    let pose = Pose::new(3.0, 4.0, 0.4, 0.0);
    let thesis = preset("radar_thesis").expect("preset");
    let mut all = thesis.clone();
    all.signal.return_mode = ReturnMode::All;
    let mut first = thesis.clone();
    first.signal.return_mode = ReturnMode::First;
    let modes = [("thesis", &thesis), ("all", &all), ("first", &first)];
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut tracer = Tracer::default();
    if let Some(name) = std::env::args().nth(1) {
        let Some((_, c)) = modes.iter().find(|(n, _)| *n == name) else {
            eprintln!("unknown mode {name}: thesis, all or first");
            std::process::exit(2);
        };
        let count = match std::env::args().nth(2).map(|n| n.parse::<usize>()) {
            None => 100_000,
            Some(Ok(n)) => n,
            Some(Err(e)) => {
                eprintln!("scan count: {e}");
                std::process::exit(2);
            }
        };
        for _ in 0..count {
            black_box(c.scan(&s.world, &pose, 0.0, &mut rng, &mut tracer));
        }
        return;
    }
    const SCANS: usize = 200;
    let mut times = vec![Vec::new(); modes.len()];
    let mut ratios = vec![Vec::new(); modes.len()];
    for _ in 0..60 {
        let mut t = [0.0; 3];
        for (i, (_, c)) in modes.iter().enumerate() {
            let t0 = Instant::now();
            for _ in 0..SCANS {
                black_box(c.scan(&s.world, &pose, 0.0, &mut rng, &mut tracer));
            }
            t[i] = t0.elapsed().as_secs_f64() / SCANS as f64 * 1e6;
            times[i].push(t[i]);
            ratios[i].push(t[i] / t[0]);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!("radar_thesis on foliage-wall, 360 azimuths (medians of 60 rounds of {SCANS} scans)");
    for (i, (name, _)) in modes.iter().enumerate() {
        println!(
            "{name:>7}: {:6.1} µs a scan, {:.2}× the thesis scan",
            median(&mut times[i]),
            median(&mut ratios[i])
        );
    }
}
