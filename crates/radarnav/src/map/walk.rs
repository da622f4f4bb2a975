//! The exact cell walk of a segment over a square grid (Amanatides & Woo 1987).
//!
//! Cells are indexed globally: cell `(i, j)` covers `[i·r, (i+1)·r) × [j·r, (j+1)·r)` for a
//! cell size `r`, so grids of any extent agree on which cell a point is in.

use glam::DVec2;

use crate::world::floor_i64;

/// A cell index `(column, row)` in the global lattice.
pub type CellIndex = (i64, i64);

/// The cell holding point `p` for cells of size `resolution`.
pub fn cell_of(p: DVec2, resolution: f64) -> CellIndex {
    (floor_i64(p.x / resolution), floor_i64(p.y / resolution))
}

/// The cells a segment passes through, in order from the cell of its start to the cell of its
/// end; consecutive cells share a side.
#[derive(Clone, Debug)]
pub struct CellWalk {
    cell: CellIndex,
    step: (i64, i64),
    /// Parameter along the segment (0 at the start, 1 at the end) of the next x and y border.
    t_max: DVec2,
    /// Parameter distance between two x (y) borders.
    t_delta: DVec2,
    /// Steps still to take in x and y; `None` once the end cell has been yielded.
    left: Option<(u64, u64)>,
}

impl CellWalk {
    /// The walk from `from` to `to` over cells of size `resolution`.
    pub fn new(from: DVec2, to: DVec2, resolution: f64) -> Self {
        let start = cell_of(from, resolution);
        let end = cell_of(to, resolution);
        let d = to - from;
        let axis = |p: f64, d: f64, c: i64| -> (i64, f64, f64) {
            if d > 0.0 {
                let border = (c + 1) as f64 * resolution;
                (1, (border - p) / d, resolution / d)
            } else if d < 0.0 {
                let border = c as f64 * resolution;
                (-1, (border - p) / d, -resolution / d)
            } else {
                (0, f64::INFINITY, f64::INFINITY)
            }
        };
        let (sx, tx, dx) = axis(from.x, d.x, start.0);
        let (sy, ty, dy) = axis(from.y, d.y, start.1);
        Self {
            cell: start,
            step: (sx, sy),
            t_max: DVec2::new(tx, ty),
            t_delta: DVec2::new(dx, dy),
            left: Some((end.0.abs_diff(start.0), end.1.abs_diff(start.1))),
        }
    }
}

impl CellWalk {
    /// Calls `f` with the storage index of each of the first `n` cells of the walk, in a grid
    /// of `width` columns whose first cell is `origin` and which holds the whole walk. The
    /// same cells in the same order as the iterator, without its bookkeeping per cell: the
    /// mapper's inner loop.
    pub fn for_each_index(
        self,
        n: usize,
        origin: CellIndex,
        width: usize,
        mut f: impl FnMut(usize),
    ) {
        let Some((mut nx, mut ny)) = self.left else {
            return;
        };
        let w = width as i64;
        let mut k = (self.cell.1 - origin.1) * w + (self.cell.0 - origin.0);
        let (kx, ky) = (self.step.0, self.step.1 * w);
        let mut t = self.t_max;
        for _ in 0..n {
            f(k as usize);
            if nx == 0 && ny == 0 {
                return;
            }
            // The iterator's rule, step for step.
            if ny == 0 || (nx > 0 && t.x < t.y) {
                k += kx;
                t.x += self.t_delta.x;
                nx -= 1;
            } else {
                k += ky;
                t.y += self.t_delta.y;
                ny -= 1;
            }
        }
    }
}

/// A segment's crossings of the cell borders of its longer axis (the *major* axis), as
/// [`mark_crossed`] steps them: crossing `i` lies between the major cells `major + i·step`
/// and `major + (i + 1)·step`, and the cross cell beside both is `(y + i·b) >> FRACTION_BITS`
/// (global, in 64-bit fixed point of [`FRACTION_BITS`] bits).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Crossings {
    /// Whether x is the major axis.
    pub x_major: bool,
    /// Major cell of the start.
    pub major: i64,
    /// Direction along the major axis: 1 or −1.
    pub step: i64,
    /// Borders crossed.
    pub n: u64,
    /// Cross coordinate at the first border, fixed point, global.
    pub y: i64,
    /// Its change per border.
    pub b: i64,
}

/// A segment's start in cells: its coordinates and its cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Start {
    /// The start divided by the cell size.
    pub p: DVec2,
    /// Its cell.
    pub cell: CellIndex,
}

impl Start {
    /// The start `from` over cells of size `resolution`.
    pub fn new(from: DVec2, resolution: f64) -> Self {
        let p = from / resolution;
        Self {
            p,
            cell: (floor_i64(p.x), floor_i64(p.y)),
        }
    }
}

impl Crossings {
    /// The cells of the ends of the segment from `from` to `to` over cells of size
    /// `resolution`, and its crossings: `None` where [`mark_crossed`] gives way for other
    /// reasons than a tie (too long for the fixed point, or rounding that leaves the
    /// segment's cross extent).
    pub fn new(from: DVec2, to: DVec2, resolution: f64) -> (CellIndex, CellIndex, Option<Self>) {
        Self::from_start(Start::new(from, resolution), to, resolution)
    }

    /// [`Crossings::new`] from a segment start taken apart before (the rays of a scan
    /// share theirs).
    #[inline(always)]
    pub fn from_start(
        start: Start,
        to: DVec2,
        resolution: f64,
    ) -> (CellIndex, CellIndex, Option<Self>) {
        let (p, c0) = (start.p, start.cell);
        let q = to / resolution;
        let c1 = (floor_i64(q.x), floor_i64(q.y));
        let d = q - p;
        let x_major = d.x.abs() >= d.y.abs();
        let (pm, pn, m0, m1, n0, n1, dm, dn) = if x_major {
            (p.x, p.y, c0.0, c1.0, c0.1, c1.1, d.x, d.y)
        } else {
            (p.y, p.x, c0.1, c1.1, c0.0, c1.0, d.y, d.x)
        };
        let borders = m1.abs_diff(m0);
        let s = if m1 > m0 { 1 } else { -1 };
        let out = Self {
            x_major,
            major: m0,
            step: s,
            n: borders,
            y: 0,
            b: 0,
        };
        if borders == 0 {
            // One cell along the longer axis, so at most two across: the two ends.
            return (c0, c1, Some(out));
        }
        let lo = n0.min(n1);
        let span = n0.max(n1) - lo;
        let slope = dn / dm;
        // The cross coordinate (from the segment's lowest cross index, so the integer part
        // is the cell) at the first border crossed, and its change per border.
        let first = if s > 0 { m0 + 1 } else { m0 };
        let at_first = (pn - lo as f64) + (first as f64 - pm) * slope;
        let fits = borders < MAX_FIXED_CELLS && span.unsigned_abs() < MAX_FIXED_CELLS;
        if !fits || !at_first.is_finite() {
            return (c0, c1, None);
        }
        let (a, b) = (
            (at_first * ONE as f64) as i64,
            (s as f64 * slope * ONE as f64) as i64,
        );
        // The crossings step by exactly `b`, so they lie between the first and the last: with
        // both of those in the segment's cross extent (always, but at a tie), so is every
        // one, and every cell marked is in the segment's bounding box.
        let last = a + (borders as i64 - 1) * b;
        if !(0..=span).contains(&(a >> FRACTION_BITS))
            || !(0..=span).contains(&(last >> FRACTION_BITS))
        {
            return (c0, c1, None);
        }
        // Global: the lowest cross index times one cell (far from overflow for any grid
        // that fits in memory, but checked).
        let y = lo
            .checked_mul(ONE)
            .and_then(|l| l.checked_add(a))
            .filter(|y| y.unsigned_abs() < 1 << 62);
        (c0, c1, y.map(|y| Self { y, b, ..out }))
    }

    /// Whether a crossing comes within [`TIE`] of a cross border, where the walk may take
    /// the other side of a cell corner than the fixed point does.
    ///
    /// Branch-free over the crossings (the sign bit of `fraction − 2·TIE` gathered by `or`),
    /// which the compiler turns into vector code.
    pub fn tie(&self) -> bool {
        let mut y = self.y.wrapping_add(TIE_FIXED);
        let mut near = 0i64;
        for _ in 0..self.n {
            near |= (y & (ONE - 1)) - 2 * TIE_FIXED;
            y = y.wrapping_add(self.b);
        }
        near < 0
    }

    /// Sets `seen[k] = 1` for the cells beside the crossings from crossing `from` on, in a
    /// grid of `w` columns whose first cell is `origin` and which holds the segment; with
    /// `CHECK`, `false` when a crossing lies within [`TIE`] of a cross border (as
    /// [`Crossings::tie`], in the same pass).
    ///
    /// # Panics
    /// If the grid does not hold the segment's crossings.
    pub fn mark<const CHECK: bool>(
        &self,
        from: u64,
        origin: CellIndex,
        w: i64,
        seen: &mut [u8],
    ) -> bool {
        let ray = self;
        if from >= ray.n {
            return true;
        }
        // The ray's cells are in its bounding box, in the grid: so are the corners of the
        // box of its crossings from `from` on, checked here once.
        let (first, last) = (ray.cross(from), ray.cross(ray.n - 1));
        let (m0, m1) = (
            ray.major + from as i64 * ray.step,
            ray.major + ray.n as i64 * ray.step,
        );
        let (cross, major) = ((first.min(last), first.max(last)), (m0.min(m1), m0.max(m1)));
        let (x, y) = if ray.x_major {
            (major, cross)
        } else {
            (cross, major)
        };
        let (x, y) = (
            (x.0 - origin.0, x.1 - origin.0),
            (y.0 - origin.1, y.1 - origin.1),
        );
        let rows_end = y.1.checked_add(1).and_then(|r| r.checked_mul(w));
        assert!(
            x.0 >= 0 && y.0 >= 0 && x.1 < w && rows_end.is_some_and(|e| e <= seen.len() as i64),
            "the grid holds the segment"
        );
        let cells = seen.as_mut_ptr();
        let mut yy = ray.y + from as i64 * ray.b;
        let near = ray.major.min(ray.major + ray.step) + from as i64 * ray.step;
        let mut near_tie = 0;
        let tie = |y: i64| (y.wrapping_add(TIE_FIXED) & (ONE - 1)) - 2 * TIE_FIXED;
        if ray.x_major {
            // The two cells side by side: one two-byte store.
            let mut k = near - origin.0 - origin.1 * w;
            for _ in from..ray.n {
                let here = (k + (yy >> FRACTION_BITS) * w) as usize;
                // SAFETY: both cells lie in the box checked above.
                unsafe { cells.add(here).cast::<[u8; 2]>().write_unaligned([1, 1]) };
                if CHECK {
                    near_tie |= tie(yy);
                }
                yy += ray.b;
                k += ray.step;
            }
        } else {
            let mut k = (near - origin.1) * w - origin.0;
            let (step, w) = (ray.step * w, w as usize);
            for _ in from..ray.n {
                let here = (k + (yy >> FRACTION_BITS)) as usize;
                // SAFETY: both cells lie in the box checked above.
                unsafe {
                    cells.add(here).write(1);
                    cells.add(here + w).write(1);
                }
                if CHECK {
                    near_tie |= tie(yy);
                }
                yy += ray.b;
                k += step;
            }
        }
        near_tie >= 0
    }

    /// The cross cell of crossing `i`.
    #[inline(always)]
    pub fn cross(&self, i: u64) -> i64 {
        (self.y + i as i64 * self.b) >> FRACTION_BITS
    }
}

/// Sets `seen[k] = 1` for the storage index `k` of every cell the segment from `from` to
/// `to` crosses, in a grid of `width` columns whose first cell is `origin` and which holds
/// the whole segment: the cells of [`CellWalk`], the end cell included, unless it returns
/// `false`. The mapper's rays go through [`mark_union`](super::union::mark_union), which
/// marks a whole scan's at once; this is its rule for one segment.
///
/// Why not the walk itself: it decides every step by comparing two running border
/// parameters, a chain where each step waits for the one before and mispredicted branches
/// take most of the time. Here the cross coordinate where the segment crosses each border
/// of its longer axis is stepped in 64-bit fixed point, each crossing floored on its own
/// (`Crossings`): the cells beside each crossing are all the cells, as the segment moves
/// at most one cell across per cell along. No branch depends on the data.
///
/// Which side of a corner the walk takes is decided by rounding where the segment passes
/// within rounding of it. So when a crossing comes within [`TIE`] of a cross border (far
/// above the walk's drift and this rule's rounding), or the segment is too long for the
/// fixed point, this returns `false`: its marks may differ from the walk's by such a corner
/// cell (or be missing), and the caller walks instead.
///
/// # Panics
/// If the grid does not hold the segment.
pub fn mark_crossed(
    from: DVec2,
    to: DVec2,
    resolution: f64,
    origin: CellIndex,
    width: usize,
    seen: &mut [u8],
) -> bool {
    let (w, len) = (width as i64, seen.len() as u64);
    // A column inside and a storage index inside put the row inside (no division).
    let index = |c: CellIndex| -> Option<usize> {
        let (i, j) = (c.0.checked_sub(origin.0)?, c.1.checked_sub(origin.1)?);
        let k = j.checked_mul(w)?.checked_add(i)?;
        ((0..w).contains(&i) && j >= 0 && (k as u64) < len).then_some(k as usize)
    };
    let (c0, c1, crossings) = Crossings::new(from, to, resolution);
    let (Some(k0), Some(k1)) = (index(c0), index(c1)) else {
        panic!("the grid holds the segment");
    };
    seen[k0] = 1;
    seen[k1] = 1;
    let Some(c) = crossings else {
        return false;
    };
    c.mark::<true>(0, origin, w, seen)
}

/// Fraction bits of the fixed-point cross coordinate of [`mark_crossed`].
pub(crate) const FRACTION_BITS: u32 = 40;
/// One cell in that fixed point.
pub(crate) const ONE: i64 = 1 << FRACTION_BITS;
/// Segments this long or wide, in cells, are walked: the fixed point holds 2²³ cells, and
/// the walk's running sums drift by up to about 2·n²·10⁻¹⁶ cells over n cells (2·10⁻⁸ at
/// this length), which must stay below [`TIE`].
const MAX_FIXED_CELLS: u64 = 10_000;
/// How near a cross border (in cells) a crossing makes [`mark_crossed`] give way to the
/// walk: 2.7 times the walk's largest drift, 7 times the fixed point's rounding (2⁻⁴⁰ a
/// step), and rare: in `compare foliage-wall`, 3.6 % of the scans have such a crossing
/// (most of them from poses on the lattice, as at a start).
pub const TIE: f64 = 1.0 / (1u64 << 24) as f64;
pub(crate) const TIE_FIXED: i64 = ONE >> 24;

impl Iterator for CellWalk {
    type Item = CellIndex;

    fn next(&mut self) -> Option<CellIndex> {
        let (nx, ny) = self.left?;
        let here = self.cell;
        // The step counts, not the border parameters, decide when to stop, so rounding can
        // never walk past the end cell or loop for ever.
        if nx == 0 && ny == 0 {
            self.left = None;
        } else if ny == 0 || (nx > 0 && self.t_max.x < self.t_max.y) {
            self.cell.0 += self.step.0;
            self.t_max.x += self.t_delta.x;
            self.left = Some((nx - 1, ny));
        } else {
            self.cell.1 += self.step.1;
            self.t_max.y += self.t_delta.y;
            self.left = Some((nx, ny - 1));
        }
        Some(here)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.left.map_or(0, |(x, y)| (x + y + 1) as usize);
        (n, Some(n))
    }
}

impl ExactSizeIterator for CellWalk {}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: every cell whose open square the segment crosses over a positive length
    /// (Liang–Barsky clipping), ordered by where the segment enters it.
    fn crossed(a: DVec2, b: DVec2, r: f64) -> Vec<CellIndex> {
        let (c0, c1) = (cell_of(a, r), cell_of(b, r));
        let d = b - a;
        let mut out = Vec::new();
        for i in c0.0.min(c1.0)..=c0.0.max(c1.0) {
            for j in c0.1.min(c1.1)..=c0.1.max(c1.1) {
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let lo = DVec2::new(i as f64 * r, j as f64 * r);
                let hi = lo + r;
                let mut clip = |p: f64, d: f64, lo: f64, hi: f64| {
                    if d == 0.0 {
                        if p < lo || p >= hi {
                            t1 = -1.0;
                        }
                    } else {
                        let (ta, tb) = ((lo - p) / d, (hi - p) / d);
                        t0 = t0.max(ta.min(tb));
                        t1 = t1.min(ta.max(tb));
                    }
                };
                clip(a.x, d.x, lo.x, hi.x);
                clip(a.y, d.y, lo.y, hi.y);
                if t1 > t0 || (i, j) == c0 {
                    out.push(((i, j), t0));
                }
            }
        }
        out.sort_by(|x, y| x.1.total_cmp(&y.1));
        out.into_iter().map(|(c, _)| c).collect()
    }

    const ORIGIN: CellIndex = (-300, -300);
    const WIDTH: usize = 600;

    /// The storage indices `mark_crossed` sets, or `None` when it gives way.
    fn marked(a: DVec2, b: DVec2, r: f64) -> Option<Vec<usize>> {
        let mut seen = vec![0u8; WIDTH * WIDTH];
        mark_crossed(a, b, r, ORIGIN, WIDTH, &mut seen)
            .then(|| (0..seen.len()).filter(|&k| seen[k] == 1).collect())
    }

    /// The walk's storage indices, sorted.
    fn walked(a: DVec2, b: DVec2, r: f64) -> Vec<usize> {
        let mut cells = Vec::new();
        CellWalk::new(a, b, r).for_each_index(usize::MAX, ORIGIN, WIDTH, |k| cells.push(k));
        cells.sort_unstable();
        cells.dedup();
        cells
    }

    /// Whether the segment crosses a border of its longer axis within `eps` cells of a
    /// cross border, in plain floating point.
    fn near_tie(a: DVec2, b: DVec2, r: f64, eps: f64) -> bool {
        let (p, q) = (a / r, b / r);
        let (pm, pn, qm, qn) = if (q - p).x.abs() >= (q - p).y.abs() {
            (p.x, p.y, q.x, q.y)
        } else {
            (p.y, p.x, q.y, q.x)
        };
        let (lo, hi) = (pm.floor().min(qm.floor()), pm.floor().max(qm.floor()));
        (lo as i64 + 1..=hi as i64).any(|m| {
            let v = pn + (m as f64 - pm) * (qn - pn) / (qm - pm);
            (v - v.round()).abs() < eps
        })
    }

    #[test]
    fn long_segments_give_way() {
        let mut seen = vec![0u8; 30_000 * 3];
        let (a, b) = (DVec2::new(0.5, 1.5), DVec2::new(29_999.5, 1.7));
        assert!(!mark_crossed(a, b, 1.0, (0, 0), 30_000, &mut seen));
        seen.fill(0);
        let (a, b) = (DVec2::new(0.5, 1.5), DVec2::new(9_000.5, 1.7));
        assert!(mark_crossed(a, b, 1.0, (0, 0), 30_000, &mut seen));
        assert_eq!(seen.iter().filter(|&&c| c == 1).count(), 9_001);
    }

    #[test]
    fn axis_aligned_and_diagonal_walks() {
        let w = |a: [f64; 2], b: [f64; 2]| -> Vec<CellIndex> {
            CellWalk::new(DVec2::from(a), DVec2::from(b), 1.0).collect()
        };
        assert_eq!(w([0.5, 0.5], [3.5, 0.5]), [(0, 0), (1, 0), (2, 0), (3, 0)]);
        assert_eq!(w([0.5, 0.5], [0.5, -1.5]), [(0, 0), (0, -1), (0, -2)]);
        assert_eq!(w([0.2, 0.2], [0.7, 0.9]), [(0, 0)]);
        // Slightly above the diagonal: up before right.
        assert_eq!(w([0.5, 0.6], [1.5, 1.6]), [(0, 0), (0, 1), (1, 1)]);
        assert_eq!(w([-0.5, 0.5], [-2.5, 0.5]), [(-1, 0), (-2, 0), (-3, 0)]);
    }

    proptest! {
        #[test]
        fn walk_equals_brute_force(
            ax in -5.0..5.0f64, ay in -5.0..5.0f64,
            bx in -5.0..5.0f64, by in -5.0..5.0f64,
            r in prop::sample::select(vec![0.05, 0.1, 0.37, 1.0]),
        ) {
            let (a, b) = (DVec2::new(ax, ay), DVec2::new(bx, by));
            let walk: Vec<CellIndex> = CellWalk::new(a, b, r).collect();
            prop_assert_eq!(walk.first().copied(), Some(cell_of(a, r)));
            prop_assert_eq!(walk.last().copied(), Some(cell_of(b, r)));
            for w in walk.windows(2) {
                prop_assert_eq!(w[0].0.abs_diff(w[1].0) + w[0].1.abs_diff(w[1].1), 1);
            }
            prop_assert_eq!(walk, crossed(a, b, r));
        }

        /// Random segments (also along the axes): the cells marked are the walk's, and
        /// when it gives way, a crossing truly lies near a cross border.
        #[test]
        fn marked_cells_are_the_walks(
            ax in -5.0..5.0f64, ay in -5.0..5.0f64,
            bx in -5.0..5.0f64, by in -5.0..5.0f64,
            r in prop::sample::select(vec![0.05, 0.1, 0.37, 1.0]),
            axis in 0usize..3,
        ) {
            let a = DVec2::new(ax, ay);
            let b = match axis {
                0 => DVec2::new(bx, by),
                1 => DVec2::new(bx, ay),
                _ => DVec2::new(ax, by),
            };
            match marked(a, b, r) {
                Some(got) => prop_assert_eq!(got, walked(a, b, r)),
                None => prop_assert!(near_tie(a, b, r, 2.0 * TIE), "gave way without a tie"),
            }
        }

        /// Segments between lattice points, which pass through cell corners: each gives way
        /// where a crossing is on a cross border, and is the walk's where it marks.
        #[test]
        fn lattice_segments_give_way_at_corners(
            ax in -20i32..20, ay in -20i32..20, bx in -20i32..20, by in -20i32..20,
            r in prop::sample::select(vec![1.0, 0.5, 0.25]),
        ) {
            let a = DVec2::new(f64::from(ax) * 0.25, f64::from(ay) * 0.25);
            let b = DVec2::new(f64::from(bx) * 0.25, f64::from(by) * 0.25);
            match marked(a, b, r) {
                Some(got) => {
                    prop_assert!(!near_tie(a, b, r, TIE / 2.0), "a corner was not seen");
                    prop_assert_eq!(got, walked(a, b, r));
                }
                None => prop_assert!(near_tie(a, b, r, 2.0 * TIE), "gave way without a tie"),
            }
        }

        /// The mapper's loop visits the iterator's cells, as storage indices, for any number
        /// of cells asked (the end cell left out, all of them, more than there are, none).
        #[test]
        fn indices_equal_the_iterator(
            ax in -5.0..5.0f64, ay in -5.0..5.0f64,
            bx in -5.0..5.0f64, by in -5.0..5.0f64,
            r in prop::sample::select(vec![0.05, 0.1, 0.37, 1.0]),
            extra in 0usize..3,
            drop in 0usize..3,
        ) {
            let (a, b) = (DVec2::new(ax, ay), DVec2::new(bx, by));
            let cells: Vec<CellIndex> = CellWalk::new(a, b, r).collect();
            let origin = (-300, -300);
            let width = 600usize;
            let index = |c: CellIndex| ((c.1 - origin.1) * width as i64 + (c.0 - origin.0)) as usize;
            let n = (cells.len() + extra).saturating_sub(drop);
            let mut got = Vec::new();
            CellWalk::new(a, b, r).for_each_index(n, origin, width, |k| got.push(k));
            let want: Vec<usize> = cells.iter().take(n).map(|&c| index(c)).collect();
            prop_assert_eq!(got, want);
        }
    }
}
