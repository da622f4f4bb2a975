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
