//! What the geometry of a Bug trial implies, computed on a raster of the world: the outcome
//! (is there a way for the robot's disc from start to goal?) and the classic path bounds.
//!
//! * **Outcome**: `reached` when a disc of the robot's half-diagonal (it can turn anywhere
//!   on it) can move from the start to within the goal tolerance, else `no_path`.
//! * **Bounds** (Choset et al. 2005, ch. 2; Lumelsky & Stepanov 1987), with every obstacle
//!   grown by the standoff the robot follows boundaries at:
//!   Bug1 ≤ d + 1.5 Σ pᵢ over the grown obstacles within d of the goal; Bug2 ≤ d + ½ Σ nᵢ pᵢ
//!   with nᵢ the number of times the m-line crosses the boundary of grown obstacle i, made
//!   even (a goal inside an obstacle is known unreachable only after going once round it).
//!   Obstacles closer than twice the standoff merge when grown: the robot follows them as one.
//!   A perimeter counts only the boundary that faces space the robot can reach (the outside
//!   of a hall's walls is nobody's path).
//!
//! What blocks depends on the sensor: a laser sees smoke as a wall, so for it a laser-opaque
//! volume is an obstacle even though the robot could drive through it.

use glam::DVec2;
use rayon::prelude::*;

use crate::map::truth::flood_fill_from;
use crate::world::overlap::body_box;
use crate::world::{Material, World};

/// Raster cell, m: fine enough for a 0.8 m doorway to be 16 cells.
pub const CELL: f64 = 0.05;

/// Extinction above which a laser sees an aerosol as a wall (mean free path ≤ 1 m), 1/m.
const LASER_WALL_EXTINCTION: f64 = 1.0;

/// Which kind of sensor the robot steers by: it decides what looks like an obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorClass {
    /// Sees through foliage and smoke; foliage still stops the robot.
    Radar,
    /// Stops at foliage and at laser-opaque smoke or dense dust.
    Laser,
}

impl SensorClass {
    /// `radar` or `laser`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Radar => "radar",
            Self::Laser => "laser",
        }
    }

    /// Whether an object of `m` is in the robot's way as far as this sensor's user can tell.
    pub fn blocks(self, m: &Material) -> bool {
        !m.traversable
            || (self == Self::Laser
                && (m.laser_opaque || m.laser_extinction_per_m >= LASER_WALL_EXTINCTION))
    }
}

/// What a trial's geometry implies.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Expectation {
    /// Whether the goal can be reached.
    pub reachable: bool,
    /// Straight-line distance start to goal, m.
    pub straight: f64,
    /// Bug1's bound, m.
    pub bug1_bound: f64,
    /// Bug2's bound, m.
    pub bug2_bound: f64,
    /// Grown obstacles (connected components).
    pub obstacles: usize,
}

/// A trial's geometry: where the robot starts and must go, how big it is and how far from
/// boundaries it keeps.
#[derive(Clone, Copy, Debug)]
pub struct TrialGeometry {
    /// Start, m.
    pub start: DVec2,
    /// Goal, m.
    pub goal: DVec2,
    /// Goal tolerance, m.
    pub tolerance: f64,
    /// Half the robot's diagonal, m.
    pub radius: f64,
    /// Distance from the robot's centre to a followed boundary, m.
    pub standoff: f64,
    /// Height band the robot collides in, m (from the ground).
    pub height: f64,
    /// Height of the sensor's scan plane, m.
    pub plane_z: f64,
}

/// A boolean raster over a rectangle of the world.
struct Raster {
    origin: DVec2,
    width: usize,
    height: usize,
}

impl Raster {
    fn centre(&self, k: usize) -> DVec2 {
        self.origin
            + DVec2::new((k % self.width) as f64 + 0.5, (k / self.width) as f64 + 0.5) * CELL
    }

    fn index(&self, p: DVec2) -> Option<usize> {
        let q = (p - self.origin) / CELL;
        (q.x >= 0.0 && q.y >= 0.0 && (q.x as usize) < self.width && (q.y as usize) < self.height)
            .then(|| q.y as usize * self.width + q.x as usize)
    }
}

/// A world rasterised for trials: which cells block a robot steering by one sensor, and each
/// cell's distance to the nearest blocking cell. Build it once per map and sensor; ask it for
/// any start, goal and standoff.
pub struct Field {
    r: Raster,
    dist: Vec<f64>,
}

impl Field {
    /// Rasterises `world` around `extra` points (start, goal) for `sensor`; `height` is the
    /// band the robot collides in, `plane_z` the sensor's scan plane, `margin` how far past
    /// the world's bounds to reach (the largest standoff asked, and some).
    pub fn new(
        world: &World,
        sensor: SensorClass,
        height: f64,
        plane_z: f64,
        extra: &[DVec2],
        margin: f64,
    ) -> Self {
        let mut lo = extra.iter().copied().fold(DVec2::INFINITY, DVec2::min);
        let mut hi = extra.iter().copied().fold(DVec2::NEG_INFINITY, DVec2::max);
        if let Some((a, b)) = world.bounds() {
            lo = lo.min(a.truncate());
            hi = hi.max(b.truncate());
        }
        if !lo.is_finite() || !hi.is_finite() {
            (lo, hi) = (DVec2::ZERO, DVec2::ZERO);
        }
        let origin = lo - DVec2::splat(margin);
        let size = hi - lo + DVec2::splat(2.0 * margin);
        let r = Raster {
            origin,
            width: (size.x / CELL).ceil() as usize,
            height: (size.y / CELL).ceil() as usize,
        };
        let n = r.width * r.height;
        // A cell blocks when its centre lies in a blocking object: the boundary is then off by
        // at most half a cell either way (a cell merely touched would narrow a doorway by two).
        const POINT: f64 = 1e-3;
        let obstacle: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|k| {
                let c = r.centre(k);
                let body = body_box(c.x, c.y, 0.0, POINT, POINT, height);
                // The scan plane decides what a sensor sees; the body band what it hits.
                let plane = body_box(c.x, c.y, plane_z - POINT, POINT, POINT, 2.0 * POINT);
                world
                    .overlapping_object(&body, |m| !m.traversable)
                    .is_some()
                    || world
                        .overlapping_object(&plane, |m| m.traversable && sensor.blocks(m))
                        .is_some()
            })
            .collect();
        let dist = distance_transform(&obstacle, r.width, r.height);
        Self { r, dist }
    }

    /// The [`Expectation`] of `g` (its height and plane are the field's).
    pub fn expect(&self, g: &TrialGeometry) -> Expectation {
        let (r, dist) = (&self.r, &self.dist);
        let n = r.width * r.height;
        // The disc fits where the nearest blocking centre is farther than the radius plus
        // half a cell (where the object's surface may lie).
        let fits: Vec<bool> = dist.iter().map(|&d| d > g.radius + CELL / 2.0).collect();
        let reach = flood_fill_from(
            &fits,
            r.width,
            r.height,
            seeds(r, &fits, g.start, g.radius).into_iter(),
        );
        let reachable = (0..n).any(|k| reach[k] && r.centre(k).distance(g.goal) <= g.tolerance);
        let grown: Vec<bool> = dist.iter().map(|&d| d <= g.standoff).collect();
        let (labels, count) = components(&grown, r.width, r.height);
        let perimeters = perimeters(&labels, count, &reach, r);
        let straight = g.start.distance(g.goal);
        // Bug1: every grown obstacle with a cell within d of the goal.
        let mut near = vec![false; count];
        for (k, label) in labels.iter().enumerate() {
            if let Some(c) = *label
                && r.centre(k).distance(g.goal) <= straight
            {
                near[c as usize] = true;
            }
        }
        let bug1 = straight
            + 1.5
                * perimeters
                    .iter()
                    .zip(&near)
                    .filter(|(_, n)| **n)
                    .map(|(p, _)| p)
                    .sum::<f64>();
        // Bug2: boundary crossings of the m-line, per grown obstacle.
        let mut crossings = vec![0usize; count];
        let samples = (straight / (CELL / 2.0)).ceil().max(1.0) as usize;
        let mut prev = None;
        for i in 0..=samples {
            let p = g.start.lerp(g.goal, i as f64 / samples as f64);
            let here = r.index(p).and_then(|k| labels[k]);
            if here != prev {
                for c in [prev, here].into_iter().flatten() {
                    crossings[c as usize] += 1;
                }
            }
            prev = here;
        }
        // A line that ends inside a grown obstacle (a goal in a pen) crosses its boundary an
        // odd number of times, yet the robot goes once round it to tell it cannot get in:
        // count a crossing more, as if the line left it again.
        let bug2 = straight
            + 0.5
                * perimeters
                    .iter()
                    .zip(&crossings)
                    .map(|(p, &c)| p * c.next_multiple_of(2) as f64)
                    .sum::<f64>();
        Expectation {
            reachable,
            straight,
            bug1_bound: bug1,
            bug2_bound: bug2,
            obstacles: count,
        }
    }
}

/// Computes the [`Expectation`] of `g` in `world` for a robot steering by `sensor`.
pub fn expect(world: &World, g: &TrialGeometry, sensor: SensorClass) -> Expectation {
    Field::new(
        world,
        sensor,
        g.height,
        g.plane_z,
        &[g.start, g.goal],
        g.standoff + 1.0,
    )
    .expect(g)
}

/// Cells to start the flood from: the start's cell, or if the disc does not fit there (a
/// start close to a wall), the fitting cells within the disc's radius of it.
fn seeds(r: &Raster, fits: &[bool], start: DVec2, radius: f64) -> Vec<usize> {
    if let Some(k) = r.index(start).filter(|&k| fits[k]) {
        return vec![k];
    }
    let span = (radius / CELL).ceil() as i64 + 1;
    let mut out = Vec::new();
    for dy in -span..=span {
        for dx in -span..=span {
            let p = start + DVec2::new(dx as f64, dy as f64) * CELL;
            if p.distance(start) <= radius
                && let Some(k) = r.index(p).filter(|&k| fits[k])
            {
                out.push(k);
            }
        }
    }
    out
}

/// Euclidean distance, m, from each cell's centre to the nearest `set` cell's centre
/// (Felzenszwalb & Huttenlocher 2012, exact, linear time).
fn distance_transform(set: &[bool], width: usize, height: usize) -> Vec<f64> {
    const FAR: f64 = 1e20;
    let mut d: Vec<f64> = set.iter().map(|&s| if s { 0.0 } else { FAR }).collect();
    let len = width.max(height);
    let (mut f, mut out, mut v, mut z) = (
        vec![0.0; len],
        vec![0.0; len],
        vec![0usize; len],
        vec![0.0; len + 1],
    );
    for y in 0..height {
        f[..width].copy_from_slice(&d[y * width..(y + 1) * width]);
        edt_1d(&f[..width], &mut out, &mut v, &mut z);
        d[y * width..(y + 1) * width].copy_from_slice(&out[..width]);
    }
    for x in 0..width {
        for y in 0..height {
            f[y] = d[y * width + x];
        }
        edt_1d(&f[..height], &mut out, &mut v, &mut z);
        for y in 0..height {
            d[y * width + x] = out[y];
        }
    }
    d.iter().map(|&s| s.sqrt() * CELL).collect()
}

/// Squared distance transform of a sampled function `f` along one line (lower envelope of
/// parabolas).
fn edt_1d(f: &[f64], out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    if n == 0 {
        return;
    }
    let mut k = 0;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let qf = q as f64;
        loop {
            let p = v[k] as f64;
            let s = ((f[q] + qf * qf) - (f[v[k]] + p * p)) / (2.0 * (qf - p));
            if s <= z[k] && k > 0 {
                k -= 1;
            } else if s <= z[k] {
                // k == 0 and the new parabola is lower everywhere to the left.
                v[0] = q;
                z[0] = f64::NEG_INFINITY;
                z[1] = f64::INFINITY;
                break;
            } else {
                k += 1;
                v[k] = q;
                z[k] = s;
                z[k + 1] = f64::INFINITY;
                break;
            }
        }
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
}

/// Connected components (8-neighbours) of `set`: each cell's label and the count.
fn components(set: &[bool], width: usize, height: usize) -> (Vec<Option<u32>>, usize) {
    let mut label = vec![None; set.len()];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for s in 0..set.len() {
        if !set[s] || label[s].is_some() {
            continue;
        }
        label[s] = Some(count);
        stack.push(s);
        while let Some(k) = stack.pop() {
            let (i, j) = ((k % width) as i64, (k / width) as i64);
            for dj in -1..=1 {
                for di in -1..=1 {
                    let (x, y) = (i + di, j + dj);
                    if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
                        continue;
                    }
                    let n = y as usize * width + x as usize;
                    if set[n] && label[n].is_none() {
                        label[n] = Some(count);
                        stack.push(n);
                    }
                }
            }
        }
        count += 1;
    }
    (label, count as usize)
}

/// Length of each component's boundary that faces `reach` cells, m: marching squares over
/// the cell centres (a straight run of cells gives its exact length, a 45° edge its exact
/// length too).
fn perimeters(labels: &[Option<u32>], count: usize, reach: &[bool], r: &Raster) -> Vec<f64> {
    let mut p = vec![0.0; count];
    let diag = CELL * std::f64::consts::FRAC_1_SQRT_2;
    for y in 0..r.height.saturating_sub(1) {
        for x in 0..r.width.saturating_sub(1) {
            let ks = [
                y * r.width + x,
                y * r.width + x + 1,
                (y + 1) * r.width + x + 1,
                (y + 1) * r.width + x,
            ];
            let inside: Vec<u32> = ks.iter().filter_map(|&k| labels[k]).collect();
            if inside.is_empty()
                || inside.len() == 4
                || !ks.iter().any(|&k| labels[k].is_none() && reach[k])
            {
                continue;
            }
            let set = |i: usize| labels[ks[i]].is_some();
            let length = match inside.len() {
                1 | 3 => diag,
                // Two set cells: side by side (a straight edge) or opposite (a saddle: two
                // corners cut).
                _ if set(0) == set(2) => 2.0 * diag,
                _ => CELL,
            };
            let share = length / inside.len() as f64;
            for c in inside {
                p[c as usize] += share;
            }
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::Shape;
    use glam::DVec3;

    fn world(objects: Vec<(Shape, &str)>) -> World {
        crate::world::strategies::world_of(&objects)
    }

    fn cuboid(x: f64, y: f64, sx: f64, sy: f64) -> Shape {
        Shape::cuboid(DVec3::new(x, y, 0.5), DVec3::new(sx, sy, 1.0), 0.0).expect("a box")
    }

    fn geometry(start: DVec2, goal: DVec2) -> TrialGeometry {
        TrialGeometry {
            start,
            goal,
            tolerance: 0.3,
            radius: 0.355,
            standoff: 1.0,
            height: 0.3,
            plane_z: 0.4,
        }
    }

    #[test]
    fn distance_transform_matches_brute_force() {
        let (w, h) = (23, 17);
        let set: Vec<bool> = (0..w * h).map(|k| (k * 7919) % 31 == 0).collect();
        let d = distance_transform(&set, w, h);
        for (k, &dk) in d.iter().enumerate() {
            let (x, y) = ((k % w) as f64, (k / w) as f64);
            let brute = (0..w * h)
                .filter(|&j| set[j])
                .map(|j| ((j % w) as f64 - x).hypot((j / w) as f64 - y))
                .fold(f64::INFINITY, f64::min)
                * CELL;
            assert!((dk - brute).abs() < 1e-9, "{k}: {dk} vs {brute}");
        }
    }

    #[test]
    fn a_square_box_has_its_grown_perimeter_and_bounds() {
        // A 2 m box between start and goal; grown by 1 m its boundary is 4·2 + 2π·1 = 14.28 m.
        let w = world(vec![(cuboid(5.0, 0.0, 2.0, 2.0), "concrete")]);
        let g = geometry(DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0));
        let e = expect(&w, &g, SensorClass::Laser);
        assert!(e.reachable);
        assert_eq!(e.obstacles, 1);
        let p = (e.bug1_bound - 10.0) / 1.5;
        // The raster errs long: a cell a box touches is an obstacle cell.
        let want = 8.0 + std::f64::consts::TAU;
        assert!(p >= want && p < 1.05 * want, "perimeter {p} vs {want}");
        // The m-line enters and leaves the grown box once: n = 2.
        assert!((e.bug2_bound - (10.0 + p)).abs() < 1e-9, "{e:?}");
        // A goal inside the box: the line only enters it, yet going once round it is what
        // tells the goal is out of reach, so it counts as n = 2 as well.
        let e = expect(
            &w,
            &geometry(DVec2::ZERO, DVec2::new(5.0, 0.0)),
            SensorClass::Laser,
        );
        assert!(!e.reachable);
        assert!((e.bug2_bound - (5.0 + p)).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn a_closed_pen_round_the_goal_has_no_path_and_a_doorway_has_one() {
        let pen = |door: f64| {
            // A 4 m square pen round (10, 0) with a doorway of `door` metres in its west side.
            let t = 0.2;
            let mut v = vec![
                (cuboid(10.0, 2.0, 4.0, t), "concrete"),
                (cuboid(10.0, -2.0, 4.0, t), "concrete"),
                (cuboid(12.0, 0.0, t, 4.0), "concrete"),
            ];
            let half = (4.0 - door) / 2.0;
            for s in [-1.0, 1.0] {
                v.push((cuboid(8.0, s * (2.0 - half / 2.0), t, half), "concrete"));
            }
            world(v)
        };
        let g = geometry(DVec2::new(2.0, 0.0), DVec2::new(10.0, 0.0));
        assert!(!expect(&pen(0.0), &g, SensorClass::Radar).reachable);
        // The robot's disc is 0.71 m across: a 0.8 m door lets it in, a 0.6 m one does not.
        assert!(expect(&pen(0.8), &g, SensorClass::Radar).reachable);
        assert!(!expect(&pen(0.6), &g, SensorClass::Radar).reachable);
    }

    #[test]
    fn smoke_blocks_the_laser_only() {
        // A room from x = -2 to 12, y = -5 to 5, a band of smoke across it at x = 5.
        let w = world(vec![
            (cuboid(5.0, 5.0, 14.0, 0.2), "concrete"),
            (cuboid(5.0, -5.0, 14.0, 0.2), "concrete"),
            (cuboid(-2.0, 0.0, 0.2, 10.0), "concrete"),
            (cuboid(12.0, 0.0, 0.2, 10.0), "concrete"),
            (cuboid(5.0, 0.0, 1.0, 10.0), "smoke"),
        ]);
        let g = geometry(DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0));
        assert!(expect(&w, &g, SensorClass::Radar).reachable);
        assert!(!expect(&w, &g, SensorClass::Laser).reachable);
    }
}
