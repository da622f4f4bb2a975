//! The ground truth a map is scored against, and the scores.
//!
//! The truth raster covers the world's bounding rectangle in the map's cells. A cell is an
//! *obstacle* when a non-traversable object overlaps its column from the ground up to the scan
//! plane (or the vehicle's height, if higher); otherwise it is *free*. Free cells are split
//! by what can be seen, in the scan plane, from anywhere the robot can reach from its start
//! (viewpoints 0.5 m apart, spread wider when there would be more than 1024; sight up to the
//! 30 m of the laser that defines "seen"):
//! *hidden* cells are in sight only through penetrable matter (foliage, smoke): a laser
//! cannot see them, an ideal radar with an endless budget could. This is the area behind the
//! foliage wall. *Outside* cells are out of sight even through foliage (beyond the room's
//! walls); no sensor of the robot can map them, so free recall leaves them out.

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::grid::{CellClass, Grid};
use super::mapper::Mapper;
use super::walk::{CellIndex, CellWalk, cell_of};
use crate::pose::Pose;
use crate::sensor::{Tracer, preset};
use crate::vehicle::VehicleSpec;
use crate::world::overlap::body_box;
use crate::world::{Band, Ray, World};

/// What a truth cell is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TruthCell {
    /// Nothing the robot could hit.
    Free,
    /// Free, but seen from where the robot can go only through penetrable matter.
    Hidden,
    /// Free, but not in sight from where the robot can go, even through penetrable matter.
    Outside,
    /// A non-traversable object.
    Obstacle,
}

/// Laser viewpoints are taken from reachable cells about this far apart, m.
const VIEWPOINT_SPACING: f64 = 0.5;
/// Azimuths per viewpoint.
const VIEW_RAYS: usize = 720;
/// Most viewpoints: in a larger world they are spread wider, so scoring costs what a
/// 16 x 16 m area costs at most, not what the world's extent does (DESIGN §12).
const MAX_VIEWPOINTS: usize = 1024;

/// A world rasterised for scoring.
#[derive(Clone, Debug)]
pub struct Truth {
    resolution: f64,
    plane_z: f64,
    origin: CellIndex,
    width: usize,
    height: usize,
    cells: Vec<TruthCell>,
    /// Free cells (hidden ones included) and hidden cells: [`Truth::coverage`]'s totals.
    free_hidden: (usize, usize),
}

impl Truth {
    /// Rasterises `world` in `resolution`-metre cells for a robot of `vehicle` starting at
    /// `start`, with a scan plane `plane_z` metres high.
    pub fn of_world(
        world: &World,
        resolution: f64,
        plane_z: f64,
        vehicle: &VehicleSpec,
        start: &Pose,
    ) -> Self {
        let Some((lo, hi)) = world.bounds() else {
            return Self {
                resolution,
                plane_z,
                origin: (0, 0),
                width: 0,
                height: 0,
                cells: Vec::new(),
                free_hidden: (0, 0),
            };
        };
        let (c0, c1) = (
            cell_of(lo.truncate(), resolution),
            cell_of(hi.truncate(), resolution),
        );
        let (width, height) = ((c1.0 - c0.0 + 1) as usize, (c1.1 - c0.1 + 1) as usize);
        let centre = |k: usize| {
            DVec2::new(
                (c0.0 + (k % width) as i64) as f64 + 0.5,
                (c0.1 + (k / width) as i64) as f64 + 0.5,
            ) * resolution
        };
        let top = plane_z.max(vehicle.height);
        let obstacle: Vec<bool> = (0..width * height)
            .into_par_iter()
            .map(|k| {
                let c = centre(k);
                let cell = body_box(c.x, c.y, 0.0, resolution, resolution, top);
                world.blocking_object(&cell).is_some()
            })
            .collect();
        // Where the robot's centre can be: a square of its smaller side fits (it can turn).
        let side = vehicle.width.min(vehicle.length);
        let fits: Vec<bool> = (0..width * height)
            .into_par_iter()
            .map(|k| {
                let c = centre(k);
                let body = body_box(c.x, c.y, 0.0, side, side, vehicle.height);
                world.blocking_object(&body).is_none()
            })
            .collect();
        let reachable = flood_fill(&fits, width, height, cell_of(start.xy(), resolution), c0);
        let stride = ((VIEWPOINT_SPACING / resolution).round() as usize).max(1);
        let open = reachable.iter().filter(|&&r| r).count();
        let planned = open as f64 / (stride * stride) as f64;
        let spread = ((planned / MAX_VIEWPOINTS as f64).sqrt().ceil() as usize).max(1);
        let stride = stride * spread;
        let start_k = index_in(cell_of(start.xy(), resolution), c0, width, height);
        let viewpoints: Vec<usize> = (0..width * height)
            .filter(|&k| {
                reachable[k] && (k % width % stride == 0 && k / width % stride == 0)
                    || Some(k) == start_k && reachable[k]
            })
            .collect();
        let laser = preset("hokuyo_utm30lx").expect("built-in preset");
        // Sight ends at the laser's range: farther cells no sensor maps from there.
        let reach = ((hi - lo).truncate().length() + 1.0).min(laser.range_max);
        // Per cell: bit 0 seen by the laser, bit 1 in sight through penetrable matter.
        let seen = viewpoints
            .par_iter()
            .fold(
                || (vec![0u8; width * height], Tracer::default()),
                |(mut seen, mut tracer), &k| {
                    let o = centre(k);
                    for a in 0..VIEW_RAYS {
                        let angle = a as f64 * std::f64::consts::TAU / VIEW_RAYS as f64;
                        let (s, c) = angle.sin_cos();
                        let ray = Ray::new(DVec3::new(o.x, o.y, plane_z), DVec3::new(c, s, 0.0));
                        let sights = [
                            (laser.kind.band(), laser.penetration_db, 1u8),
                            (Band::Radar, f64::INFINITY, 2u8),
                        ];
                        for (band, budget, bit) in sights {
                            let ret = tracer.trace(world, &ray, band, budget, reach);
                            let end = o + DVec2::new(c, s) * ret.range.min(reach);
                            for cell in CellWalk::new(o, end, resolution) {
                                match index_in(cell, c0, width, height) {
                                    Some(i) => seen[i] |= bit,
                                    None => break,
                                }
                            }
                        }
                    }
                    (seen, tracer)
                },
            )
            .map(|(seen, _)| seen)
            .reduce(
                || vec![0u8; width * height],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x |= y);
                    a
                },
            );
        let cells: Vec<TruthCell> = (0..width * height)
            .map(|k| {
                if obstacle[k] {
                    TruthCell::Obstacle
                } else if seen[k] & 1 != 0 {
                    TruthCell::Free
                } else if seen[k] & 2 != 0 {
                    TruthCell::Hidden
                } else {
                    TruthCell::Outside
                }
            })
            .collect();
        Self {
            resolution,
            plane_z,
            origin: c0,
            width,
            height,
            free_hidden: free_hidden(&cells),
            cells,
        }
    }

    /// A truth raster from explicit cells (row 0 = lowest y), for tests and hand-made cases.
    pub fn from_cells(
        resolution: f64,
        origin: CellIndex,
        width: usize,
        cells: Vec<TruthCell>,
    ) -> Self {
        let height = cells.len().checked_div(width).unwrap_or(0);
        Self {
            resolution,
            plane_z: 0.0,
            origin,
            width,
            height,
            free_hidden: free_hidden(&cells),
            cells,
        }
    }

    /// Cell size, m.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Height of the slice, m.
    pub fn plane_z(&self) -> f64 {
        self.plane_z
    }

    /// The truth of a global cell (`None` outside the raster).
    pub fn get(&self, c: CellIndex) -> Option<TruthCell> {
        index_in(c, self.origin, self.width, self.height).map(|k| self.cells[k])
    }

    /// Cells of each kind: (free, hidden, outside, obstacle).
    pub fn counts(&self) -> (usize, usize, usize, usize) {
        let n = |t| self.cells.iter().filter(|&&c| c == t).count();
        (
            n(TruthCell::Free),
            n(TruthCell::Hidden),
            n(TruthCell::Outside),
            n(TruthCell::Obstacle),
        )
    }

    /// The free and hidden coverage of `grid` (same resolution): [`MapScores::free_coverage`]
    /// and [`MapScores::hidden_coverage`] of [`Truth::score`], the same values, counted over
    /// the rows and columns both rasters hold, as a run samples them once a second.
    pub fn coverage(&self, grid: &Grid) -> (Option<f64>, Option<f64>) {
        let is_free = |t: TruthCell| matches!(t, TruthCell::Free | TruthCell::Hidden);
        let (free_true, hidden) = self.free_hidden;
        let (mut free_seen, mut hidden_seen) = (0usize, 0usize);
        // The overlap of the two rasters, in global cells: a cell off the grid is unknown.
        let (g0, t0) = (grid.origin_cell(), self.origin);
        let x0 = g0.0.max(t0.0);
        let x1 = (g0.0 + grid.width() as i64).min(t0.0 + self.width as i64);
        let y0 = g0.1.max(t0.1);
        let y1 = (g0.1 + grid.height() as i64).min(t0.1 + self.height as i64);
        if x0 < x1 {
            let n = (x1 - x0) as usize;
            for y in y0..y1 {
                let t = (y - t0.1) as usize * self.width + (x0 - t0.0) as usize;
                let g = (y - g0.1) as usize * grid.width() + (x0 - g0.0) as usize;
                for (i, &c) in self.cells[t..t + n].iter().enumerate() {
                    let seen = usize::from(grid.sensor_clear_at(g + i));
                    free_seen += usize::from(is_free(c)) & seen;
                    hidden_seen += usize::from(c == TruthCell::Hidden) & seen;
                }
            }
        }
        let ratio = |a: usize, b: usize| (b > 0).then(|| a as f64 / b as f64);
        (ratio(free_seen, free_true), ratio(hidden_seen, hidden))
    }

    /// Scores `grid` (same resolution) against this truth.
    pub fn score(&self, grid: &Grid) -> MapScores {
        let mut hidden = 0usize;
        let mut hidden_seen = 0usize;
        let (mut obs_tp, mut obs_pred, mut obs_true) = (0usize, 0usize, 0usize);
        let (mut free_tp, mut free_pred, mut free_true) = (0usize, 0usize, 0usize);
        let mut free_found = 0usize;
        let mut free_seen = 0usize;
        let mut known = 0usize;
        // Row by row: no division per cell to find its column and row.
        let rows = self.cells.chunks(self.width.max(1));
        let cells = rows.enumerate().flat_map(|(j, row)| {
            let y = self.origin.1 + j as i64;
            (row.iter().enumerate()).map(move |(i, &t)| ((self.origin.0 + i as i64, y), t))
        });
        for (c, t) in cells {
            let class = grid.class(c);
            let truly_free = t != TruthCell::Obstacle;
            known += usize::from(class != CellClass::Unknown);
            if t == TruthCell::Hidden {
                hidden += 1;
                hidden_seen += usize::from(class.sensor_clear());
            }
            obs_true += usize::from(!truly_free);
            free_true += usize::from(truly_free && t != TruthCell::Outside);
            free_seen += usize::from(truly_free && t != TruthCell::Outside && class.sensor_clear());
            if class.blocks() {
                obs_pred += 1;
                obs_tp += usize::from(!truly_free);
            } else if class == CellClass::Clear {
                free_pred += 1;
                free_tp += usize::from(truly_free);
                free_found += usize::from(truly_free && t != TruthCell::Outside);
            }
        }
        let ratio = |a: usize, b: usize| (b > 0).then(|| a as f64 / b as f64);
        let area = self.resolution * self.resolution;
        MapScores {
            cells: self.cells.len(),
            known_area_m2: known as f64 * area,
            hidden_area_m2: hidden as f64 * area,
            hidden_clear_m2: hidden_seen as f64 * area,
            hidden_coverage: ratio(hidden_seen, hidden),
            obstacle_precision: ratio(obs_tp, obs_pred),
            obstacle_recall: ratio(obs_tp, obs_true),
            free_precision: ratio(free_tp, free_pred),
            free_recall: ratio(free_found, free_true),
            free_coverage: ratio(free_seen, free_true),
        }
    }
}

/// How well a map matches the truth, over the world's bounding rectangle. `None` where a
/// ratio has nothing to count.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MapScores {
    /// Cells scored.
    pub cells: usize,
    /// Area the map knows something about (not unknown), m².
    pub known_area_m2: f64,
    /// Free area hidden from a laser anywhere the robot can reach, m².
    pub hidden_area_m2: f64,
    /// Of it, the area mapped sensor-clear (white or grey), m².
    pub hidden_clear_m2: f64,
    /// `hidden_clear_m2 / hidden_area_m2`: how much of the hidden area the map reveals.
    pub hidden_coverage: Option<f64>,
    /// Of the cells mapped impassable (black or grey), the share that are obstacles.
    pub obstacle_precision: Option<f64>,
    /// Of the obstacle cells, the share mapped impassable (insides no sensor reaches count).
    pub obstacle_recall: Option<f64>,
    /// Of the cells mapped clear (white), the share that are free.
    pub free_precision: Option<f64>,
    /// Of the free cells in sight (directly or through foliage), the share mapped clear.
    pub free_recall: Option<f64>,
    /// Of the free cells in sight, the share the sensor saw (white or grey): how much of the
    /// free area an exploration has covered.
    pub free_coverage: Option<f64>,
}

/// Scores each map against the truth of `world` for a robot of `vehicle` starting at
/// `start`; maps of the same resolution and scan plane share one truth raster.
pub fn score_maps<'m>(
    world: &World,
    vehicle: &VehicleSpec,
    start: &Pose,
    maps: impl IntoIterator<Item = &'m Mapper>,
) -> Vec<MapScores> {
    let mut truths: Vec<Truth> = Vec::new();
    maps.into_iter()
        .map(|m| {
            let key = (m.config().resolution, m.plane_z());
            let i = match truths.iter().position(|t| (t.resolution, t.plane_z) == key) {
                Some(i) => i,
                None => {
                    truths.push(Truth::of_world(world, key.0, key.1, vehicle, start));
                    truths.len() - 1
                }
            };
            truths[i].score(m.grid())
        })
        .collect()
}

/// The free cells (hidden ones included) and the hidden cells of `cells`.
fn free_hidden(cells: &[TruthCell]) -> (usize, usize) {
    let n = |t| cells.iter().filter(|&&c| c == t).count();
    let hidden = n(TruthCell::Hidden);
    (n(TruthCell::Free) + hidden, hidden)
}

fn index_in(c: CellIndex, origin: CellIndex, width: usize, height: usize) -> Option<usize> {
    let (i, j) = (c.0 - origin.0, c.1 - origin.1);
    (i >= 0 && j >= 0 && (i as usize) < width && (j as usize) < height)
        .then(|| j as usize * width + i as usize)
}

/// Cells connected (4-neighbours) to `start` through `open` cells.
fn flood_fill(
    open: &[bool],
    width: usize,
    height: usize,
    start: CellIndex,
    origin: CellIndex,
) -> Vec<bool> {
    flood_fill_from(
        open,
        width,
        height,
        index_in(start, origin, width, height).into_iter(),
    )
}

/// The cells of a `width` × `height` raster (row-major) reachable from `seeds` through `open`
/// cells, moving between 4-neighbours.
pub(crate) fn flood_fill_from(
    open: &[bool],
    width: usize,
    height: usize,
    seeds: impl Iterator<Item = usize>,
) -> Vec<bool> {
    let mut seen = vec![false; open.len()];
    let mut stack = Vec::new();
    for s in seeds {
        if open[s] && !seen[s] {
            seen[s] = true;
            stack.push(s);
        }
    }
    while let Some(k) = stack.pop() {
        let (i, j) = (k % width, k / width);
        let mut push = |n: usize| {
            if open[n] && !seen[n] {
                seen[n] = true;
                stack.push(n);
            }
        };
        if i > 0 {
            push(k - 1);
        }
        if i + 1 < width {
            push(k + 1);
        }
        if j > 0 {
            push(k - width);
        }
        if j + 1 < height {
            push(k + width);
        }
    }
    seen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::grid::{Layers, Occupancy};
    use crate::setup::Scenario;

    #[test]
    fn scores_on_a_hand_made_grid() {
        use TruthCell::{Free as F, Hidden as H, Obstacle as O, Outside as X};
        // 5 × 2 cells: row 0 = F F O H X, row 1 = F O H H X.
        let truth = Truth::from_cells(1.0, (0, 0), 5, vec![F, F, O, H, X, F, O, H, H, X]);
        let mut g = Grid::new(1.0, Occupancy::default());
        let clear = |g: &mut Grid, c: CellIndex, layers| {
            for _ in 0..5 {
                g.mark_cells([c], false, layers);
            }
        };
        clear(&mut g, (0, 0), Layers::Both); // clear, right
        clear(&mut g, (1, 0), Layers::Both); // clear, right
        g.mark_cells([(2, 0)], true, Layers::Both); // obstacle, right
        clear(&mut g, (3, 0), Layers::Sensed); // hidden, revealed
        g.mark_cells([(1, 1)], true, Layers::Both);
        clear(&mut g, (1, 1), Layers::Sensed); // grey on an obstacle: right
        g.mark_cells([(2, 1)], true, Layers::Passable);
        clear(&mut g, (2, 1), Layers::Sensed); // grey on hidden free: wrong, but revealed
        clear(&mut g, (4, 0), Layers::Both); // outside: free, counts for precision only
        // (0, 1), (3, 1) and (4, 1) stay unknown.
        let s = truth.score(&g);
        assert_eq!(s.cells, 10);
        assert_eq!(s.known_area_m2, 7.0);
        assert_eq!(s.hidden_area_m2, 3.0);
        assert_eq!(s.hidden_clear_m2, 2.0);
        assert_eq!(s.hidden_coverage, Some(2.0 / 3.0));
        assert_eq!(s.obstacle_precision, Some(2.0 / 3.0));
        assert_eq!(s.obstacle_recall, Some(1.0));
        assert_eq!(s.free_precision, Some(1.0));
        assert_eq!(s.free_recall, Some(3.0 / 6.0));
        assert_eq!(truth.counts(), (3, 3, 2, 2));
        // An empty map scores nothing.
        let e = truth.score(&Grid::new(1.0, Occupancy::default()));
        assert_eq!((e.obstacle_precision, e.free_precision), (None, None));
        assert_eq!(e.hidden_coverage, Some(0.0));
    }

    proptest::proptest! {
        /// The once-a-second coverage is the score's, on rasters that overlap in part.
        #[test]
        fn coverage_is_the_scores(
            kinds in proptest::collection::vec(0u8..4, 120),
            width in 1usize..12,
            height in 1usize..10,
            origin in (-6i64..6, -6i64..6),
            marks in proptest::collection::vec(((-8i64..14, -8i64..14), 0u8..5, 1usize..6), 0..80),
        ) {
            let cells: Vec<TruthCell> = kinds[..width * height]
                .iter()
                .map(|k| [TruthCell::Free, TruthCell::Hidden, TruthCell::Outside, TruthCell::Obstacle][*k as usize])
                .collect();
            let truth = Truth::from_cells(1.0, origin, width, cells);
            let mut g = Grid::new(1.0, Occupancy::default());
            // Repeated marks: one miss alone leaves a cell unknown.
            for (c, how, times) in marks {
                for _ in 0..times {
                    match how {
                        0 => g.mark_cells([c], true, Layers::Both),
                        1 => g.mark_cells([c], true, Layers::Passable),
                        2 => g.mark_cells([c], false, Layers::Sensed),
                        _ => g.mark_cells([c], false, Layers::Both),
                    }
                }
            }
            let s = truth.score(&g);
            proptest::prop_assert_eq!(truth.coverage(&g), (s.free_coverage, s.hidden_coverage));
        }
    }

    #[test]
    fn foliage_wall_hides_the_far_side() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let r = &s.robots[0];
        let t = Truth::of_world(&s.world, 0.05, 0.4, r.vehicle, &r.start);
        let at = |x: f64, y: f64| t.get(cell_of(DVec2::new(x, y), 0.05)).unwrap();
        assert_eq!(at(3.0, 4.0), TruthCell::Free);
        assert_eq!(at(1.5, 7.0), TruthCell::Obstacle, "cabinet");
        assert_eq!(at(7.0, 4.0), TruthCell::Obstacle, "foliage core");
        assert_eq!(at(9.0, 4.0), TruthCell::Hidden);
        assert_eq!(at(11.5, 0.5), TruthCell::Hidden);
        assert_eq!(at(10.0, 2.5), TruthCell::Obstacle, "crate");
        // Behind the cabinet is visible from elsewhere in the room.
        assert_eq!(at(1.5, 7.9), TruthCell::Free);
        assert_eq!(at(6.0, -0.5), TruthCell::Outside, "beyond the room wall");
        let (free, hidden, _, _) = t.counts();
        // The far side is about 4 × 8 m less the crate and pole and the foliage's reach.
        let hidden_m2 = hidden as f64 * 0.0025;
        assert!((28.0..34.0).contains(&hidden_m2), "{hidden_m2}");
        assert!(free as f64 * 0.0025 > 40.0);
        // No hidden cell on the near side of the wall.
        for j in 0..160 {
            for i in 0..120 {
                let c = (i, j);
                assert_ne!(t.get(c), Some(TruthCell::Hidden), "{c:?}");
            }
        }
    }
}
