//! A recorded run (what `radarnav run` does, callable from Rust and Python): a scenario's
//! mission, or a teleop file, driven through the simulation loop with maps, recordings and
//! scores written to an output directory.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use thiserror::Error;

use crate::limits::budget::{self, Budget, BudgetError, Recording};
use crate::map::{MapConfig, MapError, Mapper, PoseSource, track_coverage};
use crate::mission::{MissionError, MissionKind, TeleopSource, parse_teleop_csv};
use crate::nav::{Idle, TeleopController};
use crate::record::{RecordError, RecordOptions, Recorded, Recorder};
use crate::setup::{Robot, Scenario};
use crate::sim::{
    Controller, Observer, RunSettings, RunSummary, ScanEvent, SimError, Simulation, Step,
};
use crate::slam::SlamConfig;

/// A run that cannot be made or finished.
#[derive(Debug, Error)]
pub enum RunError {
    /// A request that does not fit the scenario (no such robot, a map asked for twice).
    #[error("{0}")]
    Request(String),
    /// A sensor to add that cannot be added.
    #[error("add sensor `{name}`: {why}")]
    AddSensor {
        /// The preset asked for.
        name: String,
        /// Why not.
        why: String,
    },
    /// The localiser's sensor is not on the robot.
    #[error("slam sensor `{name}`: robot `{robot}` has no such sensor; it has: {known}, or `none`")]
    SlamSensor {
        /// The sensor asked for.
        name: String,
        /// The robot.
        robot: String,
        /// Its sensors, comma-separated.
        known: String,
    },
    /// A teleop file that cannot be read.
    #[error("reading teleop file {path}: {cause}")]
    Teleop {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: std::io::Error,
    },
    /// The mission.
    #[error(transparent)]
    Mission(#[from] MissionError),
    /// The simulation.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The memory or output budget.
    #[error(transparent)]
    Budget(#[from] BudgetError),
    /// A map.
    #[error(transparent)]
    Map(#[from] MapError),
    /// Writing the outputs.
    #[error(transparent)]
    Record(#[from] RecordError),
}

/// Which robot runs, and what drives it.
pub struct Plan<'a> {
    /// The robot (as the scenario has it).
    pub robot: &'a Robot,
    /// What drives it.
    pub controller: Box<dyn Controller>,
    /// The mission's one-word name.
    pub mission: &'static str,
}

/// The scenario's robot `name` (default: the first), or an error naming what is missing.
pub fn robot_of<'s>(s: &'s Scenario, name: Option<&str>) -> Result<&'s Robot, RunError> {
    s.robot(name).ok_or_else(|| {
        RunError::Request(match name {
            Some(n) => format!("scenario `{}` has no robot `{n}`", s.name),
            None => format!("scenario `{}` has no robot", s.name),
        })
    })
}

/// The robot and controller of a run: `teleop` (a CSV file) wins over the scenario's
/// mission; a teleop file named in the scenario is read relative to `base` (the scenario's
/// folder); `repeat` makes a waypoint mission loop (benchmarks).
pub fn plan<'a>(
    s: &'a Scenario,
    robot: Option<&str>,
    teleop: Option<&Path>,
    base: Option<&Path>,
    repeat: bool,
    seed: u64,
) -> Result<Plan<'a>, RunError> {
    let mission_robot = s.mission.as_ref().and_then(|m| m.robot.as_deref());
    let r = robot_of(s, robot.or(mission_robot))?;
    let read_csv = |path: &Path| -> Result<Box<dyn Controller>, RunError> {
        let src = crate::limits::read_text(path).map_err(|e| RunError::Teleop {
            path: path.to_owned(),
            cause: e,
        })?;
        let steps = parse_teleop_csv(&src, &path.display().to_string())?;
        let hz = s
            .mission
            .as_ref()
            .map_or(crate::mission::DEFAULT_CONTROLLER_HZ, |m| m.controller_hz);
        Ok(Box::new(TeleopController::new(steps, hz)))
    };
    if let Some(path) = teleop {
        return Ok(Plan {
            robot: r,
            controller: read_csv(path)?,
            mission: "teleop",
        });
    }
    let Some(m) = &s.mission else {
        return Ok(Plan {
            robot: r,
            controller: Box::new(Idle { rate_hz: 10.0 }),
            mission: "none (standing still)",
        });
    };
    if robot.is_some_and(|n| mission_robot.is_some_and(|mr| mr != n)) {
        return Err(RunError::Request(format!(
            "the scenario's mission is for robot `{}`; name no robot or drive it by teleop",
            mission_robot.unwrap_or_default()
        )));
    }
    let controller = match &m.kind {
        MissionKind::Teleop(TeleopSource::File(f)) => {
            let path = base.map_or_else(|| Path::new(f).to_owned(), |b| b.join(f));
            read_csv(&path)?
        }
        MissionKind::Waypoints(w) if repeat => {
            let mut m = m.clone();
            m.kind = MissionKind::Waypoints(crate::mission::WaypointMission {
                repeat: true,
                ..w.clone()
            });
            m.controller(seed)?
        }
        _ => m.controller(seed)?,
    };
    Ok(Plan {
        robot: r,
        controller,
        mission: m.kind_name(),
    })
}

/// The plan's robot for a batch run (sweeps, benchmarks): its localiser kept only where the
/// scenario's mission steers on it, so runs spend no time on estimates nobody reads.
pub fn batch_robot(plan: &Plan<'_>, s: &Scenario) -> Robot {
    let mut robot = plan.robot.clone();
    if s.mission.as_ref().and_then(|m| m.pose()) != Some(PoseSource::Slam) {
        robot.slam = None;
    }
    robot
}

/// `robot` with the presets `names` added (see [`Robot::with_preset_mount`]).
pub fn with_sensors(robot: &Robot, names: &[String]) -> Result<Robot, RunError> {
    let mut r = robot.clone();
    for name in names {
        if r.sensor(name).is_some() {
            return Err(RunError::AddSensor {
                name: name.clone(),
                why: format!("robot `{}` already has a sensor of that name", r.name),
            });
        }
        let s = robot
            .with_preset_mount(name)
            .ok_or_else(|| RunError::AddSensor {
                name: name.clone(),
                why: "not a preset (see `radarnav presets`)".into(),
            })?;
        r.sensors.push(s);
    }
    Ok(r)
}

/// What a recorded run is asked to do.
pub struct RunRequest<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// The scenario file's folder (teleop files it names are read from there).
    pub base: Option<&'a Path>,
    /// Output directory.
    pub out: &'a Path,
    /// The robot (default: the mission's, else the first).
    pub robot: Option<&'a str>,
    /// A teleop CSV that drives the robot instead of the mission.
    pub teleop: Option<&'a Path>,
    /// Seed (default: the scenario's).
    pub seed: Option<u64>,
    /// Longest simulated time, s (default: the scenario's).
    pub duration: Option<f64>,
    /// Write `run.mcap`.
    pub mcap: bool,
    /// Write the rosbag2 recording.
    pub ros2_bag: bool,
    /// Figure size, px.
    pub pixels: u32,
    /// Map specs (`None`: no maps; empty: one per sensor).
    pub maps: Option<&'a [String]>,
    /// The pose maps are built on: `truth`, `odometry` or `slam`.
    pub map_pose: PoseSource,
    /// Map cell size, m.
    pub map_resolution: f64,
    /// Free-space reach of a ray with no return, m.
    pub map_max_free_range: f64,
    /// Presets to mount on the robot besides its own sensors.
    pub add_sensors: &'a [String],
    /// The localiser's sensor instead of the scenario's (`none`: no localiser).
    pub slam_sensor: Option<&'a str>,
    /// Memory and output limits.
    pub budget: Budget,
    /// Set by a signal: the run ends at the end of the step and its files are finished.
    pub stop: &'a AtomicBool,
}

/// What a recorded run did.
pub struct RunReport {
    /// The run's summary.
    pub summary: RunSummary,
    /// What was written and scored.
    pub recorded: Recorded,
    /// The mission's one-word name.
    pub mission: &'static str,
    /// Wall-clock seconds of the simulation (files and scores not counted).
    pub wall_seconds: f64,
    /// Whether `stop` cut it short (its files are whole all the same).
    pub interrupted: bool,
}

/// The scenario's run settings with `seed` and `duration` applied.
pub fn settings(s: &Scenario, seed: Option<u64>, duration: Option<f64>) -> RunSettings {
    let base = RunSettings::of(s);
    RunSettings {
        seed: seed.unwrap_or(base.seed),
        duration: duration.unwrap_or(base.duration),
        ..base
    }
}

/// The mappers of a run, each kept to the region its sensors can reach, and their cells
/// in all (checked against the memory budget).
fn mappers(r: &RunRequest<'_>, robot: &Robot) -> Result<(Vec<Mapper>, f64), RunError> {
    let Some(specs) = r.maps else {
        return Ok((Vec::new(), 0.0));
    };
    let config = MapConfig {
        resolution: r.map_resolution,
        max_free_range: r.map_max_free_range,
        pose: r.map_pose,
        ..MapConfig::default()
    };
    let region = budget::map_region(
        &r.scenario.world,
        robot,
        config.max_free_range,
        config.max_range,
    );
    let specs: Vec<String> = if specs.is_empty() {
        robot.sensors.iter().map(|s| s.name.clone()).collect()
    } else {
        specs.to_vec()
    };
    let maps = specs
        .iter()
        .map(|spec| {
            let mut m = Mapper::from_spec(spec, robot, config)?;
            m.limit_to(region);
            Ok(m)
        })
        .collect::<Result<Vec<_>, RunError>>()?;
    let mut names: Vec<&str> = maps.iter().map(Mapper::name).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(RunError::Request(format!(
            "`maps` names the map `{}` twice",
            w[0]
        )));
    }
    let cells = r
        .budget
        .check_maps(maps.iter().map(Mapper::name), region, config.resolution)?;
    Ok((maps, cells))
}

/// What a recorded run reports as it goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Progress {
    /// Step `.0` of at most `.1` is done.
    Step(u64, u64),
    /// The simulation is over (`interrupted`: cut short at `time` s); maps are being scored
    /// and files written.
    Finishing {
        /// Whether a stop request ended it.
        interrupted: bool,
        /// Simulated time at the end, s.
        time: f64,
    },
}

/// Forwards to an inner observer and reports each step.
struct WithProgress<'a, O: ?Sized> {
    inner: &'a mut O,
    progress: &'a mut dyn FnMut(Progress),
    step: u64,
    total: u64,
}

impl<O: Observer + ?Sized> Observer for WithProgress<'_, O> {
    type Error = O::Error;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), O::Error> {
        self.inner.on_scan(event)
    }
    fn on_step(&mut self, step: &Step) -> Result<(), O::Error> {
        self.step += 1;
        (self.progress)(Progress::Step(self.step, self.total));
        self.inner.on_step(step)
    }
}

/// Runs `sim` to its end (or until `stop` is set), reporting each step to `progress`;
/// returns the summary and wall seconds.
pub fn drive<O: Observer + ?Sized>(
    sim: &mut Simulation<'_>,
    observer: &mut O,
    stop: &AtomicBool,
    progress: &mut dyn FnMut(Progress),
) -> Result<(RunSummary, f64), O::Error> {
    let t0 = Instant::now();
    let total = sim.total_steps();
    let summary = sim.run_until(
        &mut WithProgress {
            inner: observer,
            progress,
            step: 0,
            total,
        },
        stop,
    )?;
    Ok((summary, t0.elapsed().as_secs_f64()))
}

/// Makes the run `r` asks for: its files go to `r.out` (each whole or not at all);
/// `progress` hears of each step and of the end.
pub fn record_run(
    r: &RunRequest<'_>,
    progress: &mut dyn FnMut(Progress),
) -> Result<RunReport, RunError> {
    let s = r.scenario;
    let settings = settings(s, r.seed, r.duration);
    let plan = plan(s, r.robot, r.teleop, r.base, false, settings.seed)?;
    let mut robot = with_sensors(plan.robot, r.add_sensors)?;
    match r.slam_sensor {
        None => {}
        Some("none") => robot.slam = None,
        Some(name) => {
            let i = (robot.sensors.iter().position(|s| s.name == name)).ok_or_else(|| {
                RunError::SlamSensor {
                    name: name.to_owned(),
                    robot: robot.name.clone(),
                    known: (robot.sensors.iter())
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                }
            })?;
            let c = robot.slam.unwrap_or(SlamConfig::for_sensor(i));
            robot.slam = Some(SlamConfig { sensor: i, ..c });
        }
    }
    let (mut maps, map_cells) = mappers(r, &robot)?;
    let need = budget::run_output(
        &robot,
        &Recording {
            dt: settings.dt,
            duration: settings.duration,
            mcap: r.mcap,
            ros2_bag: r.ros2_bag,
            scans: true,
            map_cells,
        },
    );
    let what = format!(
        "a run of {} s in steps of {} s",
        settings.duration, settings.dt
    );
    r.budget.check_output(&what, need)?;
    r.budget.check_memory(
        &what,
        budget::path_memory(&s.world, &robot, settings.duration),
    )?;
    if plan.mission == "explore" {
        track_coverage(
            &s.world,
            robot.vehicle,
            &robot.start,
            &mut maps,
            crate::compare::COVERAGE_PERIOD,
        );
    }
    let mut sim = Simulation::new(&s.world, &robot, plan.controller, settings)?;
    let options = RecordOptions {
        mcap: r.mcap,
        ros2_bag: r.ros2_bag,
        ..RecordOptions::default()
    };
    let mut rec = Recorder::create(r.out, &s.world, &robot, options)?
        .with_maps(maps)?
        .with_radar_images(&s.world, &robot, settings.seed)?;
    let (summary, wall_seconds) = drive(&mut sim, &mut rec, r.stop, progress)?;
    progress(Progress::Finishing {
        interrupted: sim.interrupted(),
        time: summary.duration,
    });
    let recorded = rec.finish(s, &robot, &summary, r.pixels)?;
    Ok(RunReport {
        summary,
        recorded,
        mission: plan.mission,
        wall_seconds,
        interrupted: sim.interrupted(),
    })
}
