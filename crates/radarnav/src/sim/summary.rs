//! What a run did, as written to `summary.json`.

use serde::Serialize;

use super::{Ending, Simulation};
use crate::pose::{Pose, wrap_angle};
use crate::slam::SlamStats;

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunOutcome {
    /// The controller said the mission was done.
    Completed,
    /// The navigation goal was reached.
    Reached,
    /// The controller found that no path leads to the goal.
    NoPath,
    /// Time ran out first.
    Timeout,
    /// Stopped by the user (Ctrl-C, SIGTERM) at the end of a step.
    Interrupted,
}

impl RunOutcome {
    /// The name written in `summary.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Completed => "completed",
            Self::Reached => "reached",
            Self::NoPath => "no_path",
            Self::Timeout => "timeout",
            Self::Interrupted => "interrupted",
        }
    }
}

impl From<Ending> for RunOutcome {
    fn from(e: Ending) -> Self {
        match e {
            Ending::Completed => Self::Completed,
            Ending::Reached => Self::Reached,
            Ending::NoPath => Self::NoPath,
        }
    }
}

/// A refused move.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BumpEvent {
    /// Time of the step, s.
    pub time: f64,
    /// What the robot would have hit.
    pub object: String,
}

/// Scans taken by one sensor.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorCount {
    /// Sensor name.
    pub name: String,
    /// Preset it was built from.
    pub preset: Option<String>,
    /// Configured rate, Hz.
    pub rate_hz: f64,
    /// Scans taken.
    pub scans: u64,
}

/// The localiser's part of a run's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SlamSummary {
    /// The registered sensor.
    pub sensor: String,
    /// Its estimate of the robot pose at the end.
    pub final_pose: Pose,
    /// Distance between it and the truth, m.
    pub error: f64,
    /// Heading difference, degrees.
    pub yaw_error_deg: f64,
    /// Registrations, refusals, keyframes.
    #[serde(flatten)]
    pub stats: SlamStats,
}

/// Summary of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunSummary {
    /// Robot name.
    pub robot: String,
    /// Vehicle preset.
    pub vehicle: String,
    /// Seed of the run.
    pub seed: u64,
    /// Step, s.
    pub dt: f64,
    /// Simulated time, s.
    pub duration: f64,
    /// Steps taken.
    pub steps: u64,
    /// How it ended.
    pub outcome: RunOutcome,
    /// Distance driven (true), m.
    pub distance: f64,
    /// Distance according to the odometry, m.
    pub odometry_distance: f64,
    /// True pose at the end.
    pub final_pose: Pose,
    /// Odometry estimate at the end.
    pub final_odometry: Pose,
    /// Distance between the two, m.
    pub odometry_error: f64,
    /// Heading difference between the two, degrees.
    pub odometry_yaw_error_deg: f64,
    /// The localiser's estimate at the end, and what it did (absent when the robot runs no
    /// localiser).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slam: Option<SlamSummary>,
    /// Number of refused moves.
    pub bumps: usize,
    /// Refused moves: the first [`super::MAX_BUMP_EVENTS`].
    pub bump_events: Vec<BumpEvent>,
    /// Scans per sensor.
    pub sensors: Vec<SensorCount>,
    /// What the controller reports of its mission (Bug: goal, hit and leave points, ...).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub navigation: Option<serde_json::Value>,
}

impl RunSummary {
    pub(super) fn new(sim: &Simulation<'_>) -> Self {
        let truth = sim.truth;
        let odo = sim.odometry.pose;
        Self {
            robot: sim.robot.name.clone(),
            vehicle: sim.robot.vehicle.name.to_owned(),
            seed: sim.settings.seed,
            dt: sim.settings.dt,
            duration: sim.time(),
            steps: sim.tick,
            outcome: if sim.interrupted {
                RunOutcome::Interrupted
            } else {
                sim.ending.map_or(RunOutcome::Timeout, RunOutcome::from)
            },
            distance: sim.distance,
            odometry_distance: sim.odometry.distance,
            final_pose: truth,
            final_odometry: odo,
            odometry_error: (truth.position() - odo.position()).length(),
            odometry_yaw_error_deg: wrap_angle(odo.yaw - truth.yaw).to_degrees(),
            slam: sim.slam.as_ref().map(|l| {
                let p = l.estimate(&odo);
                SlamSummary {
                    sensor: sim.robot.sensors[l.config().sensor].name.clone(),
                    final_pose: p,
                    error: (truth.xy() - p.xy()).length(),
                    yaw_error_deg: wrap_angle(p.yaw - truth.yaw).to_degrees(),
                    stats: l.stats(),
                }
            }),
            bumps: sim.bump_count,
            bump_events: sim.bumps.clone(),
            sensors: sim
                .robot
                .sensors
                .iter()
                .zip(&sim.next_scan)
                .map(|(s, &n)| SensorCount {
                    name: s.name.clone(),
                    preset: s.config.preset.clone(),
                    rate_hz: s.config.rate_hz,
                    scans: n,
                })
                .collect(),
            navigation: sim.controller.report(),
        }
    }
}
