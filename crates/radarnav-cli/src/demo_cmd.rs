//! `radarnav demo`: the thesis experiment on foliage-wall, the maps of its mission, figure 15
//! with SLAM, Bug1 and Bug2 on foliage-gap, then the radar-signal demo; tables printed here,
//! everything else in `radarnav::demo`.

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use radarnav::Scenario;
use radarnav::demo::{result_figure, thesis_experiment};
use radarnav::render::save_png;

use crate::{create_dir, signal_demo};

macro_rules! say {
    ($($arg:tt)*) => {
        writeln!(std::io::stdout().lock(), $($arg)*)?
    };
}

/// `radarnav demo`.
pub fn demo(out: &Path, seed: Option<u64>, repeats: usize) -> Result<()> {
    let s = Scenario::builtin("foliage-wall").context("built-in scenario")?;
    let seed = seed.unwrap_or(s.sim.seed);
    let results = thesis_experiment(&s, seed, repeats)?;
    create_dir(out)?;
    say!(
        "foliage-wall, robot at its start pose, seed {seed}: share of rays that see past the foliage wall"
    );
    say!(
        "{:<18} {:<18} {:>6} {:>12} {:>16}",
        "figure",
        "preset",
        "rays",
        "this scan",
        format!("mean of {}", repeats + 1)
    );
    for r in &results {
        let path = out.join(format!("{}.png", r.file));
        save_png(&result_figure(&s, r, 900)?, &path)?;
        say!(
            "{:<18} {:<18} {:>6} {:>11.1}% {:>15.2}%",
            r.file,
            r.preset,
            r.scan.len(),
            100.0 * r.share_past,
            100.0 * r.mean_share_past
        );
    }
    say!("figures written to {}", out.display());
    map_demo(&s, seed, out)?;
    slam_demo(seed, out)?;
    bug_demo(seed, out)?;
    signal_demo::signal_demo(out, seed)
}

/// The second half of the demo: the foliage-wall mission driven once while four maps are
/// built (radar and laser, each at the true and at the odometry pose), then scored.
fn map_demo(s: &Scenario, seed: u64, out: &Path) -> Result<()> {
    use radarnav::map::{PoseSource, export};
    let maps = [
        ("radar", PoseSource::Truth, "map_radar"),
        ("laser", PoseSource::Truth, "map_laser"),
        ("radar", PoseSource::Odometry, "map_radar_odometry"),
        ("laser", PoseSource::Odometry, "map_laser_odometry"),
    ];
    let specs: Vec<(&str, PoseSource)> = maps.iter().map(|m| (m.0, m.1)).collect();
    let t0 = Instant::now();
    let e = radarnav::demo::mapping_experiment(s, seed, &specs, 0.05)?;
    let wall = t0.elapsed().as_secs_f64();
    let robot = s.robot(None).context("foliage-wall has a robot")?;
    say!("");
    say!(
        "foliage-wall mission driven once ({:.1} s, {:.1} m, {} bumps, {:.2} s wall), mapped at 0.05 m:",
        e.summary.duration,
        e.summary.distance,
        e.summary.bumps,
        wall
    );
    say!(
        "{:<8} {:<9} {:>6} {:>10} {:>22} {:>10} {:>10} {:>10} {:>10}",
        "map",
        "pose",
        "scans",
        "known m2",
        "hidden area clear",
        "obst prec",
        "obst rec",
        "free prec",
        "free rec"
    );
    let pct = |x: Option<f64>| x.map_or_else(|| "-".to_owned(), |v| format!("{:.1}%", 100.0 * v));
    for (m, (_, _, stem)) in e.maps.iter().zip(maps) {
        let sc = &m.scores;
        say!(
            "{:<8} {:<9} {:>6} {:>10.1} {:>22} {:>10} {:>10} {:>10} {:>10}",
            m.mapper.name(),
            m.mapper.config().pose.as_str(),
            m.mapper.scans(),
            sc.known_area_m2,
            format!(
                "{:.1} of {:.1} m2 ({})",
                sc.hidden_clear_m2,
                sc.hidden_area_m2,
                pct(sc.hidden_coverage)
            ),
            pct(sc.obstacle_precision),
            pct(sc.obstacle_recall),
            pct(sc.free_precision),
            pct(sc.free_recall)
        );
        let title = format!(
            "foliage-wall - {} map ({} pose): {} of the hidden area clear",
            m.mapper.name(),
            m.mapper.config().pose.as_str(),
            pct(sc.hidden_coverage)
        );
        let overlay = export::Overlay {
            path: &e.path,
            robot: Some((robot.vehicle, robot.start, e.summary.final_pose)),
            region: Some(radarnav::render::world_region(&s.world)),
            marks: None,
            estimates: &[],
        };
        export::write_all(m.mapper.grid(), out, stem, &title, 900, &overlay)?;
    }
    say!(
        "maps written to {} (map_*.png in the thesis' palette, .pgm/.yaml for ROS map_server, .npy raw log-odds)",
        out.display()
    );
    Ok(())
}

/// The thesis' figure 15 made its way, with SLAM: the foliage-wall loop on a drifting odometry
/// (`slam/foliage-wall-loop`), steered on the radar localiser's pose, and the radar map built on
/// that pose, with the true, odometry and SLAM paths over it; beside it the radar map on the
/// true pose and on the odometry.
fn slam_demo(seed: u64, out: &Path) -> Result<()> {
    use radarnav::map::{PoseSource, export};
    let s = Scenario::builtin("slam/foliage-wall-loop").context("built-in scenario")?;
    let maps = [
        (PoseSource::Slam, "fig15_radar_slam"),
        (PoseSource::Truth, "map_radar_loop_truth"),
        (PoseSource::Odometry, "map_radar_loop_odometry"),
    ];
    let specs: Vec<(&str, PoseSource)> = maps.iter().map(|m| ("radar", m.0)).collect();
    let e = radarnav::demo::mapping_experiment(&s, seed, &specs, 0.05)?;
    let robot = s.robot(None).context("the scenario has a robot")?;
    let slam = e
        .summary
        .slam
        .as_ref()
        .context("the robot runs a localiser")?;
    say!("");
    say!(
        "slam/foliage-wall-loop: {:.0} s looped on a drifting odometry, steering on radar SLAM ({:.1} m, {} bumps); end error odometry {:.2} m, SLAM {:.3} m:",
        e.summary.duration,
        e.summary.distance,
        e.summary.bumps,
        e.summary.odometry_error,
        slam.error
    );
    let pct = |x: Option<f64>| x.map_or_else(|| "-".to_owned(), |v| format!("{:.1}%", 100.0 * v));
    for (m, (pose, stem)) in e.maps.iter().zip(maps) {
        say!(
            "  radar map on {:<9} hidden area clear {:>6}, obstacle precision {:>6}",
            pose.as_str(),
            pct(m.scores.hidden_coverage),
            pct(m.scores.obstacle_precision)
        );
        let title = format!(
            "radar map on the {} pose: hidden {}, obst. prec. {}",
            pose.as_str(),
            pct(m.scores.hidden_coverage),
            pct(m.scores.obstacle_precision)
        );
        let estimates = [
            (e.odometry_path.as_slice(), [200, 60, 40], "odometry"),
            (e.slam_path.as_slice(), [150, 40, 190], "radar SLAM"),
        ];
        let overlay = export::Overlay {
            path: &e.path,
            robot: Some((robot.vehicle, robot.start, e.summary.final_pose)),
            region: Some(radarnav::render::world_region(&s.world)),
            marks: None,
            estimates: &estimates,
        };
        export::write_all(m.mapper.grid(), out, stem, &title, 900, &overlay)?;
    }
    Ok(())
}

/// The third part of the demo: Bug1 and Bug2 with the radar on foliage-gap (the
/// foliage-wall hedge with a way round it), the goal behind the hedge; each path drawn over
/// the radar map built on the way.
fn bug_demo(seed: u64, out: &Path) -> Result<()> {
    use radarnav::map::{PoseSource, export};
    use radarnav::mission::MissionKind;
    use radarnav::nav::BugAlgorithm;
    let base = Scenario::builtin("foliage-gap").context("built-in scenario")?;
    say!("");
    say!(
        "Bug1 and Bug2 with the radar on foliage-gap: the foliage-wall hedge with a 3 m opening at its north end, the goal behind it:"
    );
    say!(
        "{:<6} {:>9} {:>10} {:>8} {:>6} {:>6} {:>7} {:>10}",
        "algo",
        "outcome",
        "path",
        "time",
        "bumps",
        "hits",
        "leaves",
        "to goal"
    );
    for algorithm in [BugAlgorithm::Bug1, BugAlgorithm::Bug2] {
        let mut s = base.clone();
        if let Some(MissionKind::Bug(b)) = s.mission.as_mut().map(|m| &mut m.kind) {
            b.algorithm = algorithm;
        }
        let e =
            radarnav::demo::mapping_experiment(&s, seed, &[("radar", PoseSource::Truth)], 0.05)?;
        let robot = s.robot(None).context("foliage-gap has a robot")?;
        let nav = e.summary.navigation.clone().unwrap_or_default();
        let count = |k: &str| nav[k].as_array().map_or(0, Vec::len);
        let outcome = serde_json::to_value(e.summary.outcome)?;
        let m = &e.maps[0];
        let to_goal = nav["goal_distance"].as_f64().unwrap_or(f64::NAN);
        let goal: Vec<glam::DVec2> = match s.mission.as_ref().map(|m| &m.kind) {
            Some(MissionKind::Bug(b)) => vec![b.goal],
            _ => Vec::new(),
        };
        say!(
            "{:<6} {:>9} {:>8.1} m {:>6.1} s {:>6} {:>6} {:>7} {:>8.2} m",
            algorithm.as_str(),
            outcome.as_str().unwrap_or("?"),
            e.summary.distance,
            e.summary.duration,
            e.summary.bumps,
            count("hit_points"),
            count("leave_points"),
            to_goal
        );
        let title = format!(
            "foliage-gap - {} with the radar: {} after {:.1} m, {} bumps",
            algorithm.as_str(),
            outcome.as_str().unwrap_or("?"),
            e.summary.distance,
            e.summary.bumps
        );
        let overlay = export::Overlay {
            path: &e.path,
            robot: Some((robot.vehicle, robot.start, e.summary.final_pose)),
            region: Some(radarnav::render::world_region(&s.world)),
            marks: Some((&goal, "goal")),
            estimates: &[],
        };
        export::write_all(
            m.mapper.grid(),
            out,
            &format!("{}_radar", algorithm.as_str()),
            &title,
            900,
            &overlay,
        )?;
    }
    say!(
        "paths over the radar maps written to {} (bug1_radar.png, bug2_radar.png)",
        out.display()
    );
    Ok(())
}
