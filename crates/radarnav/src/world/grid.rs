//! The acceleration structure behind every ray and box query (DESIGN §11): a uniform grid over
//! the ground plane, walked along a ray cell by cell (Amanatides–Woo DDA).
//!
//! radarnav's worlds are 2.5-D: objects stand on the ground and sensors look sideways, so a
//! grid over x, y (z ignored) separates them as well as a 3-D hierarchy does, and walking it
//! along a ray visits cells in the order the ray meets them. That order is what makes a query
//! cost follow the ray: a laser stops in the cell of its first solid, a radar in the cell where
//! its budget runs out, whatever the size of the world. With the cell size set from the number
//! of objects per area, the work per cell stays constant from 1 000 to 100 000 objects.
//!
//! Exactness: every object is registered in every cell its footprint (padded by [`Grid::pad`])
//! overlaps, so a point inside an object lies in a cell that lists it. When the walk has
//! visited every cell up to the ray parameter `t_exit`, every object the ray enters before
//! `t_exit` has been found: the intervals found so far that begin before `t_exit` are final.

use glam::{DVec2, DVec3};

use super::shape::Ray;

/// Most cells per object, and in all: the grid is at most a few times larger than the
/// object list, whatever the world's extent.
const MAX_CELLS_PER_OBJECT: f64 = 4.0;
const MAX_CELLS: f64 = (1u32 << 22) as f64;

/// A uniform grid of square cells over the xy bounds of a set of footprints; each cell lists
/// the ids (objects, or parts of them) whose footprints (padded) overlap it.
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    lo: DVec2,
    cell: f64,
    inv_cell: f64,
    nx: usize,
    ny: usize,
    /// Ids of cell `c` are `items[starts[c]..starts[c + 1]]`, in increasing order.
    starts: Vec<u32>,
    items: Vec<u32>,
    pad: f64,
}

impl Grid {
    /// A grid over `parts`: (id, xy min, xy max) of footprints, in increasing id order; an id
    /// may have several rectangles.
    pub(crate) fn new(parts: &[(u32, DVec2, DVec2)]) -> Self {
        let (lo, hi) = parts.iter().fold(
            (DVec2::INFINITY, DVec2::NEG_INFINITY),
            |(lo, hi), &(_, a, b)| (lo.min(a), hi.max(b)),
        );
        if parts.is_empty() || !lo.is_finite() || !hi.is_finite() {
            return Self {
                lo: DVec2::ZERO,
                cell: 1.0,
                inv_cell: 1.0,
                nx: 1,
                ny: 1,
                starts: vec![0, 0],
                items: Vec::new(),
                pad: 0.0,
            };
        }
        // Shape intervals and the walk's cell boundaries are exact to ~1e-15 relative; the pad
        // covers that many times over at any coordinate.
        let pad = 1e-9 * (1.0 + lo.abs().max(hi.abs()).max_element());
        let (lo, hi) = (lo - 2.0 * pad, hi + 2.0 * pad);
        let size = hi - lo;
        let objects = parts.last().map_or(0, |p| p.0 as usize + 1);
        // About one object per cell: then a cell holds a handful of footprints, and a ray
        // meets a few of them per cell it crosses (measured on forests of 1k-100k spheres:
        // `radarnav bench --forest`).
        let wanted = (parts.len() as f64)
            .min(MAX_CELLS_PER_OBJECT * objects as f64)
            .clamp(1.0, MAX_CELLS);
        let mut cell = (size.x * size.y / wanted).sqrt();
        // A long thin world: cells no wider than the world is.
        cell = cell.min(size.max_element());
        let count = |c: f64| ((size / c).ceil().max(DVec2::ONE)).as_uvec2();
        let mut n = count(cell);
        while n.x as f64 * n.y as f64 > MAX_CELLS_PER_OBJECT * objects as f64 + 16.0 {
            cell *= 1.25;
            n = count(cell);
        }
        let (nx, ny) = (n.x as usize, n.y as usize);
        let mut grid = Self {
            lo,
            cell,
            inv_cell: 1.0 / cell,
            nx,
            ny,
            starts: vec![0; nx * ny + 1],
            items: Vec::new(),
            pad,
        };
        // Two passes (count, then fill) into one flat list; `last` keeps an id that has
        // several rectangles in a cell from being listed twice there.
        let mut last = vec![u32::MAX; nx * ny];
        for fill in [false, true] {
            last.fill(u32::MAX);
            let mut cursor = if fill {
                grid.starts[..nx * ny].to_vec()
            } else {
                Vec::new()
            };
            for &(object, a, b) in parts {
                let (x0, x1, y0, y1) = grid.cell_span(a - pad, b + pad);
                for iy in y0..=y1 {
                    for ix in x0..=x1 {
                        let c = iy * nx + ix;
                        if last[c] == object {
                            continue;
                        }
                        last[c] = object;
                        if fill {
                            grid.items[cursor[c] as usize] = object;
                            cursor[c] += 1;
                        } else {
                            grid.starts[c + 1] += 1;
                        }
                    }
                }
            }
            if !fill {
                for c in 0..nx * ny {
                    grid.starts[c + 1] += grid.starts[c];
                }
                grid.items = vec![0; grid.starts[nx * ny] as usize];
            }
        }
        grid
    }

    /// How far footprints are grown before they are registered, metres.
    pub(crate) fn pad(&self) -> f64 {
        self.pad
    }

    /// Inclusive cell index ranges `(x0, x1, y0, y1)` of the cells meeting `[a, b]`,
    /// clamped to the grid.
    fn cell_span(&self, a: DVec2, b: DVec2) -> (usize, usize, usize, usize) {
        let index = |v: f64, n: usize| {
            let i = (v * self.inv_cell).floor();
            if i <= 0.0 { 0 } else { (i as usize).min(n - 1) }
        };
        let (a, b) = (a - self.lo, b - self.lo);
        (
            index(a.x, self.nx),
            index(b.x, self.nx),
            index(a.y, self.ny),
            index(b.y, self.ny),
        )
    }

    /// How many cells the grid has (cell indices run below it).
    /// Where the grid's arrays lie in memory ([`super::pages::span`]).
    pub(crate) fn spans(&self) -> [(usize, usize); 2] {
        [
            super::pages::span(&self.starts),
            super::pages::span(&self.items),
        ]
    }

    pub(crate) fn cell_count(&self) -> usize {
        self.nx * self.ny
    }

    /// The ids listed in cell `c`.
    pub(crate) fn cell(&self, c: usize) -> &[u32] {
        &self.items[self.starts[c] as usize..self.starts[c + 1] as usize]
    }

    /// The ids whose padded footprints may meet the xy rectangle `[a, b]`; an id in several of
    /// its cells comes once per cell.
    pub(crate) fn in_rect(&self, a: DVec2, b: DVec2) -> impl Iterator<Item = u32> + '_ {
        let empty = !(a.is_finite() && b.is_finite() && a.cmple(b).all()) || self.outside(a, b);
        let (x0, x1, y0, y1) = if empty {
            (1, 0, 1, 0)
        } else {
            self.cell_span(a, b)
        };
        (y0..=y1).flat_map(move |iy| {
            (x0..=x1).flat_map(move |ix| self.cell(iy * self.nx + ix).iter().copied())
        })
    }

    /// Whether `[a, b]` lies wholly outside the grid (then nothing can meet it).
    fn outside(&self, a: DVec2, b: DVec2) -> bool {
        let hi = self.lo + DVec2::new(self.nx as f64, self.ny as f64) * self.cell;
        b.x < self.lo.x || b.y < self.lo.y || a.x > hi.x || a.y > hi.y
    }

    /// The ids whose padded footprints may contain the point `p`, in increasing order.
    pub(crate) fn at_point(&self, p: DVec3) -> &[u32] {
        let p = p.truncate();
        if !p.is_finite() || self.outside(p, p) {
            return &[];
        }
        let (ix, _, iy, _) = self.cell_span(p, p);
        self.cell(iy * self.nx + ix)
    }
}

/// The cells a ray crosses within `[0, t_max]`, in order, each with the ray parameter where
/// the ray leaves it (Amanatides & Woo 1987, with each boundary's parameter computed from
/// the boundary itself rather than accumulated, so it is exact to rounding).
#[derive(Clone, Debug)]
pub(crate) struct CellWalk {
    ix: isize,
    iy: isize,
    step: [isize; 2],
    /// Ray parameter where the walk ends (the grid's far side or `t_max`).
    t_end: f64,
    origin: DVec2,
    inv_dir: DVec2,
    done: bool,
}

impl CellWalk {
    /// The walk of `ray` through `grid` up to `t_max` (nothing when the ray misses the grid).
    pub(crate) fn new(grid: &Grid, ray: &Ray, t_max: f64) -> Self {
        let o = ray.origin.truncate();
        let d = ray.dir.truncate();
        let hi = grid.lo + DVec2::new(grid.nx as f64, grid.ny as f64) * grid.cell;
        let (mut t0, mut t1) = (0.0f64, t_max);
        // A ray from inside the grid (the usual case: a sensor in the world) needs no clipping:
        // the walk ends where it steps out of the grid.
        let inside = o.cmpge(grid.lo).all() && o.cmple(hi).all();
        for a in (0..2).filter(|_| !inside) {
            if d[a] == 0.0 {
                if o[a] < grid.lo[a] || o[a] > hi[a] {
                    t1 = f64::NEG_INFINITY;
                }
            } else {
                let (ta, tb) = ((grid.lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        let mut walk = Self {
            ix: 0,
            iy: 0,
            step: [
                if d.x > 0.0 { 1 } else { -1 },
                if d.y > 0.0 { 1 } else { -1 },
            ],
            t_end: t1,
            origin: o,
            inv_dir: DVec2::new(1.0 / d.x, 1.0 / d.y),
            // NaN-safe: a NaN bound (a degenerate ray) walks nothing.
            done: t0.partial_cmp(&t1).is_none_or(|o| o.is_gt()) || grid.items.is_empty(),
        };
        if !walk.done {
            let p = o + d * t0;
            let (ix, _, iy, _) = grid.cell_span(p, p);
            (walk.ix, walk.iy) = (ix as isize, iy as isize);
        }
        walk
    }

    /// The next cell (its index) and the ray parameter where the ray leaves it; the last cell
    /// of the walk gives `f64::INFINITY` (nothing further can be met).
    pub(crate) fn next_cell(&mut self, grid: &Grid) -> Option<(usize, f64)> {
        if self.done {
            return None;
        }
        let (ix, iy) = (self.ix, self.iy);
        let boundary =
            |i: isize, s: isize, lo: f64| lo + (i + isize::from(s > 0)) as f64 * grid.cell;
        let tx = if self.inv_dir.x.is_finite() {
            (boundary(ix, self.step[0], grid.lo.x) - self.origin.x) * self.inv_dir.x
        } else {
            f64::INFINITY
        };
        let ty = if self.inv_dir.y.is_finite() {
            (boundary(iy, self.step[1], grid.lo.y) - self.origin.y) * self.inv_dir.y
        } else {
            f64::INFINITY
        };
        let t_exit = tx.min(ty);
        if tx <= ty {
            self.ix += self.step[0];
        } else {
            self.iy += self.step[1];
        }
        let outside = self.ix < 0
            || self.iy < 0
            || self.ix >= grid.nx as isize
            || self.iy >= grid.ny as isize;
        if t_exit >= self.t_end || outside {
            self.done = true;
            return Some((iy as usize * grid.nx + ix as usize, f64::INFINITY));
        }
        Some((iy as usize * grid.nx + ix as usize, t_exit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_of(rects: &[([f64; 2], [f64; 2])]) -> Grid {
        let parts: Vec<_> = rects
            .iter()
            .enumerate()
            .map(|(i, (a, b))| (i as u32, DVec2::from(*a), DVec2::from(*b)))
            .collect();
        Grid::new(&parts)
    }

    #[test]
    fn walk_visits_cells_in_ray_order_with_increasing_exits() {
        let rects: Vec<_> = (0..100)
            .map(|k| {
                let (x, y) = ((k % 10) as f64, (k / 10) as f64);
                ([x, y], [x + 0.5, y + 0.5])
            })
            .collect();
        let g = grid_of(&rects);
        let ray = Ray::new(DVec3::new(0.2, 0.1, 0.0), DVec3::new(1.0, 0.7, 0.0));
        let mut walk = CellWalk::new(&g, &ray, 100.0);
        let mut last = 0.0;
        let mut cells = 0;
        while let Some((_, t)) = walk.next_cell(&g) {
            assert!(t >= last, "{t} < {last}");
            last = t;
            cells += 1;
        }
        assert_eq!(last, f64::INFINITY);
        assert!(cells > 3, "{cells}");
    }

    #[test]
    fn a_ray_missing_the_grid_visits_nothing() {
        let g = grid_of(&[([0.0, 0.0], [1.0, 1.0]), ([3.0, 3.0], [4.0, 4.0])]);
        let away = Ray::new(DVec3::new(-1.0, -1.0, 0.0), DVec3::new(-1.0, 0.0, 0.0));
        assert!(CellWalk::new(&g, &away, 50.0).next_cell(&g).is_none());
        let vertical = Ray::new(DVec3::new(10.0, 0.5, 0.0), DVec3::Z);
        assert!(CellWalk::new(&g, &vertical, 50.0).next_cell(&g).is_none());
        let short = Ray::new(DVec3::new(-5.0, 0.5, 0.0), DVec3::X);
        assert!(CellWalk::new(&g, &short, 1.0).next_cell(&g).is_none());
    }

    #[test]
    fn every_object_is_listed_in_the_cells_its_footprint_meets() {
        let g = grid_of(&[([0.0, 0.0], [10.0, 0.2]), ([4.0, 4.0], [4.5, 4.5])]);
        assert!(g.at_point(DVec3::new(9.9, 0.1, 0.0)).contains(&0));
        assert!(g.at_point(DVec3::new(4.2, 4.2, 0.0)).contains(&1));
        let mut near: Vec<u32> = g
            .in_rect(DVec2::new(3.9, 0.0), DVec2::new(4.1, 4.1))
            .collect();
        near.sort();
        near.dedup();
        assert_eq!(near, vec![0, 1]);
        assert_eq!(
            g.in_rect(DVec2::new(20.0, 20.0), DVec2::new(21.0, 21.0))
                .count(),
            0
        );
    }

    #[test]
    fn cell_count_stays_bounded_for_a_huge_sparse_world() {
        let g = grid_of(&[
            ([0.0, 0.0], [1.0, 1.0]),
            ([1e6, 1e6], [1e6 + 1.0, 1e6 + 1.0]),
        ]);
        assert!(g.nx * g.ny <= 24, "{} x {}", g.nx, g.ny);
    }
}

#[cfg(test)]
mod extreme_tests {
    use crate::world::{MaterialTable, Object, Ray, Shape, World};
    use glam::DVec3;

    /// Objects 1e300 m apart: the grid degenerates to a few cells, but every query answers.
    #[test]
    fn queries_on_a_world_of_extreme_extent_answer_without_panicking() {
        let m = MaterialTable::default();
        let concrete = m.id("concrete").unwrap();
        let objects = [0.0, 1e300, -1e300]
            .into_iter()
            .map(|x| Object {
                name: None,
                shape: Shape::sphere(DVec3::new(x, 0.0, 1.0), 1.0).unwrap(),
                material: concrete,
            })
            .collect();
        let w = World::new(m, objects);
        let mut tracer = crate::sensor::Tracer::default();
        let r = tracer.trace(
            &w,
            &Ray::new(DVec3::new(-5.0, 0.0, 1.0), DVec3::X),
            crate::world::Band::Laser,
            0.0,
            100.0,
        );
        assert!((r.range - 4.0).abs() < 1e-9, "{r:?}");
        let mut fan = crate::world::Fan::default();
        assert!(w.fan(DVec3::new(-5.0, 0.0, 1.0), 100.0, 64, 100, &mut fan));
        let body = crate::world::overlap::body_box(0.0, 0.0, 0.0, 0.5, 0.5, 0.3);
        assert_eq!(w.blocking_object(&body), Some(0));
        assert_eq!(w.objects_at(DVec3::new(1e300, 0.0, 1.0)).count(), 1);
    }
}
