//! The localiser's map: a smoothed likelihood grid at several resolutions (Hector SLAM's
//! multi-resolution map, Kohlbrecher et al. 2011, with the Gaussian likelihood field of Thrun
//! et al.'s beam-endpoint model in its cells).
//!
//! A cell holds `M = exp(-d² / 2σ²)`, `d` the distance from its centre to the nearest return
//! (or surface joining two neighbouring returns) put in so far, `σ` the level's cell size: the
//! peak sits on the surface whatever the grid's alignment, and a wall seen a hundred times is
//! no thicker than one seen once (a sum of hits would saturate into a band as wide as the
//! kernel, with no gradient inside it). Read back with bilinear interpolation, `M` and its
//! gradient are continuous: what Gauss–Newton needs. A coarser level has a wider basin, so
//! registration starts there and refines on the finer ones.

use glam::DVec2;

/// Cells a level may hold (256 MiB of `f32` for the finest); a return farther out is not kept.
pub const MAX_CELLS: usize = 1 << 26;

/// The kernel reaches this many cell sizes from a surface (M = 0.011 there).
const KERNEL_SIGMAS: f64 = 3.0;

/// Where the line `y = yc` is within `r` of the segment `a`–`b`: an interval of x, as the
/// set within `r` of a segment (a capsule) is convex; `None` if the line misses it.
fn capsule_row(a: DVec2, b: DVec2, r: f64, yc: f64) -> Option<(f64, f64)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    // The discs at the ends.
    for p in [a, b] {
        let dy = yc - p.y;
        if dy.abs() <= r {
            let w = (r * r - dy * dy).sqrt();
            (lo, hi) = (lo.min(p.x - w), hi.max(p.x + w));
        }
    }
    // The band along the segment: |distance to its line| <= r and the projection on it in
    // [0, L], each a slab in x.
    let ab = b - a;
    let len = ab.length();
    if len > 0.0 {
        let u = ab / len;
        let dy = yc - a.y;
        // s(x) = -(x - a.x) u.y + dy u.x, t(x) = (x - a.x) u.x + dy u.y.
        let mut band = (f64::NEG_INFINITY, f64::INFINITY);
        for (slope, offset, min, max) in [(-u.y, dy * u.x, -r, r), (u.x, dy * u.y, 0.0, len)] {
            if slope.abs() < 1e-12 {
                if offset < min || offset > max {
                    band = (1.0, 0.0);
                }
            } else {
                let (e0, e1) = ((min - offset) / slope, (max - offset) / slope);
                band = (band.0.max(e0.min(e1)), band.1.min(e0.max(e1)));
            }
        }
        if band.0 <= band.1 {
            (lo, hi) = (lo.min(a.x + band.0), hi.max(a.x + band.1));
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// `d² / 2σ²` at the kernel's reach.
const KERNEL_EXPONENT: f64 = KERNEL_SIGMAS * KERNEL_SIGMAS / 2.0;
/// Entries of the kernel's table over `[0, KERNEL_EXPONENT]`.
const KERNEL_TABLE: usize = 4096;

/// `exp(-x)` for `x` in `[0, KERNEL_EXPONENT)`, from a table with linear interpolation (within
/// 2e-7 of `exp`): a keyframe puts in tens of thousands of cells, and `exp` was two thirds of
/// the localiser's time.
fn kernel(x: f64) -> f32 {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..=KERNEL_TABLE + 1)
            .map(|k| (-(k as f64) * KERNEL_EXPONENT / KERNEL_TABLE as f64).exp() as f32)
            .collect()
    });
    let u = x * (KERNEL_TABLE as f64 / KERNEL_EXPONENT);
    let k = u as usize;
    let f = (u - k as f64) as f32;
    table[k] + f * (table[k + 1] - table[k])
}

/// Margin added around a level's bounds when it grows, m.
pub const GROW_MARGIN: f64 = 16.0;

/// One resolution of the map.
#[derive(Clone, Debug)]
pub struct Level {
    /// Cell size, m.
    res: f64,
    /// World position of cell (0, 0)'s lower-left corner.
    origin: DVec2,
    width: usize,
    height: usize,
    /// Likelihood of each cell, row by row.
    cells: Vec<f32>,
}

/// A likelihood sample: `M` and its gradient in the world frame (per metre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Likelihood, 0 to 1.
    pub value: f64,
    /// dM/dx, dM/dy.
    pub gradient: DVec2,
}

impl Level {
    /// An empty level of cell size `res` covering `centre ± half` metres (at most
    /// [`MAX_CELLS`] cells).
    pub fn new(res: f64, centre: DVec2, half: f64) -> Self {
        // No more than MAX_CELLS, however fine the cells: the level grows where returns fall.
        let side = (MAX_CELLS as f64).sqrt() as usize;
        let n = ((2.0 * half / res).ceil() as usize).clamp(2, side);
        Self {
            res,
            origin: centre - DVec2::splat(n as f64 * res / 2.0),
            width: n,
            height: n,
            cells: vec![0.0; n * n],
        }
    }

    /// Cell size, m.
    pub fn resolution(&self) -> f64 {
        self.res
    }

    /// Cells held.
    pub fn cells(&self) -> usize {
        self.cells.len()
    }

    /// Continuous cell coordinates of `p`: cell centres at integers.
    fn grid_coords(&self, p: DVec2) -> DVec2 {
        (p - self.origin) / self.res - DVec2::splat(0.5)
    }

    /// The likelihood at `p` and its gradient; 0 outside the level. Interpolated with
    /// Catmull–Rom cubics: a bilinear interpolant peaks only on cell centres, which would pull
    /// every return on a wall to the nearest row of centres (half a cell of bias); the cubic's
    /// peak follows the surface to a few hundredths of a cell.
    pub fn sample(&self, p: DVec2) -> Sample {
        let g = self.grid_coords(p);
        let (i, j) = (g.x.floor(), g.y.floor());
        let none = Sample {
            value: 0.0,
            gradient: DVec2::ZERO,
        };
        if !(i >= 1.0 && j >= 1.0) {
            return none;
        }
        let (wx, dx) = catmull_rom(g.x - i);
        let (wy, dy) = catmull_rom(g.y - j);
        let (i, j) = (i as usize - 1, j as usize - 1);
        if i + 3 >= self.width || j + 3 >= self.height {
            return none;
        }
        let (mut value, mut gx, mut gy) = (0.0, 0.0, 0.0);
        for r in 0..4 {
            let row = &self.cells[(j + r) * self.width + i..][..4];
            let (mut v, mut d) = (0.0, 0.0);
            for c in 0..4 {
                let m = f64::from(row[c]);
                v += wx[c] * m;
                d += dx[c] * m;
            }
            value += wy[r] * v;
            gx += wy[r] * d;
            gy += dy[r] * v;
        }
        Sample {
            value,
            gradient: DVec2::new(gx, gy) / self.res,
        }
    }

    /// The likelihood of the cell holding `p` (no interpolation: the cheap read of a
    /// correlative search); 0 outside the level.
    pub fn nearest(&self, p: DVec2) -> f64 {
        let g = (p - self.origin) / self.res;
        if !(g.x >= 0.0 && g.y >= 0.0) {
            return 0.0;
        }
        let (i, j) = (g.x as usize, g.y as usize);
        if i >= self.width || j >= self.height {
            return 0.0;
        }
        f64::from(self.cells[j * self.width + i])
    }

    /// Puts in the surface from `a` to `b` (a single return when they are equal); `false`
    /// if the level could not grow to hold it (up to [`MAX_CELLS`]).
    pub fn insert(&mut self, a: DVec2, b: DVec2) -> bool {
        if !(a.is_finite() && b.is_finite()) {
            return false;
        }
        let reach = KERNEL_SIGMAS * self.res;
        if !(self.cover(a.min(b) - DVec2::splat(reach))
            && self.cover(a.max(b) + DVec2::splat(reach)))
        {
            return false;
        }
        let lo = ((a.min(b) - self.origin) / self.res - DVec2::splat(KERNEL_SIGMAS + 0.5)).ceil();
        let hi = ((a.max(b) - self.origin) / self.res + DVec2::splat(KERNEL_SIGMAS - 0.5)).floor();
        let (ab, len2) = (b - a, (b - a).length_squared());
        let inv = 1.0 / (2.0 * self.res * self.res);
        for j in lo.y.max(0.0) as usize..=(hi.y as usize).min(self.height - 1) {
            // Only the row's cells within reach of the surface: the reach's capsule around
            // it cuts the row's line of centres in one interval (a long slanted surface's
            // bounding box is mostly out of reach).
            let yc = self.origin.y + (j as f64 + 0.5) * self.res;
            let Some((x0, x1)) = capsule_row(a, b, reach, yc) else {
                continue;
            };
            let i0 = ((x0 - self.origin.x) / self.res - 0.5)
                .ceil()
                .max(lo.x)
                .max(0.0) as usize;
            let i1 = ((x1 - self.origin.x) / self.res - 0.5).floor().min(hi.x);
            if i1 < 0.0 {
                continue;
            }
            for i in i0..=(i1 as usize).min(self.width - 1) {
                let c = self.origin + (DVec2::new(i as f64, j as f64) + 0.5) * self.res;
                let t = if len2 > 0.0 {
                    ((c - a).dot(ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let x = (c - (a + ab * t)).length_squared() * inv;
                if x >= KERNEL_EXPONENT {
                    continue;
                }
                let cell = &mut self.cells[j * self.width + i];
                *cell = cell.max(kernel(x));
            }
        }
        true
    }

    /// Grows the level so that `p` is inside it.
    fn cover(&mut self, p: DVec2) -> bool {
        let g = self.grid_coords(p);
        if g.x >= 0.0 && g.y >= 0.0 && (g.x as usize) < self.width && (g.y as usize) < self.height {
            return true;
        }
        if !(p.x.is_finite() && p.y.is_finite()) {
            return false;
        }
        let lo = self.origin.min(p - DVec2::splat(GROW_MARGIN));
        let hi = (self.origin + DVec2::new(self.width as f64, self.height as f64) * self.res)
            .max(p + DVec2::splat(GROW_MARGIN));
        // Whole cells, so the old cells keep their places.
        let shift = ((self.origin - lo) / self.res).ceil();
        let origin = self.origin - shift * self.res;
        let width = ((hi.x - origin.x) / self.res).ceil() as usize + 1;
        let height = ((hi.y - origin.y) / self.res).ceil() as usize + 1;
        if width.saturating_mul(height) > MAX_CELLS {
            return false;
        }
        let (dx, dy) = (shift.x as usize, shift.y as usize);
        let mut cells = vec![0.0; width * height];
        for row in 0..self.height {
            let from = row * self.width;
            let to = (row + dy) * width + dx;
            cells[to..to + self.width].copy_from_slice(&self.cells[from..from + self.width]);
        }
        *self = Self {
            res: self.res,
            origin,
            width,
            height,
            cells,
        };
        true
    }
}

/// Catmull–Rom weights of the four samples around `t` ∈ [0, 1) and their derivatives.
fn catmull_rom(t: f64) -> ([f64; 4], [f64; 4]) {
    let (t2, t3) = (t * t, t * t * t);
    (
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ],
        [
            0.5 * (-3.0 * t2 + 4.0 * t - 1.0),
            0.5 * (9.0 * t2 - 10.0 * t),
            0.5 * (-9.0 * t2 + 8.0 * t + 1.0),
            0.5 * (3.0 * t2 - 2.0 * t),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_return_peaks_at_its_point_and_the_gradient_points_to_it() {
        let mut l = Level::new(0.1, DVec2::ZERO, 2.0);
        let p = DVec2::new(0.33, -0.42);
        assert!(l.insert(p, p));
        let at = l.sample(p).value;
        assert!(at > 0.9, "{at}");
        for d in [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y] {
            let s = l.sample(p + d * 0.06);
            assert!(s.value < at);
            // The gradient leads back towards the point.
            assert!(s.gradient.dot(-d) > 0.0, "{d:?}: {s:?}");
        }
        assert_eq!(l.sample(DVec2::new(1.5, 1.5)).value, 0.0);
    }

    #[test]
    fn a_wall_is_a_ridge_on_its_line_whatever_the_grid() {
        let mut l = Level::new(0.05, DVec2::ZERO, 2.0);
        let (a, b) = (DVec2::new(-1.0, 0.013), DVec2::new(1.0, 0.013));
        // Put in a hundred times: no thicker than once.
        for _ in 0..100 {
            l.insert(a, b);
        }
        // Across the wall, the highest sample is within a few millimetres of its line.
        let best = (0..200)
            .map(|k| -0.1 + 0.001 * f64::from(k))
            .max_by(|&y, &z| {
                let m = |y: f64| l.sample(DVec2::new(0.3, y)).value;
                m(y).total_cmp(&m(z))
            })
            .unwrap();
        assert!((best - 0.013).abs() < 0.006, "{best}");
        let m = l.sample(DVec2::new(0.3, 0.013 + 0.05)).value;
        assert!(m > 0.3 && m < 0.8, "one sigma off the wall: {m}");
    }

    #[test]
    fn the_gradient_is_the_derivative_of_the_value() {
        let mut l = Level::new(0.05, DVec2::ZERO, 1.0);
        l.insert(DVec2::new(-0.5, 0.2), DVec2::new(0.5, 0.25));
        let p = DVec2::new(0.013, 0.231);
        let h = 1e-6;
        let s = l.sample(p);
        let dx = (l.sample(p + DVec2::X * h).value - l.sample(p - DVec2::X * h).value) / (2.0 * h);
        let dy = (l.sample(p + DVec2::Y * h).value - l.sample(p - DVec2::Y * h).value) / (2.0 * h);
        assert!((s.gradient.x - dx).abs() < 1e-5 && (s.gradient.y - dy).abs() < 1e-5);
    }

    #[test]
    fn a_row_is_cut_where_it_is_within_reach() {
        // Against a brute-force scan of the row.
        let cases = [
            (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.5)),
            (DVec2::new(0.3, -0.2), DVec2::new(0.3, 0.9)),
            (DVec2::new(-0.5, 0.1), DVec2::new(0.7, 0.1)),
            (DVec2::new(0.2, 0.2), DVec2::new(0.2, 0.2)),
        ];
        for (a, b) in cases {
            for k in 0..60 {
                let yc = -0.6 + 0.0311 * f64::from(k);
                let inside = |x: f64| {
                    let p = DVec2::new(x, yc);
                    let t = if a == b {
                        0.0
                    } else {
                        ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0)
                    };
                    (p - a.lerp(b, t)).length() <= 0.25
                };
                let xs: Vec<f64> = (0..4000).map(|i| -1.0 + 0.001 * f64::from(i)).collect();
                let hit: Vec<f64> = xs.iter().copied().filter(|&x| inside(x)).collect();
                match capsule_row(a, b, 0.25, yc) {
                    None => assert!(hit.is_empty(), "{a} {b} {yc}"),
                    Some((lo, hi)) => {
                        assert!(
                            (hit[0] - lo).abs() < 2e-3,
                            "{a} {b} {yc}: {lo} vs {}",
                            hit[0]
                        );
                        assert!(
                            (hit.last().unwrap() - hi).abs() < 2e-3,
                            "{a} {b} {yc}: {hi}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn the_kernel_table_is_exp() {
        for k in 0..10_000 {
            let x = KERNEL_EXPONENT * f64::from(k) / 10_000.0;
            assert!((f64::from(kernel(x)) - (-x).exp()).abs() < 2e-7, "{x}");
        }
    }

    #[test]
    fn growing_keeps_what_was_inserted() {
        let mut l = Level::new(0.1, DVec2::ZERO, 1.0);
        let p = DVec2::new(0.2, 0.3);
        l.insert(p, p);
        let before = l.sample(p);
        let far = DVec2::new(-40.0, 25.0);
        assert!(l.insert(far, far));
        let after = l.sample(p);
        assert!((after.value - before.value).abs() < 1e-9);
        assert!((after.gradient - before.gradient).length() < 1e-6);
        assert!(l.sample(far).value > 0.5);
        assert!(!l.insert(DVec2::new(f64::NAN, 0.0), DVec2::ZERO));
        // Too far to hold.
        assert!(!l.insert(DVec2::new(1e6, 1e6), DVec2::new(1e6, 1e6)));
    }
}
