//! Exploration experiments (DESIGN §6): one strategy, one sensor, one seed per run, scored by
//! the coverage of the free and the hidden area against distance travelled. The CLI's
//! `compare` runs the grid of combinations in parallel.

use std::sync::Arc;

use thiserror::Error;

use crate::Scenario;
use crate::map::PoseSource;
use crate::map::{CoverageSample, MapConfig, MapError, Mapper, Truth};
use crate::mission::{DEFAULT_CONTROLLER_HZ, Mission, MissionError, MissionKind};
use crate::nav::{BumperConfig, ExploreMission, Side, Strategy};
use crate::setup::Robot;
use crate::sim::{RunSettings, RunSummary, SimError, Simulation};

/// How often an exploration run samples its coverage, s.
pub const COVERAGE_PERIOD: f64 = 1.0;

/// One exploration run to make.
#[derive(Clone, Debug, PartialEq)]
pub struct ExploreJob {
    /// Strategy.
    pub strategy: Strategy,
    /// The one sensor the robot keeps (bumpers and map use it).
    pub sensor: String,
    /// Seed of the run.
    pub seed: u64,
}

/// What an exploration run did.
#[derive(Clone, Debug)]
pub struct ExploreResult {
    /// The job.
    pub job: ExploreJob,
    /// The run's summary.
    pub summary: RunSummary,
    /// Coverage of the sensor's map against time and distance, every [`COVERAGE_PERIOD`] and
    /// at the end.
    pub coverage: Vec<CoverageSample>,
}

/// An exploration run that cannot be made.
#[derive(Debug, Error)]
pub enum ExploreError {
    /// No such robot.
    #[error("scenario `{0}` has no robot `{1}`")]
    NoRobot(String, String),
    /// No such sensor on the robot.
    #[error("robot `{robot}` has no sensor `{sensor}`; sensors: {known}")]
    NoSensor {
        /// Robot.
        robot: String,
        /// Sensor asked for.
        sensor: String,
        /// Its sensors.
        known: String,
    },
    /// The mission.
    #[error(transparent)]
    Mission(#[from] MissionError),
    /// The simulation.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The map.
    #[error(transparent)]
    Map(#[from] MapError),
}

/// `robot` of `scenario` with only its sensor `sensor`.
pub fn robot_with_sensor(
    scenario: &Scenario,
    robot: Option<&str>,
    sensor: &str,
) -> Result<Robot, ExploreError> {
    let r = scenario.robot(robot).ok_or_else(|| {
        ExploreError::NoRobot(scenario.name.clone(), robot.unwrap_or("(first)").to_owned())
    })?;
    let mut r = r.clone();
    if r.sensor(sensor).is_none() {
        return Err(ExploreError::NoSensor {
            robot: r.name.clone(),
            sensor: sensor.to_owned(),
            known: r
                .sensors
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    r.sensors.retain(|s| s.name == sensor);
    // The experiments steer on the odometry: no localiser (its sensor index would be stale).
    r.slam = None;
    Ok(r)
}

/// Runs `job` on `scenario` (its robot `robot`, the first by default) for at most
/// `duration` seconds (default: the scenario's), with `bumpers` (their sensor is the job's).
/// `truth` is the scoring raster for the sensor's scan plane at the default map resolution
/// (see [`Truth::of_world`]); share it between runs.
pub fn explore(
    scenario: &Scenario,
    robot: Option<&str>,
    job: &ExploreJob,
    duration: Option<f64>,
    bumpers: &BumperConfig,
    truth: Arc<Truth>,
) -> Result<ExploreResult, ExploreError> {
    let mut robot = robot_with_sensor(scenario, robot, &job.sensor)?;
    // The one sensor feeds the bumpers: a radar reads its first echoes, as in a scenario's
    // own exploration mission.
    if let Some(s) = robot.sensors.first_mut() {
        crate::nav::read_first_echoes(&mut s.config);
    }
    let mission = Mission {
        robot: Some(robot.name.clone()),
        controller_hz: DEFAULT_CONTROLLER_HZ,
        kind: MissionKind::Explore(ExploreMission {
            strategy: job.strategy,
            speed: 0.4,
            follow: Side::Left,
            pose: PoseSource::Odometry,
            bumpers: BumperConfig {
                sensor: None,
                ..bumpers.clone()
            },
        }),
    };
    let settings = RunSettings {
        seed: job.seed,
        duration: duration.unwrap_or(scenario.sim.duration),
        ..RunSettings::of(scenario)
    };
    let mut mapper = Mapper::new(&job.sensor, &robot, &[&job.sensor], MapConfig::default())?;
    mapper.track_coverage(truth, COVERAGE_PERIOD);
    let mut sim = Simulation::new(
        &scenario.world,
        &robot,
        mission.controller(job.seed)?,
        settings,
    )?;
    let Ok(summary) = sim.run(&mut mapper);
    mapper.finish_coverage(summary.duration);
    Ok(ExploreResult {
        job: job.clone(),
        summary,
        coverage: mapper.coverage().to_vec(),
    })
}

/// The coverage reached after driving `distance` metres: the first sample at or past it
/// (`None` if the run never drove that far or the value is undefined).
pub fn coverage_at(samples: &[CoverageSample], distance: f64, hidden: bool) -> Option<f64> {
    samples
        .iter()
        .find(|s| s.distance >= distance)
        .and_then(|s| if hidden { s.hidden } else { s.free })
}
