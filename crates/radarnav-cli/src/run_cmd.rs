//! `radarnav run` and `radarnav bench --sim`: a scenario's mission driven through the
//! simulation loop.

use std::io::{IsTerminal, Write};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use radarnav::Scenario;
use radarnav::run::{Progress, RunError, RunRequest, drive, plan, record_run, settings};
use radarnav::sim::{NoObserver, Simulation};

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

/// A progress callback that moves `bar`.
fn on_progress(bar: &ProgressBar) -> impl FnMut(Progress) + '_ {
    move |p| {
        if let Progress::Step(..) = p {
            bar.inc(1);
        }
    }
}

/// `radarnav run`; `true` when a signal cut it short (its files are whole all the same).
pub fn run(request: &RunRequest<'_>) -> Result<bool> {
    let (s, a) = (request.scenario, request);
    let settings = settings(s, a.seed, a.duration);
    let bar = progress_bar(
        (settings.duration / settings.dt).round() as u64,
        settings.dt,
    );
    // Scoring the maps against the world's truth takes a moment in a large world.
    let spinner = ProgressBar::hidden();
    let mut progress = |p: Progress| match p {
        Progress::Step(..) => bar.inc(1),
        Progress::Finishing { interrupted, time } => {
            bar.finish_and_clear();
            if interrupted {
                eprintln!(
                    "interrupted at {time:.2} s simulated: finishing the files (press Ctrl-C again to quit at once)"
                );
            }
            if std::io::stderr().is_terminal() && a.maps.is_some() {
                spinner.set_draw_target(indicatif::ProgressDrawTarget::stderr());
                spinner.set_style(ProgressStyle::default_spinner());
                spinner.set_message("scoring the maps and writing the files");
                spinner.enable_steady_tick(std::time::Duration::from_millis(120));
            }
        }
    };
    // The library names the request's fields; here they are flags.
    let report = record_run(request, &mut progress).map_err(|e| match &e {
        RunError::AddSensor { .. } | RunError::SlamSensor { .. } => {
            anyhow::anyhow!("--{}", e.to_string().replacen(' ', "-", 1))
        }
        _ => anyhow::Error::new(e),
    })?;
    spinner.finish_and_clear();
    bar.finish_and_clear();
    let (summary, recorded, wall) = (&report.summary, &report.recorded, report.wall_seconds);
    let plan_mission = report.mission;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: robot `{}`, mission {}, seed {}",
        s.name, summary.robot, plan_mission, summary.seed
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
    Ok(report.interrupted)
}

/// `radarnav bench --sim SECONDS`: the scenario's mission (waypoints looping) for that long,
/// with no recording; prints simulated seconds per wall second.
pub fn bench_sim(s: &Scenario, seconds: f64, stop: &AtomicBool) -> Result<()> {
    let plan = plan(s, None, None, None, true, s.sim.seed)?;
    let settings = settings(s, None, Some(seconds));
    // The benchmark times the simulation and its sensors, and the localiser only where the
    // mission steers on it.
    let robot = radarnav::run::batch_robot(&plan, s);
    let mut sim = Simulation::new(&s.world, &robot, plan.controller, settings)?;
    let bar = progress_bar(sim.total_steps(), settings.dt);
    let Ok((summary, wall)) = drive(&mut sim, &mut NoObserver, stop, &mut on_progress(&bar));
    bar.finish_and_clear();
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
