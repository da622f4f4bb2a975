//! The thesis experiments on a scenario.
//!
//! * [`thesis_experiment`]: one scan per sensor from the robot's start pose, the figures 7–10
//!   (laser, radar without noise, radar with side beams N = 50 and N = 100) plus the ground
//!   truth, and how many rays see past the foliage.
//! * [`mapping_experiment`]: the scenario's mission driven once while several maps are built
//!   from it (radar only, laser only, …), each scored against the world: the thesis' claim
//!   that the radar maps the area hidden behind the foliage and the laser does not.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use thiserror::Error;
use tiny_skia::Pixmap;

use crate::map::{MapConfig, MapError, MapScores, Mapper, PoseSource, score_maps};
use crate::record::Trail;
use crate::render::{Figure, RenderError};
use crate::sensor::{Scan, SensorConfig, Tracer, preset};
use crate::setup::Scenario;
use crate::sim::{Observer, RunSettings, RunSummary, Simulation, Step};
use crate::world::{RayQuery, World};

/// Why the experiment could not run.
#[derive(Debug, Error)]
pub enum DemoError {
    /// The scenario has no robot to scan from.
    #[error("scenario `{0}` has no robot")]
    NoRobot(String),
    /// The robot lacks a sensor the experiment needs.
    #[error("robot `{robot}` has no sensor named `{sensor}`")]
    NoSensor {
        /// Robot name.
        robot: String,
        /// Missing sensor.
        sensor: String,
    },
    /// Drawing failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The scenario has no mission to drive.
    #[error("scenario `{0}` has no [mission] to drive")]
    NoMission(String),
    /// The mission cannot run.
    #[error(transparent)]
    Mission(#[from] crate::mission::MissionError),
    /// The simulation cannot start.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A map cannot be built.
    #[error(transparent)]
    Map(#[from] MapError),
}

/// One sensor's result.
#[derive(Debug)]
pub struct SensorResult {
    /// Output file stem, e.g. `fig7_laser`.
    pub file: &'static str,
    /// Figure title.
    pub title: String,
    /// Preset name.
    pub preset: String,
    /// The scan drawn in the figure.
    pub scan: Scan,
    /// Share of that scan's rays that see past the foliage.
    pub share_past: f64,
    /// Mean share over `repeats` scans with fresh random draws (differs from `share_past`
    /// only for sensors with side beams or noise).
    pub mean_share_past: f64,
}

/// Whether reading `i` of `scan` sees past foliage: the segment from the ray's origin to its
/// return crosses a whole foliage volume (radar-penetrable and not traversable) and the return
/// is not itself inside foliage. A ray that leaves one bush and fades in the next does not count.
pub fn sees_past_foliage(world: &World, scan: &Scan, i: usize, query: &mut RayQuery) -> bool {
    let r = f64::from(scan.ranges[i]);
    if !r.is_finite() {
        return false;
    }
    let ray = scan.ray(i);
    let materials = world.materials();
    let foliage = |id| {
        let m = materials.get(id);
        m.radar_penetrable() && !m.traversable
    };
    let mut crossed = false;
    for iv in world.ray_intervals(&ray, r + 1e-9, query) {
        if !foliage(iv.material) {
            continue;
        }
        if iv.t_out < r - 1e-9 {
            crossed = true;
        } else if iv.t_in < r {
            return false;
        }
    }
    crossed
}

/// Share of the rays of `scan` that see past foliage.
pub fn share_past_foliage(world: &World, scan: &Scan) -> f64 {
    if scan.is_empty() {
        return 0.0;
    }
    let mut q = RayQuery::default();
    let n = (0..scan.len())
        .filter(|&i| sees_past_foliage(world, scan, i, &mut q))
        .count();
    n as f64 / scan.len() as f64
}

/// Runs the experiment: for the first robot of `scenario`, the laser named `laser` and the radar
/// presets `radar_thesis`, `radar_thesis_n50`, `radar_thesis_n100` at the mount of the sensor
/// named `radar`, plus `ground_truth`. `repeats` extra scans per sensor give the mean share.
pub fn thesis_experiment(
    scenario: &Scenario,
    seed: u64,
    repeats: usize,
) -> Result<Vec<SensorResult>, DemoError> {
    let robot = scenario
        .robot(None)
        .ok_or_else(|| DemoError::NoRobot(scenario.name.clone()))?;
    let sensor = |name: &str| {
        robot.sensor(name).ok_or_else(|| DemoError::NoSensor {
            robot: robot.name.clone(),
            sensor: name.to_owned(),
        })
    };
    let (laser, radar) = (sensor("laser")?, sensor("radar")?);
    let with_preset = |name: &str| preset(name).expect("built-in preset");
    let runs: [(&str, &str, SensorConfig, _); 5] = [
        (
            "fig7_laser",
            "Fig. 7: laser",
            laser.config.clone(),
            laser.mount,
        ),
        (
            "fig8_radar",
            "Fig. 8: radar, no side beams",
            with_preset("radar_thesis"),
            radar.mount,
        ),
        (
            "fig9_radar_n50",
            "Fig. 9: radar, side beams N=50 (0.2 m)",
            with_preset("radar_thesis_n50"),
            radar.mount,
        ),
        (
            "fig10_radar_n100",
            "Fig. 10: radar, side beams N=100 (0.4 m)",
            with_preset("radar_thesis_n100"),
            radar.mount,
        ),
        (
            "ground_truth",
            "Ground truth: first surface",
            with_preset("ground_truth"),
            radar.mount,
        ),
    ];
    let mut tracer = Tracer::default();
    let mut out = Vec::new();
    for (k, (file, title, config, mount)) in runs.into_iter().enumerate() {
        let pose = robot.start.compose(&mount);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(k as u64);
        let scan = config.scan(&scenario.world, &pose, 0.0, &mut rng, &mut tracer);
        let share_past = share_past_foliage(&scenario.world, &scan);
        let mut total = share_past;
        for _ in 0..repeats {
            let s = config.scan(&scenario.world, &pose, 0.0, &mut rng, &mut tracer);
            total += share_past_foliage(&scenario.world, &s);
        }
        out.push(SensorResult {
            file,
            title: format!("{} - {}", scenario.name, title),
            preset: config.preset.clone().unwrap_or_default(),
            scan,
            share_past,
            mean_share_past: total / (repeats + 1) as f64,
        });
    }
    Ok(out)
}

/// The figure of one result: the world, the scan, the robot at its start.
pub fn result_figure(
    scenario: &Scenario,
    result: &SensorResult,
    pixels: u32,
) -> Result<Pixmap, DemoError> {
    let mut fig = Figure::of_world(&scenario.world, None, pixels)?;
    fig.draw_scan(&result.scan);
    if let Some(robot) = scenario.robot(None) {
        fig.draw_robot(&robot.start, robot.vehicle);
    }
    Ok(fig.finish(&result.title))
}

/// One map of [`mapping_experiment`].
#[derive(Debug)]
pub struct MapResult {
    /// The finished map.
    pub mapper: Mapper,
    /// Its scores.
    pub scores: MapScores,
}

/// What [`mapping_experiment`] found.
#[derive(Debug)]
pub struct MappingExperiment {
    /// The drive.
    pub summary: RunSummary,
    /// The true path, a point per centimetre or more.
    pub path: Vec<glam::DVec2>,
    /// The odometry's path, likewise.
    pub odometry_path: Vec<glam::DVec2>,
    /// The localiser's path, likewise (empty when the robot runs none).
    pub slam_path: Vec<glam::DVec2>,
    /// Each map, in the order asked.
    pub maps: Vec<MapResult>,
}

/// Collects the true, odometry and localiser paths of a run.
#[derive(Default)]
struct PathLog(Trail, Trail, Trail);

impl Observer for PathLog {
    type Error = std::convert::Infallible;
    fn on_step(&mut self, s: &Step) -> Result<(), Self::Error> {
        self.0.push(&s.truth);
        self.1.push(&s.odometry);
        if let Some(p) = &s.slam {
            self.2.push(p);
        }
        Ok(())
    }
}

/// Drives the scenario's mission once with `seed` and builds one map per entry of `maps`
/// (a sensor spec such as `radar` or `radar+laser`, and a pose source), all at `resolution`.
/// Mapping does not steer the robot, so one drive serves every map; each sees exactly the
/// scans it would have seen on a drive of its own.
pub fn mapping_experiment(
    scenario: &Scenario,
    seed: u64,
    maps: &[(&str, PoseSource)],
    resolution: f64,
) -> Result<MappingExperiment, DemoError> {
    let mission = scenario
        .mission
        .as_ref()
        .ok_or_else(|| DemoError::NoMission(scenario.name.clone()))?;
    let robot = scenario
        .robot(mission.robot.as_deref())
        .ok_or_else(|| DemoError::NoRobot(scenario.name.clone()))?;
    let mut mappers = maps
        .iter()
        .map(|&(spec, pose)| {
            let config = MapConfig {
                resolution,
                pose,
                ..MapConfig::default()
            };
            Mapper::from_spec(spec, robot, config)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let settings = RunSettings {
        seed,
        ..RunSettings::of(scenario)
    };
    let mut sim = Simulation::new(&scenario.world, robot, mission.controller(seed)?, settings)?;
    let mut path = PathLog::default();
    let summary = match sim.run(&mut (mappers.as_mut_slice(), &mut path)) {
        Ok(s) => s,
        Err(never) => match never {},
    };
    path.0.end(&summary.final_pose);
    path.1.end(&summary.final_odometry);
    if let Some(s) = &summary.slam {
        path.2.end(&s.final_pose);
    }
    let scores = score_maps(&scenario.world, robot.vehicle, &robot.start, &mappers);
    let out = mappers
        .into_iter()
        .zip(scores)
        .map(|(mapper, scores)| MapResult { mapper, scores })
        .collect();
    Ok(MappingExperiment {
        summary,
        path: path.0.points(),
        odometry_path: path.1.points(),
        slam_path: path.2.points(),
        maps: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laser_sees_nothing_past_the_foliage_wall_and_radar_does() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let results = thesis_experiment(&s, 1, 5).unwrap();
        let share = |f: &str| results.iter().find(|r| r.file == f).unwrap();
        assert_eq!(share("fig7_laser").mean_share_past, 0.0);
        assert_eq!(share("ground_truth").mean_share_past, 0.0);
        for f in ["fig8_radar", "fig9_radar_n50", "fig10_radar_n100"] {
            assert!(share(f).mean_share_past > 0.0, "{f}");
        }
        // The radar does not see past the wall everywhere: most rays towards it fade inside.
        let radar = share("fig8_radar");
        assert!(radar.share_past < 0.2, "{}", radar.share_past);
        assert!(radar.scan.hits.contains(&crate::sensor::HitKind::Exhausted));
    }

    /// The thesis map's defining property: from anywhere on the near side, in scan planes from
    /// 0.25 m to 1 m high, neither a laser nor the first-surface ground truth gets a return
    /// from behind the foliage wall (x > 8), while the radar does.
    #[test]
    fn foliage_wall_hides_the_far_side_from_the_laser_everywhere() {
        use crate::pose::Pose;
        let s = Scenario::builtin("foliage-wall").unwrap();
        let mut tracer = Tracer::default();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut radar_behind = 0;
        for z in [0.25, 0.4, 0.7, 1.0] {
            for ix in 0..6 {
                for iy in 0..8 {
                    let pose = Pose::new(0.5 + ix as f64, 0.5 + iy as f64, z, 0.0);
                    if s.world.objects_at(pose.position()).next().is_some() {
                        continue;
                    }
                    for name in ["ground_truth", "hokuyo_utm30lx", "radar_thesis"] {
                        let mut config = preset(name).unwrap();
                        config.fov = std::f64::consts::TAU;
                        let scan = config.scan(&s.world, &pose, 0.0, &mut rng, &mut tracer);
                        let behind = (0..scan.len())
                            .filter_map(|i| scan.endpoint(i))
                            .filter(|p| p.x > 8.0)
                            .count();
                        if name == "radar_thesis" {
                            radar_behind += behind;
                        } else {
                            assert_eq!(behind, 0, "{name} at {pose:?}");
                        }
                    }
                }
            }
        }
        assert!(
            radar_behind > 100,
            "radar returns behind the wall: {radar_behind}"
        );
    }

    #[test]
    fn radar_fades_in_a_dense_core() {
        use crate::pose::Pose;
        use crate::sensor::HitKind;
        use crate::world::{Band, Ray};
        let s = Scenario::builtin("foliage-wall").unwrap();
        // Straight at the core sphere centred at (7, 4): entry at x = 6.2 (0.8 m slice radius
        // at 0.4 m height), then 3 dB / 3 dB/m = 1 m in.
        let start = Pose::new(3.0, 4.0, 0.4, 0.0).position();
        let r = Tracer::default().trace(
            &s.world,
            &Ray::new(start, glam::DVec3::X),
            Band::Radar,
            3.0,
            20.0,
        );
        assert_eq!(r.kind, HitKind::Exhausted);
        assert!((r.range - 4.2).abs() < 1e-9, "{r:?}");
    }

    /// The thesis' claim on its own map, driven: the radar map reveals part of the area
    /// behind the foliage wall; the laser map none of it.
    #[test]
    fn radar_maps_the_hidden_area_and_laser_does_not() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let maps = [
            ("radar", PoseSource::Truth),
            ("laser", PoseSource::Truth),
            ("radar", PoseSource::Odometry),
        ];
        let e = mapping_experiment(&s, 1, &maps, 0.05).unwrap();
        let (radar, laser) = (&e.maps[0].scores, &e.maps[1].scores);
        assert_eq!(laser.hidden_coverage, Some(0.0));
        assert!(radar.hidden_coverage.unwrap() > 0.1, "{radar:?}");
        assert!(radar.hidden_area_m2 > 25.0);
        assert!(laser.free_precision.unwrap() > 0.95, "{laser:?}");
        assert!(laser.obstacle_precision.unwrap() > 0.8, "{laser:?}");
        assert_eq!(e.summary.bumps, 0);
        // The odometry drifts, so the same scans placed by it draw blurred obstacles.
        let drifted = &e.maps[2].scores;
        assert!(
            drifted.obstacle_precision.unwrap() < radar.obstacle_precision.unwrap() - 0.05,
            "{drifted:?}"
        );
        assert_eq!(e.maps[0].mapper.scans(), 139);
        assert_eq!(e.maps[1].mapper.scans(), 1389);
    }

    #[test]
    fn experiment_is_deterministic() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let a = thesis_experiment(&s, 9, 0).unwrap();
        let b = thesis_experiment(&s, 9, 0).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.scan, y.scan);
        }
        let c = thesis_experiment(&s, 10, 0).unwrap();
        assert_ne!(
            a[2].scan.beams, c[2].scan.beams,
            "a new seed draws new side beams"
        );
    }
}
