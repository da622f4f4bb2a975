//! `radarnav scan`: one scan of a sensor (of the robot, or any preset) from a pose, drawn and
//! written as files.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use radarnav::Pose;
use radarnav::demo::share_past_foliage;
use radarnav::limits;
use radarnav::render::{Figure, save_png};
use radarnav::sensor::Tracer;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::{create_dir, load, signal_cmd};

macro_rules! say {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout().lock(), $($arg)*)?
    };
}

/// `radarnav scan`.
pub fn scan(
    scenario: &str,
    sensor: &str,
    robot: Option<&str>,
    pose: Option<&str>,
    seed: Option<u64>,
    out: &Path,
    pixels: u32,
) -> Result<()> {
    let s = load(scenario)?;
    let r = radarnav::run::robot_of(&s, robot)?;
    let mounted = match r.sensor(sensor) {
        Some(m) => m.clone(),
        None => r.with_preset_mount(sensor).with_context(|| {
            let on_robot: Vec<&str> = r.sensors.iter().map(|m| m.name.as_str()).collect();
            format!(
                "`{sensor}` is neither a sensor of robot `{}` ({}) nor a preset (see `radarnav presets`)",
                r.name,
                on_robot.join(", ")
            )
        })?,
    };
    let robot_pose = pose.map(parse_pose).transpose()?.unwrap_or(r.start);
    let sensor_pose = robot_pose.compose(&mounted.mount);
    let mut rng = ChaCha8Rng::seed_from_u64(seed.unwrap_or(s.sim.seed));
    let scan = mounted.config.scan(
        &s.world,
        &sensor_pose,
        0.0,
        &mut rng,
        &mut Tracer::default(),
    );

    create_dir(out)?;
    let mut fig = Figure::of_world(&s.world, None, pixels)?;
    fig.draw_scan(&scan);
    fig.draw_robot(&robot_pose, r.vehicle);
    save_png(
        &fig.finish(&format!("{} - {}", s.name, mounted.name)),
        &out.join("scan.png"),
    )?;
    let materials: Vec<&str> = s
        .world
        .materials()
        .iter()
        .map(|(_, m)| m.name.as_str())
        .collect();
    radarnav::record::scan_files::write_scan_files(
        out, &s.name, &r.name, &mounted, &scan, &materials,
    )?;
    let (signal, _) = signal_cmd::write_signal_outputs(
        &s,
        &mounted,
        &sensor_pose,
        &scan,
        &materials,
        &mut rng,
        out,
    )?;
    let share = share_past_foliage(&s.world, &scan);
    let returns = scan.ranges.iter().filter(|r| r.is_finite()).count();
    say!(
        "{} rays, {} returns, {:.1}% see past foliage; wrote scan.png, scan.json, scan.csv{} to {}",
        scan.len(),
        returns,
        100.0 * share,
        signal.iter().map(|f| format!(", {f}")).collect::<String>(),
        out.display()
    );
    Ok(())
}

fn parse_pose(s: &str) -> Result<Pose> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--pose `{s}`: expected x,y,yaw_deg"))?;
    match v.as_slice() {
        [x, y, yaw] => {
            for (what, v, limit) in [("x", x, &limits::COORD), ("y", y, &limits::COORD)]
                .into_iter()
                .chain([("yaw_deg", yaw, &limits::YAW)])
            {
                limit
                    .check(*v)
                    .map_err(|m| anyhow::anyhow!("--pose `{s}`: {what}: {m}"))?;
            }
            Ok(Pose::new(*x, *y, 0.0, yaw.to_radians()))
        }
        _ => bail!("--pose `{s}`: expected three numbers x,y,yaw_deg"),
    }
}
