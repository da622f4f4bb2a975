//! Navigation trials (DESIGN §6): Bug missions on maps nobody tuned the navigation to, each
//! run judged against what the map's geometry implies.
//!
//! A trial map is any scenario with a Bug mission (its goal, tolerance and bumpers; the
//! algorithm is set per run). Each run keeps one sensor of the robot (its first radar or its
//! first laser; a preset `radar_thesis` or `hokuyo_utm30lx` mounted like its first sensor
//! when it has none), navigates on the true pose or on odometry, with a seed. A run
//! **passes** when
//! * its outcome is the one the geometry implies ([`geometry::expect`]): `reached` when the
//!   robot's disc fits from start to goal, else `no_path` (no timeout);
//! * it never bumped;
//! * its true path length keeps the classic bound of its algorithm, summed over its standoff
//!   retries, each taken at its own standoff and at the standoff floor (the larger counts: a
//!   way narrower than twice the standoff is closed by the grown obstacles, yet the follower
//!   drives its middle).
//!
//! Runs last as long as the scenario says, or longer when the bounds need it: three times the
//! first attempt's bound at cruise speed for it, for each standoff retry the bumpers allow and for
//! the retry on the other side at the floor, twice over (Bug2 may follow each with a retry
//! from a hit point the other way round), plus a minute. A timeout means the robot was
//! lost, not slow.

pub mod geometry;

use glam::DVec2;
use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::Scenario;
use crate::map::PoseSource;
use crate::mission::{Mission, MissionError, MissionKind};
use crate::nav::bug::{retry_safety, safety_floor};
use crate::nav::{BugAlgorithm, BugMission, BumperSensor, read_first_echoes};
use crate::record::PathTrace;
use crate::render::RenderError;
use crate::sensor::SensorKind;
use crate::setup::{MountedSensor, Robot};
use crate::sim::{RunOutcome, RunSettings, SimError, Simulation};
use crate::slam::SlamConfig;
pub use geometry::{Expectation, SensorClass, TrialGeometry};

/// Why a trial cannot run.
#[derive(Debug, Error)]
pub enum TrialError {
    /// The scenario has no Bug mission.
    #[error("scenario `{0}` has no bug1 or bug2 mission: a trial map needs a goal")]
    NotBug(String),
    /// The mission names a robot the scenario lacks.
    #[error("scenario `{0}`: the mission's robot is missing")]
    NoRobot(String),
    /// The mission.
    #[error(transparent)]
    Mission(#[from] MissionError),
    /// The simulation.
    #[error("scenario `{0}`: {1}")]
    Sim(String, SimError),
    /// The map is too large to rasterise for its expected outcome and bounds.
    #[error("scenario `{0}`: {1}")]
    Budget(String, crate::limits::budget::BudgetError),
}

/// One run to make on a map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct Trial {
    /// Bug1 or Bug2.
    pub algorithm: BugAlgorithm,
    /// The sensor the bumpers read.
    pub sensor: SensorClass,
    /// The pose navigation believes.
    pub pose: PoseSource,
    /// Seed.
    pub seed: u64,
}

/// Every combination of `algorithms` × `sensors` × `poses` × seeds `1..=seeds`.
pub fn grid(
    algorithms: &[BugAlgorithm],
    sensors: &[SensorClass],
    poses: &[PoseSource],
    seeds: u64,
) -> Vec<Trial> {
    let mut out = Vec::new();
    for &algorithm in algorithms {
        for &sensor in sensors {
            for &pose in poses {
                for seed in 1..=seeds {
                    out.push(Trial {
                        algorithm,
                        sensor,
                        pose,
                        seed,
                    });
                }
            }
        }
    }
    out
}

/// The whole suite's configurations: both algorithms × both sensors × both poses, seeds
/// `1..=seeds`.
pub fn full_grid(seeds: u64) -> Vec<Trial> {
    grid(
        &[BugAlgorithm::Bug1, BugAlgorithm::Bug2],
        &[SensorClass::Radar, SensorClass::Laser],
        &[PoseSource::Truth, PoseSource::Odometry],
        seeds,
    )
}

/// A map ready for trials: its scenario, its robot with one sensor of each class, and what
/// its geometry implies for each class.
pub struct TrialMap {
    /// The scenario's name.
    pub name: String,
    scenario: Scenario,
    robot: Robot,
    bug: BugMission,
    controller_hz: f64,
    sensors: [MountedSensor; 2],
    fields: [geometry::Field; 2],
    geometries: [TrialGeometry; 2],
    expectations: [Expectation; 2],
}

impl TrialMap {
    /// Prepares `scenario` (a Bug mission is required).
    pub fn new(scenario: Scenario) -> Result<Self, TrialError> {
        let Some(Mission {
            robot: robot_name,
            controller_hz,
            kind: MissionKind::Bug(bug),
        }) = scenario.mission.clone()
        else {
            return Err(TrialError::NotBug(scenario.name.clone()));
        };
        let robot = scenario
            .robot(robot_name.as_deref())
            .ok_or_else(|| TrialError::NoRobot(scenario.name.clone()))?
            .clone();
        let pick = |kind: SensorKind, preset: &str| {
            robot
                .sensors
                .iter()
                .find(|s| s.config.kind == kind)
                .cloned()
                .or_else(|| robot.with_preset_mount(preset))
                .expect("built-in preset")
        };
        let mut sensors = [
            pick(SensorKind::Radar, "radar_thesis"),
            pick(SensorKind::Laser, "hokuyo_utm30lx"),
        ];
        // Whichever sensor the scenario's bumpers named, each run's bumpers read this one.
        read_first_echoes(&mut sensors[0].config);
        let standoff = BumperSensor::new(bug.bumpers.clone()).follow_radius(robot.vehicle);
        let v = robot.vehicle;
        let geometries = [SensorClass::Radar, SensorClass::Laser].map(|class| TrialGeometry {
            start: robot.start.xy(),
            goal: bug.goal,
            tolerance: bug.tolerance,
            radius: 0.5 * v.length.hypot(v.width),
            standoff,
            height: v.height,
            plane_z: sensors[class as usize].mount.z,
        });
        // Two rasters of 5 cm cells over the world: refuse a world too large for them.
        let g = &geometries[0];
        let (lo, hi) = crate::render::world_region(&scenario.world);
        let margin = DVec2::splat(standoff + 1.0);
        let region = (
            lo.min(g.start).min(g.goal) - margin,
            hi.max(g.start).max(g.goal) + margin,
        );
        crate::limits::budget::Budget::default()
            .check_maps(["radar", "laser"], region, geometry::CELL)
            .map_err(|e| TrialError::Budget(scenario.name.clone(), e))?;
        let fields = [SensorClass::Radar, SensorClass::Laser].map(|class| {
            let g = &geometries[class as usize];
            geometry::Field::new(
                &scenario.world,
                class,
                g.height,
                g.plane_z,
                &[g.start, g.goal],
                standoff + 1.0,
            )
        });
        let expectations = [SensorClass::Radar, SensorClass::Laser]
            .map(|c| fields[c as usize].expect(&geometries[c as usize]));
        Ok(Self {
            name: scenario.name.clone(),
            scenario,
            robot,
            bug,
            controller_hz,
            sensors,
            fields,
            geometries,
            expectations,
        })
    }

    /// What the geometry implies for a robot steering by `sensor`.
    pub fn expectation(&self, sensor: SensorClass) -> &Expectation {
        &self.expectations[sensor as usize]
    }

    /// Runs `trial`.
    pub fn run(&self, trial: &Trial) -> Result<TrialResult, TrialError> {
        self.run_traced(trial).map(|(r, _)| r)
    }

    /// The figure of a run: the map, the true and believed paths, bumps and the verdict.
    pub fn figure(
        &self,
        result: &TrialResult,
        paths: &PathTrace,
    ) -> Result<tiny_skia::Pixmap, RenderError> {
        let verdict = if result.passed() {
            "passed".to_owned()
        } else {
            result
                .faults
                .iter()
                .map(|f| f.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        paths.figure(
            &self.scenario.world,
            self.robot.vehicle,
            &self.robot.start,
            &format!(
                "{} - {} [{}] {:.0} m / {:.0} m, {} bumps",
                result.label(),
                result.outcome.as_str(),
                verdict,
                result.distance,
                result.bound,
                result.bumps
            ),
            1000,
        )
    }

    /// Runs `trial`, keeping its paths for [`TrialMap::figure`].
    pub fn run_traced(&self, trial: &Trial) -> Result<(TrialResult, PathTrace), TrialError> {
        let e = self.expectation(trial.sensor);
        let pick = |e: &Expectation| match trial.algorithm {
            BugAlgorithm::Bug1 => e.bug1_bound,
            BugAlgorithm::Bug2 => e.bug2_bound,
        };
        let g = &self.geometries[trial.sensor as usize];
        let field = &self.fields[trial.sensor as usize];
        // The follower drives the middle of a way narrower than twice its standoff, where the
        // obstacles grown by the standoff close it: an attempt's boundaries are also measured
        // at the standoff floor, where such ways are open, and its bound is the larger one.
        let floor = safety_floor(self.robot.vehicle) + self.bug.bumpers.band / 2.0;
        let attempt_bound = |start: glam::DVec2, standoff: f64| {
            let at = |standoff: f64| {
                pick(&field.expect(&TrialGeometry {
                    start,
                    standoff,
                    ..*g
                }))
            };
            if standoff > floor {
                at(standoff).max(at(floor))
            } else {
                at(standoff)
            }
        };
        let first_bound = attempt_bound(g.start, g.standoff);
        let mut robot = self.robot.clone();
        robot.sensors = vec![self.sensors[trial.sensor as usize].clone()];
        // On `slam` the trial's one sensor is the localiser's too: radar SLAM for a radar
        // trial, laser SLAM for a laser one. Elsewhere none runs (it would cost time only).
        robot.slam = (trial.pose == PoseSource::Slam).then(|| {
            let c = self.robot.slam.unwrap_or(SlamConfig::for_sensor(0));
            SlamConfig { sensor: 0, ..c }
        });
        let mut bug = self.bug.clone();
        bug.algorithm = trial.algorithm;
        bug.pose = trial.pose;
        bug.bumpers.sensor = None;
        let mission = Mission {
            robot: Some(robot.name.clone()),
            controller_hz: self.controller_hz,
            kind: MissionKind::Bug(bug.clone()),
        };
        // Time for a path as long as the bounds of the first attempt, of every standoff
        // retry the bumpers allow and of the retry on the other side at the floor, each with
        // a retry from a hit point the other way round (Bug2), at a third of the cruise
        // speed. Among crates a robot that keeps its bounds averages less than half its
        // cruise speed (ways passed at half of it, turns on the spot, backing out of dead
        // ends): 0.17 m/s over 252 m round `r15106-crates`.
        let mut attempts = 2.0;
        let mut safety = bug.bumpers.safety_for(self.robot.vehicle);
        while let Some(next) = retry_safety(safety, self.robot.vehicle) {
            attempts += 1.0;
            safety = next;
        }
        attempts *= 2.0;
        let settings = RunSettings {
            seed: trial.seed,
            duration: self
                .scenario
                .sim
                .duration
                .max(3.0 * attempts * first_bound / bug.speed + 60.0),
            ..RunSettings::of(&self.scenario)
        };
        let mut sim = Simulation::new(
            &self.scenario.world,
            &robot,
            mission.controller(trial.seed)?,
            settings,
        )
        .map_err(|err| TrialError::Sim(self.name.clone(), err))?;
        let mut paths = PathTrace {
            goal: Some(bug.goal),
            ..PathTrace::default()
        };
        let Ok(summary) = sim.run(&mut paths);
        paths.end(&summary);
        // A standoff retry starts a new Bug run where it is, nearer its boundaries: the bound
        // of the whole run is the sum of each attempt's classic bound at its own standoff.
        let mut bound = first_bound;
        let retries = summary
            .navigation
            .as_ref()
            .and_then(|n| n["retries"].as_array().cloned())
            .unwrap_or_default();
        for r in &retries {
            let (Some(x), Some(y), Some(safety)) = (
                r["at"][0].as_f64(),
                r["at"][1].as_f64(),
                r["safety"].as_f64(),
            ) else {
                continue;
            };
            bound += attempt_bound(glam::DVec2::new(x, y), safety + bug.bumpers.band / 2.0);
        }
        let expected = if e.reachable {
            RunOutcome::Reached
        } else {
            RunOutcome::NoPath
        };
        let mut faults = Vec::new();
        if summary.outcome != expected {
            faults.push(if summary.outcome == RunOutcome::Timeout {
                Fault::Timeout
            } else {
                Fault::Outcome
            });
        }
        if summary.bumps > 0 {
            faults.push(Fault::Bumped);
        }
        if summary.distance > bound {
            faults.push(Fault::OverBound);
        }
        let result = TrialResult {
            map: self.name.clone(),
            trial: *trial,
            expected,
            outcome: summary.outcome,
            bumps: summary.bumps,
            distance: summary.distance,
            bound,
            attempts: 1 + retries.len(),
            dead_ends: summary
                .navigation
                .as_ref()
                .and_then(|n| n["dead_ends"].as_array().map(Vec::len))
                .unwrap_or_default(),
            time: summary.duration,
            faults,
            reason: summary
                .navigation
                .as_ref()
                .and_then(|n| n["reason"].as_str())
                .unwrap_or_default()
                .to_owned(),
        };
        Ok((result, paths))
    }
}

/// Why a run failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Fault {
    /// The other outcome than the geometry implies.
    Outcome,
    /// Time ran out.
    Timeout,
    /// A move was refused by a collision.
    Bumped,
    /// The path was longer than the bound.
    OverBound,
}

/// What one trial did.
#[derive(Clone, Debug, Serialize)]
pub struct TrialResult {
    /// Map name.
    pub map: String,
    /// The configuration.
    pub trial: Trial,
    /// The outcome the geometry implies.
    pub expected: RunOutcome,
    /// The outcome.
    pub outcome: RunOutcome,
    /// Bumps.
    pub bumps: usize,
    /// True path length, m.
    pub distance: f64,
    /// The algorithm's bound, m: summed over the attempts when the standoff was retried.
    pub bound: f64,
    /// Bug runs made: 1 plus the standoff retries, the retry on the other side and (Bug2)
    /// the retries from a hit point the other way round.
    pub attempts: usize,
    /// Dead ends the robot got stuck in and drove back out of the way it came.
    pub dead_ends: usize,
    /// Simulated time, s.
    pub time: f64,
    /// Empty when the run passed.
    pub faults: Vec<Fault>,
    /// The controller's reason for ending.
    pub reason: String,
}

impl Fault {
    /// The name written in the results.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Outcome => "outcome",
            Self::Timeout => "timeout",
            Self::Bumped => "bumped",
            Self::OverBound => "over_bound",
        }
    }
}

impl TrialResult {
    /// Whether the run passed.
    pub fn passed(&self) -> bool {
        self.faults.is_empty()
    }

    /// `map algorithm sensor pose seed N`: which run this was.
    pub fn label(&self) -> String {
        let t = &self.trial;
        format!(
            "{} {} {} {} seed {}",
            self.map,
            t.algorithm.as_str(),
            t.sensor.as_str(),
            t.pose.as_str(),
            t.seed
        )
    }
}

/// Every run as a CSV table, one row each, with a header.
pub fn results_csv(results: &[TrialResult]) -> String {
    use std::fmt::Write;
    let mut csv = String::from(
        "map,algorithm,sensor,pose,seed,expected,outcome,bumps,distance_m,bound_m,attempts,dead_ends,time_s,passed,faults,reason\n",
    );
    for r in results {
        let t = &r.trial;
        let faults: Vec<&str> = r.faults.iter().map(|f| f.as_str()).collect();
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{:.3},{:.3},{},{},{:.2},{},{},\"{}\"",
            r.map,
            t.algorithm.as_str(),
            t.sensor.as_str(),
            t.pose.as_str(),
            t.seed,
            r.expected.as_str(),
            r.outcome.as_str(),
            r.bumps,
            r.distance,
            r.bound,
            r.attempts,
            r.dead_ends,
            r.time,
            r.passed(),
            faults.join("+"),
            r.reason.replace('"', "'")
        );
    }
    csv
}

/// Runs every trial on every map, in parallel; `progress` is called after each run.
pub fn run_all(
    maps: &[TrialMap],
    trials: &[Trial],
    progress: impl Fn(&TrialMap, &TrialResult, &PathTrace) + Sync,
) -> Result<Vec<TrialResult>, TrialError> {
    let jobs: Vec<(&TrialMap, &Trial)> = maps
        .iter()
        .flat_map(|m| trials.iter().map(move |t| (m, t)))
        .collect();
    jobs.par_iter()
        .map(|(m, t)| {
            let (r, paths) = m.run_traced(t)?;
            progress(m, &r, &paths);
            Ok(r)
        })
        .collect()
}

/// The pass table: one row per algorithm × sensor × pose with runs, passes, the pass rate
/// and the count of each fault; then the failed runs.
pub fn pass_table(results: &[TrialResult]) -> String {
    use std::collections::BTreeMap;
    use std::fmt::Write;
    let mut rows: BTreeMap<(BugAlgorithm, SensorClass, PoseSource), [usize; 6]> = BTreeMap::new();
    for r in results {
        let t = &r.trial;
        let row = rows.entry((t.algorithm, t.sensor, t.pose)).or_default();
        row[0] += 1;
        row[1] += usize::from(r.passed());
        for f in &r.faults {
            row[2 + *f as usize] += 1;
        }
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| algorithm | sensor | pose | runs | passed | pass % | wrong outcome | timeout | bumped | over bound |"
    );
    let _ = writeln!(s, "|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for ((a, c, p), n) in &rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.0} | {} | {} | {} | {} |",
            a.as_str(),
            c.as_str(),
            p.as_str(),
            n[0],
            n[1],
            100.0 * n[1] as f64 / n[0].max(1) as f64,
            n[2],
            n[3],
            n[4],
            n[5]
        );
    }
    s
}

/// One line per failed run: map, configuration, what went wrong.
pub fn failures(results: &[TrialResult]) -> Vec<String> {
    let mut out: Vec<String> = results
        .iter()
        .filter(|r| !r.passed())
        .map(|r| {
            format!(
                "{}: expected {}, got {} ({}); {} bumps; {:.1} m of {:.1} m",
                r.label(),
                r.expected.as_str(),
                r.outcome.as_str(),
                r.reason,
                r.bumps,
                r.distance,
                r.bound
            )
        })
        .collect();
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_too_large_for_its_rasters_is_refused_before_they_are_made() {
        let src = "[[object]]\nmaterial = \"concrete\"\nsphere = { center = [-4900, -4900], radius = 1 }\n\
            [[object]]\nmaterial = \"concrete\"\nsphere = { center = [4900, 4900], radius = 1 }\n\
            [[robot]]\nname = \"r\"\nstart = { x = 0.0, y = 0.0 }\n[[robot.sensor]]\nname = \"radar\"\npreset = \"radar_thesis\"\n\
            [mission]\ntype = \"bug1\"\ngoal = [3, 0]\n";
        let s = Scenario::from_toml(src, "big.toml", "big").unwrap();
        let e = TrialMap::new(s).err().expect("refused");
        assert!(matches!(e, TrialError::Budget(..)), "{e}");
        assert!(e.to_string().contains("more than the limit of 1e8"), "{e}");
    }

    #[test]
    fn a_failed_run_is_one_csv_row_and_one_failure_line() {
        let r = TrialResult {
            map: "nav/x".into(),
            trial: Trial {
                algorithm: BugAlgorithm::Bug2,
                sensor: SensorClass::Laser,
                pose: PoseSource::Odometry,
                seed: 2,
            },
            expected: RunOutcome::Reached,
            outcome: RunOutcome::NoPath,
            bumps: 1,
            distance: 12.5,
            bound: 10.0,
            attempts: 3,
            dead_ends: 1,
            time: 40.0,
            faults: vec![Fault::Outcome, Fault::Bumped, Fault::OverBound],
            reason: "said \"no\"".into(),
        };
        let csv = results_csv(std::slice::from_ref(&r));
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows.len(), 2);
        assert_eq!(
            rows[1],
            "nav/x,bug2,laser,odometry,2,reached,no_path,1,12.500,10.000,3,1,40.00,false,outcome+bumped+over_bound,\"said 'no'\""
        );
        assert_eq!(rows[0].split(',').count(), rows[1].split(',').count());
        assert_eq!(
            failures(&[r]),
            [
                "nav/x bug2 laser odometry seed 2: expected reached, got no_path (said \"no\"); 1 bumps; 12.5 m of 10.0 m"
            ]
        );
    }
}
