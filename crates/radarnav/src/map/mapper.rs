//! Building a map from a run's scans: a [`Mapper`] watches the simulation like a recorder
//! does and inserts every scan of its sensors at the pose it is told to trust.

use glam::DVec2;
use serde::{Deserialize, Serialize};

use std::sync::Arc;

use super::MapError;
use super::coverage::{CoverageSample, CoverageTrack};
use super::grid::{Beam, Grid, Layers, Occupancy};
use super::truth::Truth;
use super::walk::CellIndex;
use crate::pose::Pose;
use crate::sensor::{Scan, SensorKind};
use crate::setup::{MountedSensor, Robot};
use crate::sim::{Observer, ScanEvent, Step};
use crate::vehicle::VehicleSpec;

/// Which robot pose the mapper uses to place scans.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// The true pose: mapping with known poses, as the thesis did with USARSim's ground-truth
    /// sensor. Shows what the sensor alone can map.
    #[default]
    Truth,
    /// The wheel odometry: what a robot without localisation has; the map shows its drift.
    Odometry,
    /// The localiser's estimate ([`crate::slam`]): scans registered against the map of the
    /// scans before them, the odometry as the motion prior.
    Slam,
}

impl PoseSource {
    /// Lowercase name, as in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Truth => "truth",
            Self::Odometry => "odometry",
            Self::Slam => "slam",
        }
    }

    /// Parses `truth`, `odometry` or `slam`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "truth" => Some(Self::Truth),
            "odometry" => Some(Self::Odometry),
            "slam" => Some(Self::Slam),
            _ => None,
        }
    }
}

/// How a map is built.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MapConfig {
    /// Cell size, m.
    pub resolution: f64,
    /// Which pose places the scans.
    pub pose: PoseSource,
    /// A ray with no return (`+inf`) frees cells up to this range (or the sensor's
    /// `range_max`, if shorter), m; it marks no hit.
    pub max_free_range: f64,
    /// Returns farther than this are not taken as hits but as no return (free up to
    /// `max_free_range`): far, grazing returns are unreliable and would grow the grid, m.
    pub max_range: f64,
    /// Returns lower than this above the ground are taken as the ground, not an obstacle
    /// (only tilted scan planes reach it), m.
    pub ground_clearance: f64,
    /// The robot's body marks the cells under it passable, and a bump the cells in front of it
    /// an obstacle.
    pub body: bool,
    /// Log-odds settings.
    pub occupancy: Occupancy,
}

impl Default for MapConfig {
    fn default() -> Self {
        Self {
            resolution: 0.05,
            pose: PoseSource::Truth,
            max_free_range: 10.0,
            max_range: 50.0,
            ground_clearance: 0.05,
            body: true,
            occupancy: Occupancy::default(),
        }
    }
}

impl MapConfig {
    /// Checks every value.
    pub fn validate(&self) -> Result<(), MapError> {
        let bad = |what: String| Err(MapError::Config(what));
        if !(self.resolution > 0.0 && self.resolution.is_finite()) {
            return bad(format!(
                "resolution must be a finite number > 0, found {}",
                self.resolution
            ));
        }
        if !(self.max_free_range >= 0.0 && self.max_free_range.is_finite()) {
            return bad(format!(
                "max_free_range must be a finite number >= 0, found {}",
                self.max_free_range
            ));
        }
        if self.max_range.is_nan() || self.max_range <= 0.0 {
            return bad(format!(
                "max_range must be a number > 0, found {}",
                self.max_range
            ));
        }
        if !self.ground_clearance.is_finite() {
            return bad("ground_clearance must be finite".into());
        }
        self.occupancy.validate().map_err(MapError::Config)
    }
}

/// Whether a sensor's rays stop at the first thing in their way, so the cells they cross are
/// passable. A radar ray crosses foliage, so its misses only say "clear to the sensor".
pub fn misses_are_passable(kind: SensorKind) -> bool {
    kind != SensorKind::Radar
}

/// Builds one occupancy grid from some of a robot's sensors.
#[derive(Clone, Debug)]
pub struct Mapper {
    name: String,
    sensor_names: Vec<String>,
    /// Per robot sensor: its mount when it feeds this map.
    mounts: Vec<Option<Pose>>,
    vehicle: &'static VehicleSpec,
    config: MapConfig,
    grid: Grid,
    beams: Vec<Beam>,
    scans: u64,
    last_body: Option<Pose>,
    coverage: Option<CoverageTrack>,
}

impl Mapper {
    /// A mapper named `name` fed by the robot's sensors called `sensors`.
    pub fn new(
        name: &str,
        robot: &Robot,
        sensors: &[&str],
        config: MapConfig,
    ) -> Result<Self, MapError> {
        Self::for_sensors(
            name,
            &robot.name,
            &robot.sensors,
            robot.vehicle,
            sensors,
            config,
        )
    }

    /// A mapper named `name` fed by the sensors called `sensors` among `mounted`, the sensors
    /// of robot `robot` (a name for messages) driving `vehicle`.
    pub fn for_sensors(
        name: &str,
        robot: &str,
        mounted: &[MountedSensor],
        vehicle: &'static VehicleSpec,
        sensors: &[&str],
        config: MapConfig,
    ) -> Result<Self, MapError> {
        config.validate()?;
        if sensors.is_empty() {
            return Err(MapError::Config(format!("map `{name}` has no sensor")));
        }
        let mut mounts = vec![None; mounted.len()];
        for want in sensors {
            let i = mounted
                .iter()
                .position(|s| s.name == *want)
                .ok_or_else(|| MapError::UnknownSensor {
                    sensor: (*want).to_owned(),
                    robot: robot.to_owned(),
                    known: mounted
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })?;
            mounts[i] = Some(mounted[i].mount);
        }
        Ok(Self {
            name: name.to_owned(),
            sensor_names: sensors.iter().map(|s| (*s).to_owned()).collect(),
            mounts,
            vehicle,
            config,
            grid: Grid::new(config.resolution, config.occupancy),
            beams: Vec::new(),
            scans: 0,
            last_body: None,
            coverage: None,
        })
    }

    /// Keeps the map inside `region` (m): see [`Grid::limit_to`].
    pub fn limit_to(&mut self, region: (DVec2, DVec2)) {
        self.grid.limit_to(region.0, region.1);
    }

    /// A mapper from a spec `a+b+…` of sensor names, named after it (`radar`, `radar+laser`).
    pub fn from_spec(spec: &str, robot: &Robot, config: MapConfig) -> Result<Self, MapError> {
        let names: Vec<&str> = spec.split('+').map(str::trim).collect();
        if names.iter().any(|n| n.is_empty()) {
            return Err(MapError::Config(format!(
                "map `{spec}`: expected sensor names joined by `+`"
            )));
        }
        let twice = (1..names.len()).find(|&i| names[..i].contains(&names[i]));
        if let Some(n) = twice.map(|i| names[i]) {
            return Err(MapError::Config(format!(
                "`{spec}` names the sensor `{n}` twice"
            )));
        }
        Self::new(&names.join("+"), robot, &names, config)
    }

    /// Samples the map's coverage against `truth` every `period` seconds of the run.
    pub fn track_coverage(&mut self, truth: Arc<Truth>, period: f64) {
        self.coverage = Some(CoverageTrack::new(truth, period));
    }

    /// The coverage samples so far (empty unless tracked).
    pub fn coverage(&self) -> &[CoverageSample] {
        self.coverage.as_ref().map_or(&[], |c| c.samples())
    }

    /// Takes a last coverage sample at the end of a run, at `time`.
    pub fn finish_coverage(&mut self, time: f64) {
        if let Some(c) = self.coverage.as_mut() {
            c.sample(time, &self.grid);
        }
    }

    /// The map's name (used in file names and topics).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The sensors that feed it.
    pub fn sensor_names(&self) -> &[String] {
        &self.sensor_names
    }

    /// Its settings.
    pub fn config(&self) -> &MapConfig {
        &self.config
    }

    /// The grid so far.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Scans inserted so far.
    pub fn scans(&self) -> u64 {
        self.scans
    }

    /// Height of the scan plane of its first sensor, m (where a 2D map of it is a slice).
    pub fn plane_z(&self) -> f64 {
        self.mounts.iter().flatten().next().map_or(0.0, |m| m.z)
    }

    /// Inserts `scan` as taken from `sensor_pose` (the pose the robot believes). Only what a
    /// real robot knows is used: each ray's range and its nominal direction from the nominal
    /// origin (not which side beam answered, nor how or where the ray really ended).
    pub fn insert_scan(&mut self, scan: &Scan, sensor_pose: &Pose) {
        if !scan.echo_start.is_empty() {
            self.insert_echo_scan(scan, sensor_pose);
            return;
        }
        self.beams.clear();
        let from = DVec2::new(sensor_pose.x, sensor_pose.y);
        let free_reach = self.config.max_free_range.min(scan.range_max);
        for (el, rays) in scan.planes() {
            let (se, ce) = el.sin_cos();
            for (k, i) in rays.enumerate() {
                let (s, c) = (sensor_pose.yaw + scan.azimuth(k)).sin_cos();
                let dir = DVec2::new(c, s);
                let r = f64::from(scan.ranges[i]);
                let (reach, hit) = if r.is_finite() && r <= self.config.max_range {
                    (r, sensor_pose.z + r * se >= self.config.ground_clearance)
                } else if r == f64::INFINITY || r > self.config.max_range {
                    (free_reach, false)
                } else {
                    continue; // closer than range_min, or not a number: no information
                };
                self.beams.push(Beam {
                    from,
                    to: from + dir * (reach * ce),
                    hit,
                });
            }
        }
        self.grid
            .insert(&self.beams, misses_are_passable(scan.kind));
        self.scans += 1;
    }

    /// Inserts a multi-echo scan (DESIGN §7.3): the first echo bounds what is passable (cells
    /// before it are free in both layers, its own cell an obstacle); the ray goes on through
    /// what made it, so the cells up to the last echo are clear to the sensor, a later surface
    /// echo is an obstacle, and the depth of a volume echo (foliage scattering from inside) is
    /// not passable: seen through but blocked, the thesis' grey.
    fn insert_echo_scan(&mut self, scan: &Scan, sensor_pose: &Pose) {
        let from = DVec2::new(sensor_pose.x, sensor_pose.y);
        let res = self.config.resolution;
        let free_reach = self.config.max_free_range.min(scan.range_max);
        let (mut first, mut through) = (Vec::new(), Vec::new());
        let mut inside: Vec<CellIndex> = Vec::new();
        let mut misses = Vec::new();
        for (el, rays) in scan.planes() {
            let (se, ce) = el.sin_cos();
            for (k, i) in rays.enumerate() {
                let (s, c) = (sensor_pose.yaw + scan.azimuth(k)).sin_cos();
                let dir = DVec2::new(c, s) * ce;
                let at = |r: f64| from + dir * r;
                let echoes = scan.echoes_of(i);
                let max_range = self.config.max_range;
                let seen = |r: f64| {
                    r <= max_range && sensor_pose.z + r * se >= self.config.ground_clearance
                };
                let Some(e1) = echoes.first() else {
                    if f64::from(scan.ranges[i]) == f64::INFINITY {
                        misses.push(Beam {
                            from,
                            to: at(free_reach),
                            hit: false,
                        });
                    }
                    continue;
                };
                if e1.range > max_range {
                    continue;
                }
                first.push(Beam {
                    from,
                    to: at(e1.range),
                    hit: seen(e1.range),
                });
                let Some(last) = echoes.iter().rev().find(|e| e.range <= max_range) else {
                    continue;
                };
                let end = last.range + last.depth;
                let start = e1.range + res;
                if end > start {
                    through.push(Beam {
                        from: at(start),
                        to: at(end.min(max_range)),
                        hit: last.depth == 0.0 && echoes.len() > 1 && seen(last.range),
                    });
                }
                for e in echoes
                    .iter()
                    .filter(|e| e.depth > 0.0 && e.range <= max_range)
                {
                    let walk = super::walk::CellWalk::new(
                        at(e.range),
                        at((e.range + e.depth).min(max_range)),
                        res,
                    );
                    inside.extend(walk);
                }
            }
        }
        self.grid.insert(&first, true);
        self.grid.insert(&through, false);
        self.grid.insert(&misses, misses_are_passable(scan.kind));
        // Neighbouring rays cross the same foliage cells: `mark_cells` changes each once.
        self.grid.mark_cells(inside, true, Layers::Passable);
        self.scans += 1;
    }

    /// Marks the cells under the body at `pose` passable.
    pub fn insert_body(&mut self, pose: &Pose) {
        let v = self.vehicle;
        let cells = cells_in_rect(pose, 0.0, v.length, v.width, self.config.resolution);
        self.grid.mark_cells(cells, false, Layers::Passable);
        self.last_body = Some(*pose);
    }

    /// Marks the strip just ahead of the body (behind it when `forward` is false) an
    /// obstacle: the robot at `pose` bumped into something there.
    pub fn insert_bump(&mut self, pose: &Pose, forward: bool) {
        let v = self.vehicle;
        let res = self.config.resolution;
        let depth = 1.5 * res;
        let ahead = (v.length + depth) / 2.0 * if forward { 1.0 } else { -1.0 };
        let cells = cells_in_rect(pose, ahead, depth, v.width, res);
        self.grid.mark_cells(cells, true, Layers::Passable);
    }

    /// The pose the map trusts; on `slam` without a localiser in the run, the odometry.
    fn pose_of(&self, truth: &Pose, odometry: &Pose, slam: Option<Pose>) -> Pose {
        match self.config.pose {
            PoseSource::Truth => *truth,
            PoseSource::Odometry => *odometry,
            PoseSource::Slam => slam.unwrap_or(*odometry),
        }
    }
}

/// Global cells whose centres lie in the `length` × `width` rectangle centred `ahead` metres
/// in front of `pose`, aligned with it.
fn cells_in_rect(pose: &Pose, ahead: f64, length: f64, width: f64, res: f64) -> Vec<CellIndex> {
    let (s, c) = pose.yaw.sin_cos();
    let fwd = DVec2::new(c, s);
    let left = DVec2::new(-s, c);
    let centre = DVec2::new(pose.x, pose.y) + fwd * ahead;
    let (hl, hw) = (length / 2.0, width / 2.0);
    let reach = DVec2::new(
        (fwd.x * hl).abs() + (left.x * hw).abs(),
        (fwd.y * hl).abs() + (left.y * hw).abs(),
    );
    let lo = ((centre - reach) / res).floor();
    let hi = ((centre + reach) / res).floor();
    let mut out = Vec::new();
    for j in lo.y as i64..=hi.y as i64 {
        for i in lo.x as i64..=hi.x as i64 {
            let d = (DVec2::new(i as f64, j as f64) + 0.5) * res - centre;
            if d.dot(fwd).abs() <= hl && d.dot(left).abs() <= hw {
                out.push((i, j));
            }
        }
    }
    out
}

impl Observer for Mapper {
    type Error = std::convert::Infallible;

    fn on_scan(&mut self, e: &ScanEvent<'_>) -> Result<(), Self::Error> {
        if let Some(Some(mount)) = self.mounts.get(e.sensor) {
            let pose = self.pose_of(&e.truth, &e.odometry, e.slam).compose(mount);
            self.insert_scan(e.scan, &pose);
        }
        Ok(())
    }

    fn on_step(&mut self, step: &Step) -> Result<(), Self::Error> {
        if let Some(c) = self.coverage.as_mut() {
            c.step(step.time, &step.truth, &self.grid);
        }
        if !self.config.body {
            return Ok(());
        }
        let pose = self.pose_of(&step.truth, &step.odometry, step.slam);
        let moved = self.last_body.is_none_or(|l| {
            (l.x - pose.x).hypot(l.y - pose.y) >= self.config.resolution / 2.0
                || crate::pose::wrap_angle(l.yaw - pose.yaw).abs() >= 2f64.to_radians()
        });
        if moved {
            self.insert_body(&pose);
        }
        if step.bumped && step.command.v != 0.0 {
            self.insert_bump(&pose, step.command.v > 0.0);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::grid::{CellClass, logit};
    use crate::sensor::Tracer;
    use crate::setup::Scenario;
    use crate::world::Shape;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A 4 m square room whose inner faces (x, y = ±2.025) run through the middle of a row
    /// of 0.05 m cells, so every return lands in that row whatever rounding does.
    const ROOM: &str = r#"
        [[object]]
        material = "concrete"
        box = { center = [0.0, 2.125], size = [4.45, 0.2, 1.0] }
        [[object]]
        material = "concrete"
        box = { center = [0.0, -2.125], size = [4.45, 0.2, 1.0] }
        [[object]]
        material = "concrete"
        box = { center = [2.125, 0.0], size = [0.2, 4.45, 1.0] }
        [[object]]
        material = "concrete"
        box = { center = [-2.125, 0.0], size = [0.2, 4.45, 1.0] }
        [[robot]]
        name = "r"
        vehicle = "p3at"
        start = { x = 0.013, y = -0.021 }
        [[robot.sensor]]
        name = "laser"
        preset = "hokuyo_utm30lx"
        fov_deg = 360.0
        range_noise_std = 0.0
        range_noise_rel = 0.0
        mount = { z = 0.4 }
        [[robot.sensor]]
        name = "radar"
        preset = "radar_thesis"
        mount = { z = 0.4 }
        [[robot.sensor]]
        name = "tilted"
        preset = "hokuyo_utm30lx"
        elevations_deg = [-30.0, 0.0]
        mount = { z = 0.4 }
    "#;

    /// A mapper of the room fed by `sensor`, and one scan of it from the robot's start.
    fn room_mapper(sensor: &str, config: MapConfig) -> (Mapper, Scan, Pose) {
        let s = Scenario::from_toml(ROOM, "room.toml", "room").unwrap();
        let m = Mapper::from_spec(sensor, &s.robots[0], config).unwrap();
        let (scan, pose) = scan_of(&s, sensor);
        (m, scan, pose)
    }

    fn scan_of(s: &Scenario, sensor: &str) -> (Scan, Pose) {
        let robot = &s.robots[0];
        let m = robot.sensor(sensor).unwrap();
        let pose = robot.start.compose(&m.mount);
        let scan = m.config.scan(
            &s.world,
            &pose,
            0.0,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut Tracer::default(),
        );
        (scan, pose)
    }

    /// The radar of foliage-wall in `all` mode maps the hedge it sees through as seen-through
    /// but impassable (grey) or obstacle; the thesis return leaves most of it clear.
    #[test]
    fn multi_echo_scan_maps_foliage_as_impassable() {
        let src = crate::scenario::builtin_source("foliage-wall").unwrap();
        let share = |src: &str| {
            let s = Scenario::from_toml(src, "fw.toml", "fw").unwrap();
            let mut m = Mapper::from_spec("radar", &s.robots[0], MapConfig::default()).unwrap();
            let (scan, pose) = scan_of(&s, "radar");
            // A robot standing still for 2.5 s: enough evidence for cells to settle.
            for _ in 0..10 {
                m.insert_scan(&scan, &pose);
            }
            // Cells inside the hedge's spheres at scan height, in sight of the robot.
            let mut inside = 0;
            let mut blocked = 0;
            for o in s.world.objects() {
                let Shape::Sphere { center, radius } = o.shape else {
                    continue;
                };
                let g = m.grid();
                let r = (radius * radius - (0.4 - center.z).powi(2)).sqrt() * 0.8;
                let n = (r / g.resolution()) as i64;
                let c = g.cell_of(center.truncate());
                for dx in -n..=n {
                    for dy in -n..=n {
                        let class = g.class((c.0 + dx, c.1 + dy));
                        if class != CellClass::Unknown {
                            inside += 1;
                            blocked += usize::from(class.blocks());
                        }
                    }
                }
            }
            blocked as f64 / inside as f64
        };
        let thesis = share(src);
        let all = share(&src.replace(
            "preset = \"radar_thesis\"",
            "preset = \"radar_thesis\"\nreturn = \"all\"",
        ));
        assert!(all > 0.9 && thesis < 0.5, "all {all}, thesis {thesis}");
    }

    #[test]
    fn one_scan_in_a_known_room_gives_the_exact_cells() {
        let (mut m, scan, pose) = room_mapper("laser", MapConfig::default());
        m.insert_scan(&scan, &pose);
        let g = m.grid();
        let (hit, miss) = (logit(0.7), logit(0.4));
        // Cells -41..=40 in each axis: the face rows are -41 ([-2.05, -2.0)) and 40
        // ([2.0, 2.05)); every cell between is crossed by some ray (0.25° rays are at most
        // 2.9 m × 0.0044 = 1.3 cm apart at the walls, under a cell).
        for j in -45..45i64 {
            for i in -45..45i64 {
                let face = (i == -41 || i == 40) && (-41..=40).contains(&j)
                    || (j == -41 || j == 40) && (-41..=40).contains(&i);
                let inside = (-40..40).contains(&i) && (-40..40).contains(&j);
                let want = if face {
                    (hit, hit)
                } else if inside {
                    (miss, miss)
                } else {
                    (0.0, 0.0)
                };
                assert_eq!(g.log_odds((i, j)), want, "cell ({i}, {j})");
            }
        }
        assert_eq!(g.class((40, 3)), CellClass::Obstacle);
        // One scan is not yet enough evidence to call a cell free.
        assert_eq!(g.class((0, 0)), CellClass::Unknown);
        for _ in 0..3 {
            m.insert_scan(&scan, &pose);
        }
        assert_eq!(m.grid().class((0, 0)), CellClass::Clear);
    }

    #[test]
    fn radar_misses_do_not_make_cells_passable() {
        let (mut m, scan, pose) = room_mapper("radar", MapConfig::default());
        for _ in 0..4 {
            m.insert_scan(&scan, &pose);
        }
        let (sensed, passable) = m.grid().log_odds((10, 0));
        assert!(sensed < logit(0.196));
        assert_eq!(passable, 0.0);
        assert_eq!(m.grid().class((10, 0)), CellClass::Clear);
        assert_eq!(
            m.grid().log_odds((40, 0)).1,
            logit(0.97).min(4.0 * logit(0.7))
        );
    }

    #[test]
    fn no_return_frees_up_to_the_max_free_range_and_marks_no_hit() {
        let config = MapConfig {
            max_free_range: 1.0,
            ..MapConfig::default()
        };
        let (mut m, mut scan, pose) = room_mapper("laser", config);
        scan.ranges.fill(f32::INFINITY);
        scan.ranges[0] = f32::NEG_INFINITY;
        // Beyond max_range (50 m): no hit, like no return.
        scan.ranges[100] = 60.0;
        m.insert_scan(&scan, &pose);
        let g = m.grid();
        assert!(g.sensed().iter().all(|&l| l <= 0.0), "no hit anywhere");
        // Ray 0 points along -x (the scan starts at -180°) and is ignored; others reach 1 m.
        assert_eq!(g.log_odds((19, 0)).0, logit(0.4));
        assert_eq!(g.log_odds((21, 0)).0, 0.0);
    }

    #[test]
    fn ground_returns_of_a_tilted_plane_are_not_obstacles() {
        let (mut m, scan, pose) = room_mapper("tilted", MapConfig::default());
        m.insert_scan(&scan, &pose);
        let g = m.grid();
        // The -30° plane meets the ground 0.4 / tan 30° = 0.69 m out: free up to there, no
        // hit; the level plane hits the walls, projected as they are.
        let (hit, miss) = (logit(0.7), logit(0.4));
        assert_eq!(
            g.log_odds((13, 0)).0,
            miss,
            "ground at 0.69 m is not an obstacle"
        );
        assert_eq!(g.log_odds((40, 0)).0, hit);
        // Every hit is at a wall face (within the laser's noise), none on the floor between.
        let (w, (oi, oj)) = (g.width(), g.origin_cell());
        for (k, _) in g.sensed().iter().enumerate().filter(|(_, l)| **l > 0.0) {
            let (i, j) = (oi + (k % w) as i64, oj + (k / w) as i64);
            assert!(i.abs() >= 38 || j.abs() >= 38, "hit at ({i}, {j})");
        }
    }

    #[test]
    fn unknown_sensor_and_bad_config_are_errors() {
        let s = Scenario::from_toml(ROOM, "room.toml", "room").unwrap();
        let e = Mapper::from_spec("radar+sonar", &s.robots[0], MapConfig::default()).unwrap_err();
        assert!(e.to_string().contains("sonar") && e.to_string().contains("laser, radar, tilted"));
        let bad = MapConfig {
            resolution: 0.0,
            ..MapConfig::default()
        };
        assert!(Mapper::from_spec("radar", &s.robots[0], bad).is_err());
        assert!(Mapper::from_spec("radar+", &s.robots[0], MapConfig::default()).is_err());
    }

    #[test]
    fn body_and_bumps_mark_the_passable_layer() {
        let s = Scenario::from_toml(ROOM, "room.toml", "room").unwrap();
        let mut m = Mapper::from_spec("laser", &s.robots[0], MapConfig::default()).unwrap();
        let pose = Pose::new(0.0, 0.0, 0.0, 0.0);
        m.insert_body(&pose);
        m.insert_bump(&pose, true);
        let g = m.grid();
        // The 0.508 × 0.497 m body covers cell centres within ±0.254 / ±0.2485 m.
        assert_eq!(g.log_odds((4, 4)), (0.0, logit(0.4)));
        assert_eq!(g.log_odds((-5, -5)), (0.0, logit(0.4)));
        assert_eq!(g.log_odds((5, 0)), (0.0, logit(0.7)), "just ahead: bumped");
        assert_eq!(g.log_odds((-6, 0)), (0.0, 0.0));
    }
}
