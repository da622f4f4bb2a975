//! The two-layer log-odds occupancy grid (DESIGN §5).
//!
//! Layer `sensed` records what the sensors saw: cells a ray passed through become freer, the
//! cell of a return more occupied. Layer `passable` records what the robot may drive on:
//! returns of every sensor and bumps make it more occupied, only rays that stop at the first
//! thing in their way (laser, ground truth) and the robot's own footprint make it freer. A
//! radar ray that crosses foliage therefore clears `sensed` there but not `passable`.

use glam::DVec2;
use serde::Serialize;

use super::union::{UnionScratch, mark_union};
use super::walk::{CellIndex, CellWalk, cell_of};

/// `ln(p / (1 - p))`.
pub fn logit(p: f64) -> f32 {
    (p / (1.0 - p)).ln() as f32
}

/// Log-odds update and classification settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Occupancy {
    /// Probability a return gives its cell (update `logit(hit)`).
    pub hit: f64,
    /// Probability a ray passing through gives a cell (update `logit(miss)`).
    pub miss: f64,
    /// Lower clamp of a cell's probability, so a cell can change its mind.
    pub min: f64,
    /// Upper clamp.
    pub max: f64,
    /// Above this a cell is occupied (ROS `map_server` `occupied_thresh`).
    pub occupied_thresh: f64,
    /// Below this a cell is free (ROS `map_server` `free_thresh`).
    pub free_thresh: f64,
}

impl Default for Occupancy {
    /// One return makes a cell occupied (0.7 > 0.65); four rays through it make it free
    /// (0.4⁴ odds: p = 0.165 < 0.196). Clamped to [0.12, 0.97], so a cell changes its mind
    /// after a bounded number of contrary scans (8 misses un-occupy a saturated cell).
    fn default() -> Self {
        Self {
            hit: 0.7,
            miss: 0.4,
            min: 0.12,
            max: 0.97,
            occupied_thresh: 0.65,
            free_thresh: 0.196,
        }
    }
}

impl Occupancy {
    /// Checks the probabilities are ordered and inside (0, 1).
    pub fn validate(&self) -> Result<(), String> {
        let open = |p: f64| p > 0.0 && p < 1.0;
        if !(open(self.min) && open(self.max) && open(self.hit) && open(self.miss)) {
            return Err("probabilities must lie strictly between 0 and 1".into());
        }
        if !(self.miss < 0.5 && self.hit > 0.5) {
            return Err(format!(
                "need miss < 0.5 < hit, found miss {} and hit {}",
                self.miss, self.hit
            ));
        }
        if !(self.min < self.free_thresh
            && self.free_thresh <= self.occupied_thresh
            && self.occupied_thresh < self.max)
        {
            return Err(format!(
                "need min < free_thresh <= occupied_thresh < max, found {} {} {} {}",
                self.min, self.free_thresh, self.occupied_thresh, self.max
            ));
        }
        Ok(())
    }
}

/// What a map says about a cell, in the thesis' palette (its figure 15).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum CellClass {
    /// No evidence either way (blue).
    Unknown = 0,
    /// Clear to the sensor and not known to block the robot (white).
    Clear = 1,
    /// Seen through by the sensor but not passable: foliage (grey).
    SeeThrough = 2,
    /// A return, or known to block the robot (black).
    Obstacle = 3,
}

impl CellClass {
    /// Every class, by code.
    pub const ALL: [CellClass; 4] = [
        CellClass::Unknown,
        CellClass::Clear,
        CellClass::SeeThrough,
        CellClass::Obstacle,
    ];

    /// The thesis' colour.
    pub fn rgb(self) -> [u8; 3] {
        match self {
            Self::Unknown => [70, 110, 200],
            Self::Clear => [255, 255, 255],
            Self::SeeThrough => [150, 150, 150],
            Self::Obstacle => [0, 0, 0],
        }
    }

    /// Legend text.
    pub fn label(self) -> &'static str {
        match self {
            Self::Unknown => "unknown",
            Self::Clear => "sensor-clear",
            Self::SeeThrough => "seen through, impassable",
            Self::Obstacle => "obstacle",
        }
    }

    /// Whether the sensor saw through the cell (white or grey).
    pub fn sensor_clear(self) -> bool {
        matches!(self, Self::Clear | Self::SeeThrough)
    }

    /// Whether the robot should not drive into the cell (grey or black).
    pub fn blocks(self) -> bool {
        matches!(self, Self::SeeThrough | Self::Obstacle)
    }
}

/// Which layers an update touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layers {
    /// Both `sensed` and `passable`.
    Both,
    /// Only `sensed`.
    Sensed,
    /// Only `passable`.
    Passable,
}

impl Layers {
    fn sensed(self) -> bool {
        self != Self::Passable
    }
    fn passable(self) -> bool {
        self != Self::Sensed
    }
}

/// One ray of an update, in the plane: from the sensor to where it ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beam {
    /// Sensor position.
    pub from: DVec2,
    /// End of the ray: the return, or where free space stops being claimed.
    pub to: DVec2,
    /// Whether `to` is a return (its cell gets the hit).
    pub hit: bool,
}

/// Cells added around the needed extent when the grid grows, so growth is rare.
const GROW_PAD: i64 = 64;

/// A growing two-layer occupancy grid. Row 0 is the southern-most (lowest y) row.
#[derive(Clone, Debug)]
pub struct Grid {
    resolution: f64,
    occupancy: Occupancy,
    l_hit: f32,
    l_miss: f32,
    l_min: f32,
    l_max: f32,
    /// Log-odds of `occupied_thresh` and `free_thresh`.
    l_occupied: f32,
    l_free: f32,
    /// Global index of column 0 and row 0.
    origin: CellIndex,
    width: usize,
    height: usize,
    sensed: Vec<f32>,
    passable: Vec<f32>,
    /// Number of the last update that touched each cell: a cell changes once per update.
    mark: Vec<u32>,
    /// Scratch of [`Grid::insert`]: the cells its rays crossed; all zero between updates.
    seen: Vec<u8>,
    /// Scratch of [`mark_union`].
    union: UnionScratch,
    updates: u32,
    /// The rectangle the grid may grow over (`None`: anywhere), m.
    limit: Option<(DVec2, DVec2)>,
}

impl Grid {
    /// An empty grid of `resolution`-metre cells.
    pub fn new(resolution: f64, occupancy: Occupancy) -> Self {
        let l = |p| logit(p);
        Self {
            resolution,
            occupancy,
            l_hit: l(occupancy.hit),
            l_miss: l(occupancy.miss),
            l_min: l(occupancy.min),
            l_max: l(occupancy.max),
            l_occupied: l(occupancy.occupied_thresh),
            l_free: l(occupancy.free_thresh),
            origin: (0, 0),
            width: 0,
            height: 0,
            sensed: Vec::new(),
            passable: Vec::new(),
            mark: Vec::new(),
            seen: Vec::new(),
            union: UnionScratch::default(),
            updates: 0,
            limit: None,
        }
    }

    /// Keeps the grid inside the rectangle `lo..hi` (m): rays are cut at its edge (a cut
    /// return is no return) and cells outside it are dropped, so no scan can grow the grid
    /// past the size estimated for it (DESIGN §12).
    pub fn limit_to(&mut self, lo: DVec2, hi: DVec2) {
        self.limit = Some((lo, hi));
    }

    /// The rectangle set by [`Grid::limit_to`].
    pub fn limit(&self) -> Option<(DVec2, DVec2)> {
        self.limit
    }

    /// `beam` cut to the limit; `None` when it lies outside.
    fn clip(&self, beam: &Beam) -> Option<Beam> {
        let Some((lo, hi)) = self.limit else {
            return Some(*beam);
        };
        // Liang–Barsky on the parameter t of from + t (to − from), t in [0, 1].
        let d = beam.to - beam.from;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-d.x, beam.from.x - lo.x),
            (d.x, hi.x - beam.from.x),
            (-d.y, beam.from.y - lo.y),
            (d.y, hi.y - beam.from.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        if t0 > t1 {
            return None;
        }
        // Clamped: rounding must not put a cut end a hair outside the rectangle.
        Some(Beam {
            from: (beam.from + d * t0).clamp(lo, hi),
            to: if t1 < 1.0 {
                (beam.from + d * t1).clamp(lo, hi)
            } else {
                beam.to
            },
            hit: beam.hit && t1 >= 1.0,
        })
    }

    /// Whether a cell is inside the limit.
    fn allowed(&self, c: CellIndex) -> bool {
        self.limit.is_none_or(|(lo, hi)| {
            let (a, b) = (self.cell_of(lo), self.cell_of(hi));
            (a.0..=b.0).contains(&c.0) && (a.1..=b.1).contains(&c.1)
        })
    }

    /// Cell size, m.
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// The update and classification settings.
    pub fn occupancy(&self) -> &Occupancy {
        &self.occupancy
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Global index of cell (0, 0).
    pub fn origin_cell(&self) -> CellIndex {
        self.origin
    }

    /// World position of the lower-left corner of cell (0, 0), m.
    pub fn origin(&self) -> DVec2 {
        DVec2::new(self.origin.0 as f64, self.origin.1 as f64) * self.resolution
    }

    /// Log-odds of layer `sensed`, row by row from row 0.
    pub fn sensed(&self) -> &[f32] {
        &self.sensed
    }

    /// Log-odds of layer `passable`, row by row from row 0.
    pub fn passable(&self) -> &[f32] {
        &self.passable
    }

    /// The storage index of a global cell, `None` outside the grid.
    pub fn index(&self, c: CellIndex) -> Option<usize> {
        let (i, j) = (c.0 - self.origin.0, c.1 - self.origin.1);
        (i >= 0 && j >= 0 && (i as usize) < self.width && (j as usize) < self.height)
            .then(|| j as usize * self.width + i as usize)
    }

    /// The global cell holding world point `p`.
    pub fn cell_of(&self, p: DVec2) -> CellIndex {
        cell_of(p, self.resolution)
    }

    /// Log-odds (sensed, passable) of a global cell; 0 outside the grid.
    pub fn log_odds(&self, c: CellIndex) -> (f32, f32) {
        self.index(c)
            .map_or((0.0, 0.0), |k| (self.sensed[k], self.passable[k]))
    }

    /// The class of a global cell (unknown outside the grid).
    pub fn class(&self, c: CellIndex) -> CellClass {
        self.index(c)
            .map_or(CellClass::Unknown, |k| self.class_at(k))
    }

    /// The class of storage index `k`.
    pub fn class_at(&self, k: usize) -> CellClass {
        let (occ, free) = (self.l_occupied, self.l_free);
        let (s, p) = (self.sensed[k], self.passable[k]);
        if p > occ {
            if s < free {
                CellClass::SeeThrough
            } else {
                CellClass::Obstacle
            }
        } else if s > occ {
            CellClass::Obstacle
        } else if s < free || p < free {
            CellClass::Clear
        } else {
            CellClass::Unknown
        }
    }

    /// Whether storage index `k` is sensor-clear: [`CellClass::sensor_clear`] of
    /// [`Grid::class_at`], without the class's branches.
    pub fn sensor_clear_at(&self, k: usize) -> bool {
        let (occ, free) = (self.l_occupied, self.l_free);
        let (s, p) = (self.sensed[k], self.passable[k]);
        if free <= occ {
            // Clear or see-through: sensed clear, or passable clear and not sensed occupied.
            (s < free) | ((p < free) & (s <= occ))
        } else {
            // Thresholds `Occupancy::validate` refuses: the classes decide.
            self.class_at(k).sensor_clear()
        }
    }

    /// The class of every cell, row by row from row 0.
    pub fn classes(&self) -> Vec<CellClass> {
        (0..self.sensed.len()).map(|k| self.class_at(k)).collect()
    }

    /// Grows the grid (keeping its contents) so that it holds cells `lo..=hi`.
    pub fn ensure(&mut self, lo: CellIndex, hi: CellIndex) {
        let (x0, y0) = self.origin;
        let (x1, y1) = (x0 + self.width as i64, y0 + self.height as i64);
        if self.width > 0 && lo.0 >= x0 && lo.1 >= y0 && hi.0 < x1 && hi.1 < y1 {
            return;
        }
        let (nx0, ny0, nx1, ny1) = if self.width == 0 {
            (
                lo.0 - GROW_PAD,
                lo.1 - GROW_PAD,
                hi.0 + GROW_PAD + 1,
                hi.1 + GROW_PAD + 1,
            )
        } else {
            let pad = |need: bool| if need { GROW_PAD } else { 0 };
            (
                lo.0.min(x0) - pad(lo.0 < x0),
                lo.1.min(y0) - pad(lo.1 < y0),
                (hi.0 + 1).max(x1) + pad(hi.0 >= x1),
                (hi.1 + 1).max(y1) + pad(hi.1 >= y1),
            )
        };
        // The padding stops at the limit: the grid never outgrows its estimate.
        let (nx0, ny0, nx1, ny1) = match self.limit {
            Some((a, b)) => {
                let (a, b) = (self.cell_of(a), self.cell_of(b));
                // What must stay: the cells asked for and those already held.
                let (k0, k1) = if self.width == 0 {
                    (lo, (hi.0 + 1, hi.1 + 1))
                } else {
                    (
                        (lo.0.min(x0), lo.1.min(y0)),
                        ((hi.0 + 1).max(x1), (hi.1 + 1).max(y1)),
                    )
                };
                (
                    nx0.max(a.0.min(k0.0)),
                    ny0.max(a.1.min(k0.1)),
                    nx1.min((b.0 + 1).max(k1.0)),
                    ny1.min((b.1 + 1).max(k1.1)),
                )
            }
            None => (nx0, ny0, nx1, ny1),
        };
        let (w, h) = ((nx1 - nx0) as usize, (ny1 - ny0) as usize);
        let mut sensed = vec![0.0; w * h];
        let mut passable = vec![0.0; w * h];
        let mut mark = vec![0; w * h];
        for row in 0..self.height {
            let src = row * self.width;
            let dst = (row as i64 + y0 - ny0) as usize * w + (x0 - nx0) as usize;
            sensed[dst..dst + self.width].copy_from_slice(&self.sensed[src..src + self.width]);
            passable[dst..dst + self.width].copy_from_slice(&self.passable[src..src + self.width]);
            mark[dst..dst + self.width].copy_from_slice(&self.mark[src..src + self.width]);
        }
        self.origin = (nx0, ny0);
        (self.width, self.height) = (w, h);
        (self.sensed, self.passable, self.mark) = (sensed, passable, mark);
        self.seen = vec![0; w * h];
    }

    /// Starts an update: every cell changes at most once until the next one, as in
    /// Cartographer's range-data inserter, so a dense scan counts as much as a sparse one.
    fn begin(&mut self) -> u32 {
        self.updates = self.updates.wrapping_add(1);
        if self.updates == 0 {
            self.mark.fill(0);
            self.updates = 1;
        }
        self.updates
    }

    fn apply(&mut self, k: usize, delta: f32, layers: Layers) {
        let (lo, hi) = (self.l_min, self.l_max);
        if layers.sensed() {
            self.sensed[k] = (self.sensed[k] + delta).clamp(lo, hi);
        }
        if layers.passable() {
            self.passable[k] = (self.passable[k] + delta).clamp(lo, hi);
        }
    }

    /// Inserts one scan: the cell of every return gets a hit in both layers; every other cell
    /// a ray passes through gets one miss in `sensed`, and in `passable` too when
    /// `misses_clear_passable` (the sensor stops at the first thing in its way).
    pub fn insert(&mut self, beams: &[Beam], misses_clear_passable: bool) {
        // Scans inside the limit (all of them in a closed world) are used as they are; a ray
        // with an end not a number (a pose gone wrong upstream) says nothing and is dropped.
        let usable = |p: DVec2| match self.limit {
            Some((lo, hi)) => p.cmpge(lo).all() && p.cmple(hi).all(),
            None => p.is_finite(),
        };
        let clipped: Vec<Beam>;
        let beams = if beams.iter().all(|b| usable(b.from) && usable(b.to)) {
            beams
        } else {
            let finite = |b: &&Beam| b.from.is_finite() && b.to.is_finite();
            clipped = beams
                .iter()
                .filter(finite)
                .filter_map(|b| self.clip(b))
                .collect();
            &clipped[..]
        };
        if beams.is_empty() {
            return;
        }
        let (mut lo, mut hi) = (beams[0].from, beams[0].from);
        for b in beams {
            (lo, hi) = (lo.min(b.from).min(b.to), hi.max(b.from).max(b.to));
        }
        // Flooring keeps the order, so the corners' cells bound the cell of every end.
        let (lo, hi) = (self.cell_of(lo), self.cell_of(hi));
        self.ensure(lo, hi);
        let stamp = self.begin();
        let layers = if misses_clear_passable {
            Layers::Both
        } else {
            Layers::Sensed
        };
        // The result depends only on the union of the cells the rays cross (each changes once
        // per update), so the walks only record that union, one byte store per visit: near
        // the sensor a dense scan crosses each cell many times. Then every cell of the union
        // that is not a return of this scan gets its miss, row by row over the scan's extent.
        // Inside the grid: `ensure` covered both ends, so the whole segments.
        let (res, origin, width) = (self.resolution, self.origin, self.width);
        let seen = &mut self.seen[..];
        let exact = mark_union(
            beams,
            |b| (b.from, b.to),
            res,
            origin,
            width,
            seen,
            &mut self.union,
        );
        if !exact {
            // A ray passed within rounding of a cell corner (rare but for poses on the
            // lattice): the whole scan is walked instead, so its cells are the walk's.
            for j in lo.1 - origin.1..=hi.1 - origin.1 {
                let row = j as usize * width;
                seen[row + (lo.0 - origin.0) as usize..=row + (hi.0 - origin.0) as usize].fill(0);
            }
            for b in beams {
                CellWalk::new(b.from, b.to, res)
                    .for_each_index(usize::MAX, origin, width, |k| seen[k] = 1);
            }
        }
        // A return's cell takes its hit (once, however many rays end in it), not a miss,
        // though its ray crossed it. The hits and the misses fall on different cells, so
        // they may come in either order.
        let ends = std::mem::take(&mut self.union.end_cells);
        for (_, &k) in beams.iter().zip(&ends).filter(|(b, _)| b.hit) {
            self.seen[k] = 0;
            if self.mark[k] != stamp {
                self.mark[k] = stamp;
                self.apply(k, self.l_hit, Layers::Both);
            }
        }
        self.union.end_cells = ends;
        let seen = &mut self.seen[..];
        let (lo_l, hi_l, miss) = (self.l_min, self.l_max, self.l_miss);
        let missed = |l: &mut f32| *l = (*l + miss).clamp(lo_l, hi_l);
        let (i0, i1) = (lo.0 - origin.0, hi.0 - origin.0 + 1);
        for j in lo.1 - origin.1..=hi.1 - origin.1 {
            let span = j as usize * width + i0 as usize..j as usize * width + i1 as usize;
            let (seen, sensed, passable) = (
                &mut seen[span.clone()],
                &mut self.sensed[span.clone()],
                &mut self.passable[span],
            );
            // Eight cells at a time: most of a scan's extent is either not crossed at all or
            // crossed all over (near the sensor), and a whole chunk's update vectorises.
            let whole = seen.len() / 8 * 8;
            let mut chunks = seen.chunks_exact_mut(8);
            for (c, chunk) in chunks.by_ref().enumerate() {
                let all = u64::from_ne_bytes(<[u8; 8]>::try_from(&*chunk).unwrap_or_default());
                if all == 0 {
                    continue;
                }
                chunk.fill(0);
                let cells = c * 8..c * 8 + 8;
                if all == u64::from_ne_bytes([1; 8]) {
                    sensed[cells.clone()].iter_mut().for_each(missed);
                    if layers.passable() {
                        passable[cells].iter_mut().for_each(missed);
                    }
                    continue;
                }
                for (k, b) in cells.zip(all.to_ne_bytes()) {
                    if b != 0 {
                        missed(&mut sensed[k]);
                        if layers.passable() {
                            missed(&mut passable[k]);
                        }
                    }
                }
            }
            for k in whole..seen.len() {
                if std::mem::take(&mut seen[k]) != 0 {
                    missed(&mut sensed[k]);
                    if layers.passable() {
                        missed(&mut passable[k]);
                    }
                }
            }
        }
    }

    /// One update of `layers` on `cells`: a hit (`occupied`) or a miss, once per cell.
    pub fn mark_cells(
        &mut self,
        cells: impl IntoIterator<Item = CellIndex>,
        occupied: bool,
        layers: Layers,
    ) {
        let cells: Vec<CellIndex> = cells.into_iter().filter(|&c| self.allowed(c)).collect();
        let Some(&first) = cells.first() else {
            return;
        };
        let (lo, hi) = cells.iter().fold((first, first), |(lo, hi), c| {
            (
                (lo.0.min(c.0), lo.1.min(c.1)),
                (hi.0.max(c.0), hi.1.max(c.1)),
            )
        });
        self.ensure(lo, hi);
        let stamp = self.begin();
        let delta = if occupied { self.l_hit } else { self.l_miss };
        for c in cells {
            if let Some(k) = self.index(c)
                && self.mark[k] != stamp
            {
                self.mark[k] = stamp;
                self.apply(k, delta, layers);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::walk::mark_crossed;

    fn grid() -> Grid {
        Grid::new(0.1, Occupancy::default())
    }

    #[test]
    fn one_ray_frees_its_path_and_hits_its_end() {
        let mut g = grid();
        let beam = Beam {
            from: DVec2::new(0.05, 0.05),
            to: DVec2::new(0.55, 0.05),
            hit: true,
        };
        g.insert(&[beam], true);
        let (h, m) = (logit(0.7), logit(0.4));
        for i in 0..5 {
            assert_eq!(g.log_odds((i, 0)), (m, m), "cell {i}");
        }
        assert_eq!(g.log_odds((5, 0)), (h, h));
        assert_eq!(g.log_odds((6, 0)), (0.0, 0.0));
        assert_eq!(g.class((5, 0)), CellClass::Obstacle);
        // A radar-like ray frees only the sensed layer.
        let mut g = grid();
        g.insert(&[beam], false);
        assert_eq!(g.log_odds((2, 0)), (m, 0.0));
    }

    #[test]
    fn a_cell_changes_once_per_scan_and_hits_win() {
        let mut g = grid();
        let through = Beam {
            from: DVec2::new(0.05, 0.05),
            to: DVec2::new(0.95, 0.05),
            hit: true,
        };
        let ends = Beam {
            to: DVec2::new(0.45, 0.05),
            ..through
        };
        g.insert(&[through, through, ends], true);
        assert_eq!(g.log_odds((4, 0)).0, logit(0.7), "ended in, though crossed");
        assert_eq!(
            g.log_odds((2, 0)).0,
            logit(0.4),
            "crossed by three, counted once"
        );
    }

    #[test]
    fn clamping_and_classes() {
        let mut g = grid();
        let c = (3, -2);
        for _ in 0..20 {
            g.mark_cells([c], true, Layers::Both);
        }
        assert_eq!(g.log_odds(c).0, logit(0.97));
        for _ in 0..3 {
            g.mark_cells([c], false, Layers::Sensed);
        }
        // Sensed is no longer occupied, passable still is.
        assert_eq!(g.class(c), CellClass::Obstacle);
        for _ in 0..10 {
            g.mark_cells([c], false, Layers::Sensed);
        }
        assert_eq!(g.class(c), CellClass::SeeThrough);
        for _ in 0..20 {
            g.mark_cells([c], false, Layers::Passable);
        }
        assert_eq!(g.class(c), CellClass::Clear);
        assert_eq!(g.class((100, 100)), CellClass::Unknown);
    }

    #[test]
    fn growing_keeps_contents() {
        let mut g = grid();
        g.mark_cells([(0, 0)], true, Layers::Both);
        let before = g.log_odds((0, 0));
        g.mark_cells([(-500, 300)], true, Layers::Sensed);
        g.mark_cells([(700, -40)], false, Layers::Passable);
        assert_eq!(g.log_odds((0, 0)), before);
        assert!(g.index((-500, 300)).is_some() && g.index((700, -40)).is_some());
        assert_eq!(g.log_odds((-500, 300)), (logit(0.7), 0.0));
        assert_eq!(g.log_odds((700, -40)), (0.0, logit(0.4)));
        assert_eq!(g.width() * g.height(), g.sensed().len());
    }

    proptest::proptest! {
        /// A limited grid never grows past its rectangle, and inside it holds what an
        /// unlimited grid holds for the same beams (cut at the edge, a cut return is no hit).
        #[test]
        fn a_limited_grid_stays_inside_and_agrees_inside(
            beams in proptest::collection::vec(
                (-30.0f64..30.0, -30.0f64..30.0, -30.0f64..30.0, -30.0f64..30.0, proptest::bool::ANY),
                1..20,
            ),
        ) {
            let (lo, hi) = (DVec2::new(-5.0, -3.0), DVec2::new(4.0, 6.0));
            let mut limited = grid();
            limited.limit_to(lo, hi);
            let mut free = grid();
            let beams: Vec<Beam> = beams
                .iter()
                .map(|&(a, b, c, d, hit)| Beam { from: DVec2::new(a, b), to: DVec2::new(c, d), hit })
                .collect();
            limited.insert(&beams, true);
            free.insert(&beams, true);
            let (a, b) = (limited.cell_of(lo), limited.cell_of(hi));
            if limited.width() > 0 {
                let o = limited.origin_cell();
                proptest::prop_assert!(o.0 >= a.0 && o.1 >= a.1);
                proptest::prop_assert!(o.0 + limited.width() as i64 - 1 <= b.0);
                proptest::prop_assert!(o.1 + limited.height() as i64 - 1 <= b.1);
            }
            // Cells well inside (a cell from the edge: a ray cut there may end a cell early).
            for i in a.0 + 1..b.0 {
                for j in a.1 + 1..b.1 {
                    let (l, f) = (limited.log_odds((i, j)), free.log_odds((i, j)));
                    let hit_only = beams.iter().any(|b| b.hit && free.cell_of(b.to) == (i, j));
                    if !hit_only {
                        proptest::prop_assert_eq!(l, f, "cell {:?}", (i, j));
                    }
                }
            }
        }
    }

    /// The update as DESIGN §5 states it, cell by cell: every return's cell a hit, every
    /// other cell some ray crosses one miss, each at most once per scan.
    fn insert_reference(g: &mut Grid, beams: &[Beam], misses_clear_passable: bool) {
        let hits: std::collections::BTreeSet<CellIndex> = beams
            .iter()
            .filter(|b| b.hit)
            .map(|b| g.cell_of(b.to))
            .collect();
        let crossed: std::collections::BTreeSet<CellIndex> = beams
            .iter()
            .flat_map(|b| CellWalk::new(b.from, b.to, g.resolution()))
            .filter(|c| !hits.contains(c))
            .collect();
        g.mark_cells(hits, true, Layers::Both);
        let layers = if misses_clear_passable {
            Layers::Both
        } else {
            Layers::Sensed
        };
        g.mark_cells(crossed, false, layers);
    }

    /// A scan from a cell corner along the axes and diagonals passes through cell corners,
    /// where the marking gives way and the scan is walked: still the reference update.
    #[test]
    fn scans_through_cell_corners_give_the_reference_update() {
        for (from, hit) in [(DVec2::ZERO, true), (DVec2::new(0.2, -0.3), false)] {
            let beams: Vec<Beam> = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-2, -2), (3, -1)]
                .iter()
                .map(|&(x, y)| Beam {
                    from,
                    to: from + DVec2::new(f64::from(x), f64::from(y)) * 0.5,
                    hit,
                })
                .collect();
            let diagonal = &beams[1];
            let mut scratch = vec![0u8; 100 * 100];
            assert!(!mark_crossed(
                diagonal.from,
                diagonal.to,
                0.1,
                (-50, -50),
                100,
                &mut scratch
            ));
            let (mut fast, mut slow) = (grid(), grid());
            fast.insert(&beams, true);
            insert_reference(&mut slow, &beams, true);
            for i in -30..30 {
                for j in -30..30 {
                    assert_eq!(fast.log_odds((i, j)), slow.log_odds((i, j)), "cell {i} {j}");
                }
            }
        }
    }

    proptest::proptest! {
        /// Scans of many rays from one point (a fan, where a cell near the sensor is crossed
        /// many times) and of scattered rays give the reference update, scan after scan.
        #[test]
        fn insert_equals_the_cell_by_cell_update(
            origin in (-3.0f64..3.0, -3.0f64..3.0),
            fan in proptest::bool::ANY,
            rays in proptest::collection::vec(
                (0.0f64..std::f64::consts::TAU, 0.0f64..4.0, proptest::bool::ANY,
                 -4.0f64..4.0, -4.0f64..4.0),
                1..200,
            ),
            passable in proptest::bool::ANY,
        ) {
            let beams: Vec<Beam> = rays
                .iter()
                .map(|&(a, r, hit, x, y)| {
                    let from = if fan { DVec2::new(origin.0, origin.1) } else { DVec2::new(x, y) };
                    Beam { from, to: from + DVec2::from_angle(a) * r, hit }
                })
                .collect();
            let (mut fast, mut slow) = (grid(), grid());
            for scan in beams.chunks(37) {
                fast.insert(scan, passable);
                insert_reference(&mut slow, scan, passable);
            }
            let cells = beams.iter().flat_map(|b| CellWalk::new(b.from, b.to, 0.1));
            for c in cells {
                proptest::prop_assert_eq!(fast.log_odds(c), slow.log_odds(c), "cell {:?}", c);
            }
        }
    }

    /// Rays with an end not a number or infinite are dropped; the rest update as alone, with
    /// or without a limit.
    #[test]
    fn rays_with_non_finite_ends_are_dropped() {
        let good = [
            Beam {
                from: DVec2::new(0.12, 0.31),
                to: DVec2::new(1.7, 0.9),
                hit: true,
            },
            Beam {
                from: DVec2::new(0.12, 0.31),
                to: DVec2::new(-0.8, 1.4),
                hit: false,
            },
        ];
        let bad = [
            Beam {
                from: DVec2::new(0.12, 0.31),
                to: DVec2::new(f64::NAN, 1.0),
                hit: true,
            },
            Beam {
                from: DVec2::new(f64::INFINITY, 0.0),
                to: DVec2::new(1.0, 1.0),
                hit: false,
            },
        ];
        let all: Vec<Beam> = [bad[0], good[0], bad[1], good[1]].to_vec();
        for limit in [None, Some((DVec2::new(-5.0, -5.0), DVec2::new(5.0, 5.0)))] {
            let (mut with, mut without) = (grid(), grid());
            with.limit = limit;
            without.limit = limit;
            with.insert(&all, true);
            without.insert(&good, true);
            assert_eq!(
                (with.origin, with.width, with.height),
                (without.origin, without.width, without.height)
            );
            assert_eq!(with.sensed, without.sensed);
            assert_eq!(with.passable, without.passable);
            assert!(with.sensed.iter().any(|&l| l != 0.0));
        }
    }

    #[test]
    fn default_occupancy_is_valid_and_bad_ones_are_refused() {
        assert!(Occupancy::default().validate().is_ok());
        let bad = Occupancy {
            hit: 0.4,
            ..Occupancy::default()
        };
        assert!(bad.validate().is_err());
        let bad = Occupancy {
            free_thresh: 0.7,
            ..Occupancy::default()
        };
        assert!(bad.validate().is_err());
    }
}
