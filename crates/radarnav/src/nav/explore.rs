//! Exploration strategies (DESIGN §6), all on virtual bumpers:
//! * `bounce`: straight ahead until the front trips, then turn on the spot by a random
//!   angle in [90°, 270°] (the vacuum-robot strategy);
//! * `wall_follow`: find a wall and follow it ([`WallFollower`]);
//! * `spiral`: an Archimedean spiral out from where it starts, turns `SPIRAL_SPACING` apart;
//!   when the front trips it follows the wall for a while, then starts a new spiral;
//! * `frontier` (Yamauchi 1997): builds its own occupancy grid from its sensors at the pose
//!   it believes, and drives to the nearest reachable frontier (a sensor-clear cell next to
//!   unknown ones; for a radar also a place near foliage that borders unknown space, where it
//!   sees further through) along the cheapest path through clear cells: never nearer to
//!   anything that blocks than the body's turning circle plus the minimum clearance, and
//!   dearer the nearer it comes within the follow distance. A robot that starts nearer than
//!   that may leave the tight zone it stands in. It drives on while the body's corridor ahead
//!   is free (the bumpers' safety circle is wider than the ways it may take), gives a target
//!   up when blocked or once reached, and ends the mission when no frontier is reachable.

use std::collections::BinaryHeap;
use std::f64::consts::{PI, TAU};

use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::bug::MIN_CLEARANCE;
use super::bumper::{BumperConfig, BumperSensor, BumperState, Bumpers};
use super::wall_follow::{Side, WallFollower};
use super::{Behaviour, nav_pose};
use crate::map::{CellClass, MapConfig, Mapper, PoseSource};
use crate::pose::wrap_angle;
use crate::sensor::SensorKind;
use crate::sim::{ControlInput, Decision, Ending};
use crate::vehicle::DriveCommand;

/// Turn rate on the spot, rad/s.
const TURN_RATE: f64 = 0.8;
/// Distance between spiral turns, m.
pub const SPIRAL_SPACING: f64 = 1.5;
/// Starting radius of a spiral, m.
const SPIRAL_R0: f64 = 0.5;
/// How long the spiral strategy follows a wall before starting a new spiral, s.
const SPIRAL_WALL_TIME: f64 = 15.0;
/// Cell size of the frontier strategy's own grid, m.
pub const FRONTIER_RESOLUTION: f64 = 0.1;
/// How often the frontier strategy plans anew, s.
const FRONTIER_REPLAN: f64 = 2.0;
/// The frontier strategy ends when no frontier has been reachable for this long, s.
const GIVE_UP_AFTER: f64 = 6.0;
/// Frontiers nearer than this (in path length) are not targets, m: the rear of the robot is
/// unknown until the scans have swept it.
const MIN_FRONTIER_DISTANCE: f64 = 1.0;
/// The 8 neighbours of a cell.
const NEIGHBOURS: [(i64, i64); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
];
/// Look-ahead along the planned path, m.
const LOOKAHEAD: f64 = 0.6;
/// How far past the front the body's corridor must be free to drive on, m.
const AHEAD_CHECK: f64 = 0.25;
/// Margin round the body in that corridor, m.
const BODY_MARGIN: f64 = 0.05;
/// A radar's target near foliage lies within the wanted clearance and this of it, m.
const FOLIAGE_TARGET: f64 = 1.0;
/// Unknown space behind foliage worth going nearer for, m².
const HIDDEN_MIN_AREA: f64 = 4.0;
/// Extra path cost per metre where the clearance is nil (falling linearly to none at the
/// wanted clearance): a way twice as long in the open beats a tight one.
const CLEARANCE_WEIGHT: f64 = 2.0;

/// Clearances of planned paths from anything that blocks, m.
#[derive(Clone, Copy, Debug)]
struct Clearance {
    /// Never less.
    hard: f64,
    /// Where there is room.
    wanted: f64,
}

/// A cost and a cell, ordered for a min-heap.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cost(f64, usize);

impl Eq for Cost {}

impl Ord for Cost {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

impl PartialOrd for Cost {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// An exploration strategy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Straight, turn by a random angle at obstacles.
    Bounce,
    /// Follow walls.
    WallFollow,
    /// Centre-out spiral.
    Spiral,
    /// Nearest frontier on an occupancy grid.
    Frontier,
}

impl Strategy {
    /// Every strategy.
    pub const ALL: [Strategy; 4] = [Self::Bounce, Self::WallFollow, Self::Spiral, Self::Frontier];

    /// Parses a name as in [`Strategy::as_str`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.as_str() == s)
    }

    /// `bounce`, `wall_follow`, `spiral` or `frontier`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Bounce => "bounce",
            Self::WallFollow => "wall_follow",
            Self::Spiral => "spiral",
            Self::Frontier => "frontier",
        }
    }
}

/// The parameters of an exploration mission (`[mission] explore = "…"`).
#[derive(Clone, Debug, PartialEq)]
pub struct ExploreMission {
    /// Strategy.
    pub strategy: Strategy,
    /// Cruise speed, m/s.
    pub speed: f64,
    /// Side walls are kept on.
    pub follow: Side,
    /// The pose the frontier strategy maps and plans with.
    pub pose: PoseSource,
    /// Bumpers.
    pub bumpers: BumperConfig,
}

#[derive(Clone, Debug)]
enum Phase {
    Straight,
    Turn { left: f64, sign: f64 },
    Spiral { turned: f64 },
    Wall { until: f64 },
    Path,
}

/// Drives an [`ExploreMission`].
#[derive(Clone, Debug)]
pub struct ExploreController {
    mission: ExploreMission,
    rate_hz: f64,
    rng: ChaCha8Rng,
    bumpers: BumperSensor,
    follower: WallFollower,
    phase: Phase,
    frontier: Option<Frontier>,
}

impl ExploreController {
    /// A controller for `mission` at `rate_hz`; `seed` drives the random turns.
    pub fn new(mission: ExploreMission, rate_hz: f64, seed: u64) -> Self {
        let phase = match mission.strategy {
            Strategy::Bounce => Phase::Straight,
            Strategy::WallFollow => Phase::Wall {
                until: f64::INFINITY,
            },
            Strategy::Spiral => Phase::Spiral { turned: 0.0 },
            Strategy::Frontier => Phase::Path,
        };
        Self {
            bumpers: BumperSensor::new(mission.bumpers.clone()).believing(mission.pose),
            follower: WallFollower::new(mission.follow, mission.speed, TURN_RATE),
            rng: ChaCha8Rng::seed_from_u64(seed),
            phase,
            frontier: None,
            mission,
            rate_hz,
        }
    }

    /// Feeds new scans into the frontier strategy's own map, at the believed pose.
    fn map_scans(&mut self, input: &ControlInput<'_>) {
        let f = self.frontier.get_or_insert_with(|| {
            let names: Vec<&str> = input.sensors.iter().map(|s| s.name.as_str()).collect();
            let config = MapConfig {
                resolution: FRONTIER_RESOLUTION,
                ..MapConfig::default()
            };
            let mapper = Mapper::for_sensors(
                "frontier",
                "robot",
                input.sensors,
                input.vehicle,
                &names,
                config,
            )
            .ok();
            Frontier::new(mapper, input.sensors.len())
        });
        let Some(mapper) = f.mapper.as_mut() else {
            return;
        };
        for (i, scan) in input.scans.iter().enumerate() {
            let Some(scan) = scan else { continue };
            if scan.stamp == f.stamps[i] {
                continue;
            }
            f.stamps[i] = scan.stamp;
            let pose = match self.mission.pose {
                PoseSource::Truth => scan.pose,
                source => match super::scan_pose(source, input, i) {
                    Some(o) => o.compose(&input.sensors[i].mount),
                    None => continue,
                },
            };
            mapper.insert_scan(scan, &pose);
        }
    }

    fn frontier_step(&mut self, input: &ControlInput<'_>, b: &Bumpers, bumped: bool) -> Decision {
        let pose = nav_pose(self.mission.pose, input);
        let vehicle = input.vehicle;
        // The path keeps the follow distance where there is room and never less than the
        // body's turning circle plus the minimum clearance (the Bug's standoff floor).
        let clearance = Clearance {
            hard: 0.5 * vehicle.length.hypot(vehicle.width) + MIN_CLEARANCE,
            wanted: self.bumpers.follow_radius(vehicle),
        };
        // A radar also goes where it sees only through foliage, to see it better.
        let see_through = input
            .sensors
            .iter()
            .any(|s| s.config.kind == SensorKind::Radar);
        // Driving on needs the body's own corridor free a little ahead: the bumpers' safety
        // circle is wider than the ways the path may take.
        let ahead_free = b.corridor_free(
            0.0,
            vehicle.length / 2.0 + AHEAD_CHECK,
            vehicle.width / 2.0 + BODY_MARGIN,
        );
        let blocked = bumped || !ahead_free;
        let speed = self.mission.speed;
        let Some(f) = self.frontier.as_mut() else {
            return Decision::Drive(DriveCommand::STOP);
        };
        if f.done {
            return Decision::Finished(Ending::Completed);
        }
        // Plan only once every sensor has scanned.
        if f.stamps.iter().any(|s| !s.is_finite()) {
            return Decision::Drive(DriveCommand::STOP);
        }
        // Blocked ahead: give the target up, plan anew.
        if blocked && !f.path.is_empty() {
            if let Some(t) = f.target {
                f.rejected.push(t);
            }
            f.path.clear();
            f.next_plan = input.time;
        }
        if input.time >= f.next_plan || f.path.is_empty() {
            f.next_plan = input.time + FRONTIER_REPLAN;
            if f.plan(pose.xy(), clearance, see_through).is_some() {
                f.failing_since = None;
            } else {
                // A cell needs a few scans to count as clear: give up only when no frontier
                // has been reachable for a while.
                let since = *f.failing_since.get_or_insert(input.time);
                if input.time - since >= GIVE_UP_AFTER {
                    f.done = true;
                    return Decision::Finished(Ending::Completed);
                }
                f.next_plan = input.time + 0.5;
                return Decision::Drive(DriveCommand::STOP);
            }
        }
        // Pure pursuit on the path.
        let here = pose.xy();
        while f.path.len() > 1 && (f.path[0] - here).length() < LOOKAHEAD {
            f.path.remove(0);
        }
        let Some(&aim) = f.path.first() else {
            return Decision::Drive(DriveCommand::STOP);
        };
        if f.path.len() == 1 && (aim - here).length() < 0.3 {
            // There: if the target is still one at the next plan, looking from here did not
            // reveal it; do not come back for it.
            if let Some(t) = f.target.take() {
                f.rejected.push(t);
            }
            f.path.clear();
            return Decision::Drive(DriveCommand::STOP);
        }
        let err = wrap_angle((aim - here).to_angle() - pose.yaw);
        let omega = (1.5 * err).clamp(-TURN_RATE, TURN_RATE);
        let v = if err.abs() > 0.52 {
            0.0
        } else {
            speed * err.cos()
        };
        if v > 0.0 && !ahead_free {
            // Something the map missed is in the way: turn toward the path on the spot; the
            // next plan gives the target up.
            return Decision::Drive(DriveCommand::twist(0.0, omega));
        }
        Decision::Drive(DriveCommand::twist(v, omega))
    }
}

/// Whether the front sector (and, with 8 sectors, the diagonals beside it) reports
/// something at or inside the band.
fn front_trips(b: &Bumpers) -> bool {
    let diag = if b.sectors() == 8 { 1 } else { 0 };
    (-diag..=diag).any(|k| {
        let s = b.state(k);
        s == BumperState::TooClose || (k == 0 && s == BumperState::Pressed)
    })
}

impl Behaviour for ExploreController {
    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn bumpers(&self) -> Option<&Bumpers> {
        self.bumpers.latest()
    }

    fn touched(&mut self, input: &ControlInput<'_>, moving: (f64, f64)) {
        self.bumpers.touched(input, moving);
    }

    fn decide(&mut self, input: &ControlInput<'_>, bumped: bool) -> Decision {
        let dt = 1.0 / self.rate_hz;
        if self.mission.strategy == Strategy::Frontier {
            self.map_scans(input);
        }
        let Some(b) = self.bumpers.update(input).cloned() else {
            return Decision::Drive(DriveCommand::STOP);
        };
        let speed = self.mission.speed;
        let radius = self.bumpers.follow_radius(input.vehicle);
        let pose = nav_pose(self.mission.pose, input);
        let front_blocked = bumped || front_trips(&b);
        match &mut self.phase {
            Phase::Straight => {
                if front_blocked {
                    let angle = self.rng.random_range(0.5 * PI..1.5 * PI);
                    let sign = if self.rng.random_bool(0.5) { 1.0 } else { -1.0 };
                    self.phase = Phase::Turn { left: angle, sign };
                    return Decision::Drive(DriveCommand::STOP);
                }
                // Something too close at a side: veer away from it while going on.
                let q = b.sectors() as isize / 4;
                let side = |k| b.state(k) == BumperState::TooClose;
                let omega = match (side(q), side(-q)) {
                    (true, false) => -0.5 * TURN_RATE,
                    (false, true) => 0.5 * TURN_RATE,
                    _ => 0.0,
                };
                Decision::Drive(DriveCommand::twist(speed, omega))
            }
            Phase::Turn { left, sign } => {
                if *left <= 0.0 && !front_blocked {
                    self.phase = Phase::Straight;
                    return Decision::Drive(DriveCommand::twist(speed, 0.0));
                }
                *left -= TURN_RATE * dt;
                Decision::Drive(DriveCommand::twist(0.0, *sign * TURN_RATE))
            }
            Phase::Spiral { turned } => {
                if front_blocked {
                    self.follower = WallFollower::new(self.mission.follow, speed, TURN_RATE);
                    self.follower.engage();
                    self.phase = Phase::Wall {
                        until: input.time + SPIRAL_WALL_TIME,
                    };
                    return Decision::Drive(self.follower.command(&b, &pose, dt, radius));
                }
                let r = SPIRAL_R0 + SPIRAL_SPACING * *turned / TAU;
                let omega = self.mission.follow.sign() * speed / r;
                *turned += omega.abs() * dt;
                Decision::Drive(DriveCommand::twist(speed, omega))
            }
            Phase::Wall { until } => {
                if bumped {
                    self.follower.bumped();
                }
                if input.time >= *until && !front_blocked {
                    self.phase = Phase::Spiral { turned: 0.0 };
                }
                Decision::Drive(self.follower.command(&b, &pose, dt, radius))
            }
            Phase::Path => self.frontier_step(input, &b, bumped),
        }
    }
}

/// Distance of every cell of a `w` × `h` grid of `res`-metre cells to the nearest of `seeds`
/// (cell indices), out to `cap` metres (farther: infinite): a brushfire on the 8-neighbour
/// grid, within a few per cent of Euclidean.
///
/// A cell within `cap` lowers each neighbour to its own distance plus the step (`res`, or
/// `res`·√2 across a corner) until no cell changes. Every order of those relaxations ends in
/// the same distances, bit for bit (addition rounds monotonically, so the values one order
/// reaches bound the other's from below), so the order need not be a heap's: cells wait in
/// buckets one cell wide by distance (Dial's algorithm; a step is at least a bucket, so a
/// cell is almost never lowered after it spread), under half the heap's time.
fn brushfire(seeds: &[usize], w: usize, h: usize, res: f64, cap: f64) -> Vec<f64> {
    let mut dist = vec![f64::INFINITY; w * h];
    for &k in seeds {
        dist[k] = 0.0;
    }
    let diagonal = res * 2f64.sqrt();
    // No path on the grid is longer than (w + h) diagonal steps: the buckets stay few
    // whatever the cap.
    let reach = cap.min((w + h) as f64 * diagonal);
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); (reach / res) as usize + 2];
    // Only seeds beside a cell that is not one spread: inside a wall a seed has nothing to
    // lower.
    buckets[0] = seeds
        .iter()
        .copied()
        .filter(|&k| {
            NEIGHBOURS
                .iter()
                .any(|&step| neighbour(k, step, w, h).is_some_and(|n| dist[n] > 0.0))
        })
        .collect();
    for bucket in 0..buckets.len() {
        while let Some(k) = buckets[bucket].pop() {
            let d = dist[k];
            if d > cap {
                continue;
            }
            for (di, dj) in NEIGHBOURS {
                let Some(n) = neighbour(k, (di, dj), w, h) else {
                    continue;
                };
                let nd = d + if di != 0 && dj != 0 { diagonal } else { res };
                if nd < dist[n] {
                    dist[n] = nd;
                    // Beyond the cap a cell spreads nothing: it needs no bucket.
                    if nd <= cap {
                        let to = ((nd / res) as usize).clamp(bucket, buckets.len() - 1);
                        buckets[to].push(n);
                    }
                }
            }
        }
    }
    dist
}

/// Cell `k`'s neighbour one `(column, row)` step away on a `w` × `h` grid (row-major), if
/// the grid holds it.
fn neighbour(k: usize, (di, dj): (i64, i64), w: usize, h: usize) -> Option<usize> {
    let (a, b) = ((k % w) as i64 + di, (k / w) as i64 + dj);
    (a >= 0 && b >= 0 && (a as usize) < w && (b as usize) < h).then(|| b as usize * w + a as usize)
}

/// The frontier strategy's map and plan.
#[derive(Clone, Debug)]
struct Frontier {
    mapper: Option<Mapper>,
    stamps: Vec<f64>,
    path: Vec<DVec2>,
    next_plan: f64,
    rejected: Vec<DVec2>,
    target: Option<DVec2>,
    failing_since: Option<f64>,
    done: bool,
}

impl Frontier {
    /// A planner on `mapper` (fed by `sensors` sensors), with no scan yet.
    fn new(mapper: Option<Mapper>, sensors: usize) -> Self {
        Self {
            mapper,
            stamps: vec![f64::NEG_INFINITY; sensors],
            path: Vec::new(),
            next_plan: 0.0,
            rejected: Vec::new(),
            target: None,
            failing_since: None,
            done: false,
        }
    }

    /// Plans a path from `from` to the nearest reachable frontier (by a path cost that grows
    /// where the clearance falls below `clearance.wanted`) through clear cells at least
    /// `clearance.hard` from any blocking cell. A robot standing nearer than that to something
    /// may leave the zone it stands in, never cross another. `None`: no frontier is reachable.
    ///
    /// With `see_through`, a reachable cell within the wanted clearance (and a metre) of
    /// foliage that borders unknown space (of [`HIDDEN_MIN_AREA`] or more) is a target too:
    /// nearer, a radar sees further through it.
    fn plan(&mut self, from: DVec2, clearance: Clearance, see_through: bool) -> Option<()> {
        let grid = self.mapper.as_ref()?.grid();
        let (w, h) = (grid.width(), grid.height());
        let res = grid.resolution();
        let (oi, oj) = grid.origin_cell();
        let classes = grid.classes();
        let at = |i: i64, j: i64| -> Option<usize> {
            (i >= 0 && j >= 0 && (i as usize) < w && (j as usize) < h)
                .then(|| j as usize * w + i as usize)
        };
        // Distance of every cell to the nearest blocking one, up to the wanted clearance.
        let cap = clearance.wanted.max(clearance.hard) + res;
        let blocking: Vec<usize> = (0..w * h).filter(|&k| classes[k].blocks()).collect();
        let dist = brushfire(&blocking, w, h, res, cap);
        let start_cell = grid.cell_of(from);
        let start = at(start_cell.0 - oi, start_cell.1 - oj)?;
        let centre = |k: usize| {
            DVec2::new(
                (oi + (k % w) as i64) as f64 + 0.5,
                (oj + (k / w) as i64) as f64 + 0.5,
            ) * res
        };
        // A frontier cell has at least 3 unknown cells among its 8 neighbours: single unknown
        // cells between the rays of a far scan are not frontiers.
        let is_frontier = |k: usize| {
            let (i, j) = ((k % w) as i64, (k / w) as i64);
            NEIGHBOURS
                .iter()
                .filter(|(di, dj)| {
                    at(i + di, j + dj).is_none_or(|n| classes[n] == CellClass::Unknown)
                })
                .count()
                >= 3
        };
        let tight = |k: usize| dist[k] < clearance.hard;
        // Distance to foliage (seen through, impassable) that borders unknown space of some
        // size.
        let reach = clearance.wanted + FOLIAGE_TARGET;
        let mut to_foliage = Vec::new();
        if see_through {
            // Unknown regions by size: the inside of a bush the radar never sees into is no
            // reason to go anywhere.
            let mut region = vec![usize::MAX; w * h];
            let mut sizes = Vec::new();
            for k0 in 0..w * h {
                if classes[k0] != CellClass::Unknown || region[k0] != usize::MAX {
                    continue;
                }
                let id = sizes.len();
                let mut stack = vec![k0];
                region[k0] = id;
                let mut n = 0usize;
                while let Some(k) = stack.pop() {
                    n += 1;
                    let (i, j) = ((k % w) as i64, (k / w) as i64);
                    for (di, dj) in &NEIGHBOURS[..4] {
                        if let Some(m) = at(i + di, j + dj)
                            && classes[m] == CellClass::Unknown
                            && region[m] == usize::MAX
                        {
                            region[m] = id;
                            stack.push(m);
                        }
                    }
                }
                sizes.push(n);
            }
            let worth = (HIDDEN_MIN_AREA / (res * res)).ceil() as usize;
            let foliage: Vec<usize> = (0..w * h)
                .filter(|&k| {
                    let (i, j) = ((k % w) as i64, (k / w) as i64);
                    classes[k] == CellClass::SeeThrough
                        && NEIGHBOURS.iter().any(|(di, dj)| {
                            at(i + di, j + dj).is_some_and(|n| {
                                classes[n] == CellClass::Unknown && sizes[region[n]] >= worth
                            })
                        })
                })
                .collect();
            to_foliage = brushfire(&foliage, w, h, res, reach);
        }
        // Path cost: length, times up to 1 + CLEARANCE_WEIGHT where the clearance is below
        // the wanted one.
        let step_cost = |n: usize, len: f64| {
            let short = ((clearance.wanted - dist[n]) / clearance.wanted).clamp(0.0, 1.0);
            len * (1.0 + CLEARANCE_WEIGHT * short)
        };
        let mut cost = vec![f64::INFINITY; w * h];
        let mut travelled = vec![0.0f64; w * h];
        let mut parent = vec![usize::MAX; w * h];
        // Cells reached through too-tight cells only: the robot may leave the tight zone it
        // stands in, but not cross one.
        let mut escaping = vec![false; w * h];
        cost[start] = 0.0;
        parent[start] = start;
        escaping[start] = true;
        let mut queue = BinaryHeap::from([Cost(0.0, start)]);
        let mut found = None;
        while let Some(Cost(c, k)) = queue.pop() {
            if c > cost[k] {
                continue;
            }
            if travelled[k] >= MIN_FRONTIER_DISTANCE
                && !tight(k)
                && (is_frontier(k) || to_foliage.get(k).is_some_and(|&d| d <= reach))
                && !self
                    .rejected
                    .iter()
                    .any(|r| (*r - centre(k)).length() < 1.0)
            {
                found = Some(k);
                break;
            }
            let (i, j) = ((k % w) as i64, (k / w) as i64);
            for (di, dj) in NEIGHBOURS {
                let Some(n) = at(i + di, j + dj) else {
                    continue;
                };
                if classes[n] != CellClass::Clear || (tight(n) && !escaping[k]) {
                    continue;
                }
                let len = res * ((di * di + dj * dj) as f64).sqrt();
                let nc = c + step_cost(n, len);
                if nc < cost[n] {
                    cost[n] = nc;
                    travelled[n] = travelled[k] + len;
                    parent[n] = k;
                    escaping[n] = escaping[k] && tight(n);
                    queue.push(Cost(nc, n));
                }
            }
        }
        let goal = found?;
        let mut cells = vec![goal];
        while let Some(&k) = cells.last() {
            if k == start {
                break;
            }
            cells.push(parent[k]);
        }
        cells.reverse();
        self.path = cells.into_iter().skip(1).step_by(3).map(centre).collect();
        let end = centre(goal);
        if self.path.last() != Some(&end) {
            self.path.push(end);
        }
        self.target = Some(end);
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::bumper::tests::ring_scan;
    use crate::pose::Pose;
    use crate::sensor::preset;
    use crate::setup::MountedSensor;

    const HALF_METRE: Clearance = Clearance {
        hard: 0.5,
        wanted: 0.5,
    };

    #[test]
    fn neighbours_stay_on_the_grid() {
        // 3 × 2 grid: 0 1 2 / 3 4 5.
        assert_eq!(neighbour(0, (1, 0), 3, 2), Some(1));
        assert_eq!(neighbour(0, (1, 1), 3, 2), Some(4));
        assert_eq!(neighbour(0, (-1, 0), 3, 2), None);
        assert_eq!(neighbour(2, (1, 0), 3, 2), None, "no wrap to the next row");
        assert_eq!(neighbour(3, (0, -1), 3, 2), Some(0));
        assert_eq!(neighbour(5, (0, 1), 3, 2), None);
        assert_eq!(neighbour(4, (-1, -1), 3, 2), Some(0));
    }

    proptest::proptest! {
        /// The brushfire's distances are the fixed point of relaxing every cell within the
        /// cap into its neighbours, bit for bit, walls of seeds included.
        #[test]
        fn brushfire_is_the_relaxed_distance(
            seeded in proptest::collection::vec(proptest::bool::weighted(0.3), 1..200),
            w in 1usize..16,
            cap in 0.05f64..0.6,
        ) {
            let h = seeded.len().div_ceil(w);
            let seeds: Vec<usize> = (0..w * h)
                .filter(|&k| seeded.get(k).copied().unwrap_or(false))
                .collect();
            let res = 0.05;
            let mut want = vec![f64::INFINITY; w * h];
            for &k in &seeds {
                want[k] = 0.0;
            }
            let mut changed = true;
            while changed {
                changed = false;
                for k in 0..w * h {
                    if want[k] > cap {
                        continue;
                    }
                    for (di, dj) in NEIGHBOURS {
                        let Some(n) = neighbour(k, (di, dj), w, h) else {
                            continue;
                        };
                        let nd = want[k] + res * ((di * di + dj * dj) as f64).sqrt();
                        if nd < want[n] {
                            want[n] = nd;
                            changed = true;
                        }
                    }
                }
            }
            let got = brushfire(&seeds, w, h, res, cap);
            let bits = |v: &[f64]| v.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
            proptest::prop_assert_eq!(bits(&got), bits(&want));
        }
    }

    /// A frontier planner whose map holds five scans from the origin of a 3 m ring of walls,
    /// open (no return) for |azimuth| < `gap_deg`.
    fn planner(gap_deg: f64) -> Frontier {
        let sensors = [MountedSensor {
            name: "radar".into(),
            config: preset("radar_thesis").unwrap(),
            mount: Pose::default(),
        }];
        let vehicle = crate::vehicle::vehicle("p3at").unwrap();
        let config = MapConfig {
            resolution: FRONTIER_RESOLUTION,
            ..MapConfig::default()
        };
        let mut mapper =
            Mapper::for_sensors("f", "r", &sensors, vehicle, &["radar"], config).unwrap();
        let scan = ring_scan(720, |a: f64| {
            if a.abs().to_degrees() < gap_deg {
                f32::INFINITY
            } else {
                3.0
            }
        });
        // At scan height: returns of a plane at the floor would not be obstacles.
        let sensor = Pose::new(0.0, 0.0, 0.4, 0.0);
        for _ in 0..5 {
            mapper.insert_scan(&scan, &sensor);
        }
        Frontier::new(Some(mapper), 1)
    }

    #[test]
    fn the_nearest_frontier_is_where_the_walls_open() {
        let mut f = planner(20.0);
        assert!(f.plan(DVec2::ZERO, HALF_METRE, false).is_some());
        let t = f.target.unwrap();
        // Beyond the ring's radius, inside the opening.
        assert!(
            t.length() > 2.9 && t.to_angle().abs().to_degrees() < 21.0,
            "{t}"
        );
        // The path starts near the robot, ends at the target and keeps the hard clearance
        // (less half a cell) from the ring's wall.
        assert!(f.path[0].length() < 0.5 && *f.path.last().unwrap() == t);
        for p in &f.path {
            for a in (40..=680).map(|h| f64::from(h) / 2.0) {
                let wall = DVec2::from_angle(a.to_radians()) * 3.0;
                assert!((*p - wall).length() >= 0.45, "{p} near the wall at {a}°");
            }
        }
        // Starting 0.3 m from the wall, inside the hard clearance: it leaves that zone.
        let mut near = planner(20.0);
        assert!(
            near.plan(DVec2::new(-2.7, 0.0), HALF_METRE, false)
                .is_some()
        );
        assert!(near.target.unwrap().to_angle().abs().to_degrees() < 21.0);
        // A rejected target is not chosen again.
        f.rejected.push(t);
        assert!(f.plan(DVec2::ZERO, HALF_METRE, false).is_some());
        assert!((f.target.unwrap() - t).length() >= 1.0);
    }

    #[test]
    fn a_closed_ring_has_no_frontier() {
        let mut f = planner(0.0);
        assert!(f.plan(DVec2::ZERO, HALF_METRE, false).is_none());
        // Nor does a ring whose opening is narrower than the robot's keep-off circle.
        let mut narrow = planner(4.0);
        assert!(narrow.plan(DVec2::ZERO, HALF_METRE, false).is_none());
    }

    #[test]
    fn strategies_parse_by_name() {
        for s in Strategy::ALL {
            assert_eq!(Strategy::parse(s.as_str()), Some(s));
        }
        assert_eq!(Strategy::parse("zigzag"), None);
    }
}
