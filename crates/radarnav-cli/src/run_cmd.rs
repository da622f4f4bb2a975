//! `radarnav run` and `radarnav bench --sim`: a scenario's mission driven through the
//! simulation loop.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use radarnav::Scenario;
use radarnav::limits::budget::{self, Budget, Recording};
use radarnav::map::{MapConfig, Mapper, PoseSource, track_coverage};
use radarnav::mission::{MissionKind, TeleopSource, parse_teleop_csv};
use radarnav::nav::{Idle, TeleopController};
use radarnav::record::{RecordOptions, Recorder};
use radarnav::scenario::Robot;
use radarnav::sim::{
    Controller, NoObserver, Observer, RunSettings, RunSummary, ScanEvent, Simulation, Step,
};
use radarnav::slam::SlamConfig;

/// What `run` and `bench --sim` share: which robot, which controller.
pub struct Plan<'a> {
    pub robot: &'a Robot,
    pub controller: Box<dyn Controller>,
    pub mission: &'static str,
}

/// The robot and controller of a run: `--teleop` wins over the scenario's mission; a teleop
/// file named in the scenario is read relative to the scenario file (`base`).
pub fn plan<'a>(
    s: &'a Scenario,
    robot: Option<&str>,
    teleop: Option<&Path>,
    base: Option<&Path>,
    repeat: bool,
    seed: u64,
) -> Result<Plan<'a>> {
    let mission_robot = s.mission.as_ref().and_then(|m| m.robot.as_deref());
    let name = robot.or(mission_robot);
    let r = robot_of(s, name)?;
    let read_csv = |path: &Path| -> Result<Box<dyn Controller>> {
        let src = radarnav::limits::read_text(path)
            .with_context(|| format!("reading teleop file {}", path.display()))?;
        let steps = parse_teleop_csv(&src, &path.display().to_string())?;
        let hz = s
            .mission
            .as_ref()
            .map_or(radarnav::mission::DEFAULT_CONTROLLER_HZ, |m| {
                m.controller_hz
            });
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
        bail!(
            "the scenario's mission is for robot `{}`; drop --robot or pass --teleop",
            mission_robot.unwrap_or_default()
        );
    }
    let controller = match &m.kind {
        MissionKind::Teleop(TeleopSource::File(f)) => {
            let path = base.map_or_else(|| Path::new(f).to_owned(), |b| b.join(f));
            read_csv(&path)?
        }
        MissionKind::Waypoints(w) if repeat => {
            let mut m = m.clone();
            m.kind = MissionKind::Waypoints(radarnav::mission::WaypointMission {
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

/// Forwards to an inner observer and moves a progress bar (drawn only on a terminal).
struct WithProgress<'a, O> {
    inner: &'a mut O,
    bar: ProgressBar,
}

impl<O: Observer> Observer for WithProgress<'_, O> {
    type Error = O::Error;
    fn on_scan(&mut self, event: &ScanEvent<'_>) -> Result<(), O::Error> {
        self.inner.on_scan(event)
    }
    fn on_step(&mut self, step: &Step) -> Result<(), O::Error> {
        self.bar.inc(1);
        self.inner.on_step(step)
    }
}

fn progress_bar(steps: u64, dt: f64) -> ProgressBar {
    if !std::io::stdout().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(steps);
    let style =
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {msg} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar.set_message(format!("{:.0} s simulated", steps as f64 * dt));
    bar
}

/// A flag set by the first SIGINT (Ctrl-C) or SIGTERM; a second one ends the process at
/// once, as users expect of a program that seems stuck.
pub fn stop_flag() -> Result<Arc<AtomicBool>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Order matters: the shutdown check must see the flag before this signal sets it.
        flag::register_conditional_shutdown(sig, 130, Arc::clone(&stop))
            .context("installing the signal handlers")?;
        flag::register(sig, Arc::clone(&stop)).context("installing the signal handlers")?;
    }
    Ok(stop)
}

/// Runs a simulation to its end (or until `stop` is set) with a progress bar; returns the
/// summary and wall seconds.
fn drive<O: Observer>(
    sim: &mut Simulation<'_>,
    dt: f64,
    obs: &mut O,
    stop: &AtomicBool,
) -> Result<(RunSummary, f64), O::Error> {
    let bar = progress_bar(sim.total_steps(), dt);
    let t0 = Instant::now();
    let summary = sim.run_until(
        &mut WithProgress {
            inner: obs,
            bar: bar.clone(),
        },
        stop,
    )?;
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok((summary, wall))
}

/// Options of `radarnav run`.
pub struct RunArgs<'a> {
    pub scenario: &'a Scenario,
    pub base: Option<&'a Path>,
    pub out: &'a Path,
    pub robot: Option<&'a str>,
    pub teleop: Option<&'a Path>,
    pub seed: Option<u64>,
    pub duration: Option<f64>,
    pub mcap: bool,
    /// Write the rosbag2 recording.
    pub ros2_bag: bool,
    pub pixels: u32,
    /// Map specs (`None`: no maps; empty: one per sensor).
    pub maps: Option<&'a [String]>,
    pub map_pose: &'a str,
    pub map_resolution: f64,
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

/// The scenario's robot `name` (default: the first), or an error naming what is missing.
pub fn robot_of<'s>(s: &'s Scenario, name: Option<&str>) -> Result<&'s Robot> {
    s.robot(name).with_context(|| match name {
        Some(n) => format!("scenario `{}` has no robot `{n}`", s.name),
        None => format!("scenario `{}` has no robot", s.name),
    })
}

/// `robot` with the presets `names` added (see [`Robot::with_preset_mount`]).
pub fn with_sensors(robot: &Robot, names: &[String]) -> Result<Robot> {
    let mut r = robot.clone();
    for name in names {
        if r.sensor(name).is_some() {
            bail!(
                "--add-sensor `{name}`: robot `{}` already has a sensor of that name",
                r.name
            );
        }
        let s = robot.with_preset_mount(name).with_context(|| {
            format!("--add-sensor `{name}` is not a preset (see `radarnav presets`)")
        })?;
        r.sensors.push(s);
    }
    Ok(r)
}

/// The mappers `run` builds, each kept to the region its sensors can reach, and their cells
/// in all (checked against the memory budget).
fn mappers(a: &RunArgs<'_>, robot: &Robot) -> Result<(Vec<Mapper>, f64)> {
    let Some(specs) = a.maps else {
        return Ok((Vec::new(), 0.0));
    };
    let pose = PoseSource::parse(a.map_pose).with_context(|| {
        format!(
            "--map-pose `{}`: expected `truth`, `odometry` or `slam`",
            a.map_pose
        )
    })?;
    let config = MapConfig {
        resolution: a.map_resolution,
        max_free_range: a.map_max_free_range,
        pose,
        ..MapConfig::default()
    };
    let region = budget::map_region(
        &a.scenario.world,
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
            let mut m = Mapper::from_spec(spec, robot, config)
                .with_context(|| format!("--maps `{spec}`"))?;
            m.limit_to(region);
            Ok(m)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut names: Vec<&str> = maps.iter().map(Mapper::name).collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        bail!("--maps names the map `{}` twice", w[0]);
    }
    let cells = a
        .budget
        .check_maps(maps.iter().map(Mapper::name), region, config.resolution)
        .with_context(|| format!("--map-resolution {}", config.resolution))?;
    Ok((maps, cells))
}

/// The scenario's run settings with `--seed` and `--duration` (range-checked by the argument
/// parser) applied.
fn settings(s: &Scenario, seed: Option<u64>, duration: Option<f64>) -> RunSettings {
    let base = RunSettings::of(s);
    RunSettings {
        seed: seed.unwrap_or(base.seed),
        duration: duration.unwrap_or(base.duration),
        ..base
    }
}

/// `radarnav run`; `true` when a signal cut it short (its files are whole all the same).
pub fn run(a: &RunArgs<'_>) -> Result<bool> {
    let s = a.scenario;
    let settings = settings(s, a.seed, a.duration);
    let plan = plan(s, a.robot, a.teleop, a.base, false, settings.seed)?;
    let mut robot = with_sensors(plan.robot, a.add_sensors)?;
    match a.slam_sensor {
        None => {}
        Some("none") => robot.slam = None,
        Some(name) => {
            let i = (robot.sensors.iter().position(|s| s.name == name)).with_context(|| {
                let known: Vec<&str> = robot.sensors.iter().map(|s| s.name.as_str()).collect();
                format!(
                    "--slam-sensor `{name}`: robot `{}` has no such sensor; it has: {}, or `none`",
                    robot.name,
                    known.join(", ")
                )
            })?;
            let c = robot.slam.unwrap_or(SlamConfig::for_sensor(i));
            robot.slam = Some(SlamConfig { sensor: i, ..c });
        }
    }
    let (mut maps, map_cells) = mappers(a, &robot)?;
    let need = budget::run_output(
        &robot,
        &Recording {
            dt: settings.dt,
            duration: settings.duration,
            mcap: a.mcap,
            ros2_bag: a.ros2_bag,
            scans: true,
            map_cells,
        },
    );
    let what = format!(
        "a run of {} s in steps of {} s",
        settings.duration, settings.dt
    );
    a.budget.check_output(&what, need)?;
    a.budget.check_memory(
        &what,
        budget::path_memory(&s.world, &robot, settings.duration),
    )?;
    if plan.mission == "explore" {
        track_coverage(
            &s.world,
            robot.vehicle,
            &robot.start,
            &mut maps,
            radarnav::compare::COVERAGE_PERIOD,
        );
    }
    let mut sim = Simulation::new(&s.world, &robot, plan.controller, settings)?;
    let options = RecordOptions {
        mcap: a.mcap,
        ros2_bag: a.ros2_bag,
        ..RecordOptions::default()
    };
    let mut rec = Recorder::create(a.out, &s.world, &robot, options)?
        .with_maps(maps)?
        .with_radar_images(&s.world, &robot, settings.seed)?;
    let (summary, wall) = drive(&mut sim, settings.dt, &mut rec, a.stop)?;
    if sim.interrupted() {
        eprintln!(
            "interrupted at {:.2} s simulated: finishing the files (press Ctrl-C again to quit at once)",
            summary.duration
        );
    }
    // Scoring the maps against the world's truth takes a moment in a large world.
    let spinner = if std::io::stderr().is_terminal() && !rec.maps().is_empty() {
        let sp = ProgressBar::new_spinner();
        sp.set_message("scoring the maps and writing the files");
        sp.enable_steady_tick(std::time::Duration::from_millis(120));
        sp
    } else {
        ProgressBar::hidden()
    };
    let recorded = rec.finish(s, &robot, &summary, a.pixels)?;
    spinner.finish_and_clear();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: robot `{}`, mission {}, seed {}",
        s.name, summary.robot, plan.mission, summary.seed
    )?;
    writeln!(
        out,
        "  {:?} after {:.1} s simulated in {:.2} s wall ({:.0}x real time)",
        summary.outcome,
        summary.duration,
        wall,
        summary.duration / wall.max(1e-9)
    )?;
    writeln!(
        out,
        "  drove {:.2} m (odometry {:.2} m, final error {:.3} m / {:.2} deg), {} bumps",
        summary.distance,
        summary.odometry_distance,
        summary.odometry_error,
        summary.odometry_yaw_error_deg,
        summary.bumps
    )?;
    if let Some(nav) = &summary.navigation
        && let Some(reason) = nav.get("reason").and_then(|r| r.as_str())
    {
        writeln!(out, "  navigation: {reason}")?;
    }
    for c in &summary.sensors {
        writeln!(
            out,
            "  {:<10} {:>6} scans at {} Hz",
            c.name, c.scans, c.rate_hz
        )?;
    }
    let slam = summary
        .slam
        .as_ref()
        .map(|s| format!("slam ({})", s.sensor));
    for (name, errors) in [
        (Some("odometry".to_owned()), &recorded.odometry_errors),
        (slam, &recorded.slam_errors),
    ] {
        let (Some(name), Some(a)) = (name, errors) else {
            continue;
        };
        let rpe = a.rpe.map_or_else(
            || "RPE: under 10 m of path".to_owned(),
            |r| {
                format!(
                    "RPE {:.2} % / {:.3} deg/m over {} segments of 10 m",
                    r.translation_percent, r.rotation_deg_per_m, r.segments
                )
            },
        );
        writeln!(out, "  {name}: ATE {:.3} m, {rpe}", a.ate_rmse_m)?;
    }
    let pct = |x: Option<f64>| x.map_or_else(|| "-".to_owned(), |v| format!("{:.1}%", 100.0 * v));
    for (name, m) in &recorded.maps {
        writeln!(
            out,
            "  map {name:<12} hidden area clear {:>6} of {:.1} m2, obstacles P/R {} / {}, free P/R {} / {}",
            pct(m.hidden_coverage),
            m.hidden_area_m2,
            pct(m.obstacle_precision),
            pct(m.obstacle_recall),
            pct(m.free_precision),
            pct(m.free_recall)
        )?;
    }
    writeln!(
        out,
        "  wrote {} files to {}",
        recorded.files.len(),
        a.out.display()
    )?;
    Ok(sim.interrupted())
}

/// `radarnav bench --sim SECONDS`: the scenario's mission (waypoints looping) for that long,
/// with no recording; prints simulated seconds per wall second.
pub fn bench_sim(s: &Scenario, seconds: f64, stop: &AtomicBool) -> Result<()> {
    let plan = plan(s, None, None, None, true, s.sim.seed)?;
    let settings = settings(s, None, Some(seconds));
    // The localiser runs only where the mission steers on it: the benchmark times the
    // simulation and its sensors.
    let mut robot = plan.robot.clone();
    if s.mission.as_ref().and_then(|m| m.pose()) != Some(PoseSource::Slam) {
        robot.slam = None;
    }
    let mut sim = Simulation::new(&s.world, &robot, plan.controller, settings)?;
    let (summary, wall) =
        drive(&mut sim, settings.dt, &mut NoObserver, stop).map_err(|e| match e {})?;
    let rays: f64 = plan
        .robot
        .sensors
        .iter()
        .zip(&summary.sensors)
        .map(|(m, c)| {
            (m.config.azimuth_count() * m.config.elevations.len()) as f64 * c.scans as f64
        })
        .sum();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {:.0} s simulated (mission {}, {} steps) in {:.2} s wall: {:.1}x real time, {:.2} M rays/s",
        s.name,
        summary.duration,
        plan.mission,
        summary.steps,
        wall,
        summary.duration / wall.max(1e-9),
        rays / wall.max(1e-9) / 1e6
    )?;
    for (m, c) in plan.robot.sensors.iter().zip(&summary.sensors) {
        writeln!(
            out,
            "  {:<10} {:<16} {:>5} rays x {:>6} scans ({} Hz)",
            c.name,
            c.preset.as_deref().unwrap_or("-"),
            m.config.azimuth_count() * m.config.elevations.len(),
            c.scans,
            c.rate_hz
        )?;
    }
    writeln!(
        out,
        "  drove {:.1} m, {} bumps",
        summary.distance, summary.bumps
    )?;
    Ok(())
}
