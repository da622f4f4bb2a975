//! Whole-scenario navigation tests: the Bug scenarios of the thesis' figures 13 and 14 with
//! both algorithms, both sensors and several seeds; Bug1 against Bug2 on the spiral; the
//! foliage-gap demo map; exploration in foliage without touching it.

use radarnav::Scenario;
use radarnav::mission::MissionKind;
use radarnav::nav::{BugAlgorithm, BugReport};
use radarnav::scenario::Robot;
use radarnav::sim::{NoObserver, RunOutcome, RunSettings, RunSummary, Simulation};
use rayon::prelude::*;

/// Runs the built-in `name` with its Bug mission switched to `algorithm`, the robot keeping
/// only `sensor` (which then feeds the bumpers), at `seed`.
fn run_bug(name: &str, algorithm: BugAlgorithm, sensor: &str, seed: u64) -> RunSummary {
    let s = Scenario::builtin(name).expect("built-in scenario");
    let mut mission = s.mission.clone().expect("mission");
    let MissionKind::Bug(bug) = &mut mission.kind else {
        panic!("{name}: not a bug mission");
    };
    bug.algorithm = algorithm;
    bug.bumpers.sensor = None;
    let mut robot: Robot = s.robots[0].clone();
    robot.sensors.retain(|m| m.name == sensor);
    assert_eq!(robot.sensors.len(), 1, "{name} has a `{sensor}`");
    let settings = RunSettings {
        seed,
        ..RunSettings::of(&s)
    };
    let mut sim = Simulation::new(
        &s.world,
        &robot,
        mission.controller(seed).expect("controller"),
        settings,
    )
    .expect("simulation");
    let Ok(summary) = sim.run(&mut NoObserver);
    summary
}

fn report(s: &RunSummary) -> BugReport {
    let v = s.navigation.clone().expect("navigation report");
    BugReport {
        hit_points: serde_json::from_value(v["hit_points"].clone()).expect("hit points"),
        leave_points: serde_json::from_value(v["leave_points"].clone()).expect("leave points"),
        mline_crossings: v["mline_crossings"].as_u64().expect("crossings") as usize,
        reason: v["reason"].as_str().unwrap_or_default().to_owned(),
        ..BugReport::default()
    }
}

#[test]
fn figure_13_and_14_scenarios_give_their_outcomes_with_both_algorithms_and_sensors() {
    let cases = [
        ("bug1-path", RunOutcome::Reached),
        ("bug2-path", RunOutcome::Reached),
        ("bug1-enclosed", RunOutcome::NoPath),
        ("bug2-enclosed", RunOutcome::NoPath),
    ];
    let mut jobs = Vec::new();
    for (name, want) in cases {
        for algorithm in [BugAlgorithm::Bug1, BugAlgorithm::Bug2] {
            for sensor in ["radar", "laser"] {
                for seed in 1..=3 {
                    jobs.push((name, want, algorithm, sensor, seed));
                }
            }
        }
    }
    let failures: Vec<String> = jobs
        .par_iter()
        .filter_map(|&(name, want, algorithm, sensor, seed)| {
            let s = run_bug(name, algorithm, sensor, seed);
            let r = report(&s);
            let ok = s.outcome == want
                && s.bumps == 0
                && !r.hit_points.is_empty()
                && (want != RunOutcome::Reached || !r.leave_points.is_empty());
            (!ok).then(|| {
                format!(
                    "{name} {} {sensor} seed {seed}: {:?} after {:.1} m, {} bumps, {} hits, {} leaves ({})",
                    algorithm.as_str(),
                    s.outcome,
                    s.distance,
                    s.bumps,
                    r.hit_points.len(),
                    r.leave_points.len(),
                    r.reason
                )
            })
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn on_the_spiral_bug2_crosses_the_m_line_many_times_and_travels_farther_than_bug1() {
    let b1 = run_bug("bug-spiral", BugAlgorithm::Bug1, "radar", 1);
    let b2 = run_bug("bug-spiral", BugAlgorithm::Bug2, "radar", 1);
    assert_eq!((b1.outcome, b2.outcome), (RunOutcome::Reached, RunOutcome::Reached));
    assert_eq!((b1.bumps, b2.bumps), (0, 0));
    let (r1, r2) = (report(&b1), report(&b2));
    assert!(r2.mline_crossings >= 3, "bug2 crossed {} times", r2.mline_crossings);
    assert!(r2.hit_points.len() >= 2, "bug2 met the spiral {} times", r2.hit_points.len());
    assert_eq!(r1.hit_points.len(), 1);
    assert!(
        b1.distance * 1.5 < b2.distance,
        "bug1 {:.1} m, bug2 {:.1} m",
        b1.distance,
        b2.distance
    );
}

#[test]
fn both_bugs_reach_the_goal_behind_the_foliage_hedge_with_the_radar() {
    for algorithm in [BugAlgorithm::Bug1, BugAlgorithm::Bug2] {
        for seed in 1..=2 {
            let s = run_bug("foliage-gap", algorithm, "radar", seed);
            assert_eq!(s.outcome, RunOutcome::Reached, "{} seed {seed}", algorithm.as_str());
            assert_eq!(s.bumps, 0, "{} seed {seed}", algorithm.as_str());
        }
    }
}
