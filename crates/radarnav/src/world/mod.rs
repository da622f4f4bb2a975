//! The 3D world: objects (shape + material) and the ray query every sensor is built on.

mod fan;
pub mod forest;
mod grid;
pub mod material;
pub mod mesh;
pub mod overlap;
mod pages;
pub mod procedural;
pub mod shape;

pub use fan::Fan;
pub use material::{
    Band, DB_PER_UNIT_EXTINCTION, DEFAULT_SPECULAR_LOBE_DEG, METAL_DIFFUSE, Material, MaterialId,
    MaterialTable, builtin_materials,
};
pub use shape::{OrientedBox, Ray, Shape, ShapeError};

use shape::sphere_interval;

use std::cmp::Ordering;

use glam::{DVec2, DVec3};

use grid::{CellWalk, Grid};
use mesh::{BoxRay, Need, SingleStretch};

/// A solid in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Optional name from the scenario.
    pub name: Option<String>,
    /// Geometry.
    pub shape: Shape,
    /// What it is made of.
    pub material: MaterialId,
}

/// One stretch of a ray inside one object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Entry distance (negative when the ray starts inside).
    pub t_in: f64,
    /// Exit distance.
    pub t_out: f64,
    /// Index of the object in [`World::objects`].
    pub object: u32,
    /// The object's material.
    pub material: MaterialId,
    /// The wall segment this stretch is inside, when the wall was tested segment by segment
    /// (a wall solid to the ray's band); [`Interval::WHOLE`] for a whole object.
    pub segment: u16,
}

impl Interval {
    /// [`Interval::segment`] of an interval of a whole object.
    pub const WHOLE: u16 = u16::MAX;
}

/// `x.floor() as i64`, bit for bit (NaN gives 0, out-of-range values saturate), without the
/// call to libm's `floor` that a baseline x86-64 build makes: cell and sector indices are
/// taken once or twice per ray.
#[inline]
pub fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    i.saturating_sub(i64::from((i as f64) > x))
}

/// The order every interval list of a ray is in: by entry, then object index, then exit.
fn entry_order(a: &Interval, b: &Interval) -> Ordering {
    a.t_in
        .total_cmp(&b.t_in)
        .then(a.object.cmp(&b.object))
        .then(a.t_out.total_cmp(&b.t_out))
}

/// Files the interval of these fields in a pending list sorted last-first (the next interval
/// at the end). It takes the fields one by one (see [`World::test_part`]) and is never
/// inlined, so that its callers stay small enough to be inlined themselves.
#[inline(never)]
fn insert_pending(
    pending: &mut Vec<Interval>,
    t_in: f64,
    t_out: f64,
    object: u32,
    material: MaterialId,
    segment: u16,
) {
    let iv = Interval {
        t_in,
        t_out,
        object,
        material,
        segment,
    };
    let at = pending.partition_point(|p| entry_order(p, &iv) == Ordering::Greater);
    pending.insert(at, iv);
}

/// Whether this is the first time ray `stamp` meets grid part `part` in the cells it walks
/// (marking it met, in `reached`). In a world with meshes a part's bounds are tested before
/// anything else of it, and a mesh spans many cells: met again, its bounds need no second
/// test (a query's stretch only shrinks, so a mesh passed by stays passed by), and a part
/// tested once is never tested again on the same ray anyway ([`RayQuery::stamps`]).
#[inline(always)]
fn first_visit(reached: &mut [u32], part: u32, stamp: u32) -> bool {
    let last = &mut reached[part as usize];
    let first = *last != stamp;
    *last = stamp;
    first
}

/// Remakes `stretch` for the first-hit query's current bound: `t_max`, or just past the
/// `best` entry found so far.
#[inline(always)]
fn refresh_stretch(
    box_ray: &BoxRay,
    t_max: f64,
    best: Option<Interval>,
    stretch: &mut SingleStretch,
) {
    let t_max = best.map_or(t_max, |b| t_max.min(b.t_in.next_up()));
    if t_max != stretch.t_max() {
        *stretch = box_ray.single_stretch(t_max);
    }
}

/// Each cell's parts of `grid` as [`mesh::ReachGroup`]s of their reaches, in the cell's
/// order, and where each cell's groups begin (one entry more than there are cells).
fn reach_groups(grid: &Grid, reach: &[mesh::SingleReach]) -> (Vec<mesh::ReachGroup>, Vec<u32>) {
    let mut groups = Vec::new();
    let mut starts = Vec::with_capacity(grid.cell_count() + 1);
    for c in 0..grid.cell_count() {
        starts.push(groups.len() as u32);
        for four in grid.cell(c).chunks(4) {
            let parts: Vec<(u32, mesh::SingleReach)> =
                four.iter().map(|&p| (p, reach[p as usize])).collect();
            groups.push(mesh::ReachGroup::of(&parts));
        }
    }
    starts.push(groups.len() as u32);
    (groups, starts)
}

/// Reusable buffers for the ray queries of [`World`], so that casting many rays allocates
/// nothing once they have grown.
#[derive(Clone, Debug, Default)]
pub struct RayQuery {
    spans: Vec<(f64, f64)>,
    /// Results of [`World::ray_intervals`]; in [`OrderedIntervals`], the intervals found and
    /// not yet taken, sorted last-first so that the next one is popped off the end.
    intervals: Vec<Interval>,
    /// Per object, then per part, the number of the last ray that tested it: an object
    /// listed in several cells is tested once per ray ("mailboxing").
    stamps: Vec<u32>,
    stamp: u32,
    /// Per part, the number of the last ray that met it walking the grid ([`first_visit`]).
    reached: Vec<u32>,
    /// The current ray prepared for the mesh bounds tests (set only in a world with meshes).
    box_ray: BoxRay,
    /// Its stretch up to the query's `t_max` for [`BoxRay::may_meet_single`] (likewise).
    stretch: SingleStretch,
}

impl RayQuery {
    /// Starts a new ray over a world of `slots` objects and parts.
    fn next_ray(&mut self, slots: usize) {
        if self.stamps.len() < slots {
            self.stamps.resize(slots, 0);
            self.reached.resize(slots, 0);
        }
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.stamps.fill(0);
            self.reached.fill(0);
            self.stamp = 1;
        }
        self.intervals.clear();
    }
}

/// The intervals of one ray in entry order ([`World::ray_intervals`]'s order), revealed only
/// as far as the consumer needs them.
pub trait IntervalSource {
    /// The next interval, when it is known to be next: every interval not revealed yet comes
    /// after it. `None` when every remaining interval begins after `need` (there may be more
    /// beyond it), or none remains.
    fn peek(&mut self, need: f64) -> Option<Interval>;
    /// Drops the interval that [`IntervalSource::peek`] returned.
    fn pop(&mut self);
}

/// A sorted list of intervals as an [`IntervalSource`]: all known up front.
#[derive(Clone, Debug)]
pub struct SortedIntervals<'a> {
    list: &'a [Interval],
    next: usize,
}

impl<'a> SortedIntervals<'a> {
    /// The intervals of `list`, which is in entry order.
    pub fn new(list: &'a [Interval]) -> Self {
        Self { list, next: 0 }
    }
}

impl IntervalSource for SortedIntervals<'_> {
    fn peek(&mut self, _need: f64) -> Option<Interval> {
        self.list.get(self.next).copied()
    }
    fn pop(&mut self) {
        self.next += 1;
    }
}

/// Where a front-to-back query takes its next parts to test from.
#[derive(Debug)]
enum Candidates<'w> {
    /// The grid's cells along the ray.
    Grid(CellWalk),
    /// A fan's sector list, nearest first.
    Fan(&'w [(f64, u32)]),
}

/// The front-to-back ray query ([`World::ordered_intervals`], [`World::fan_intervals`]):
/// tests parts in the order the ray can meet them and only as far as asked, so that a sensor
/// that stops at its first solid, or where its budget runs out, does no work behind that
/// point.
#[derive(Debug)]
pub struct OrderedIntervals<'w, 'q> {
    world: &'w World,
    /// Borrowed, not copied: a ray is usually written field by field just before its walk
    /// starts, and a copy reads it back sixteen bytes at a time, which stalls the store
    /// buffer (about 5 % of a multi-echo radar scan).
    ray: &'q Ray,
    t_max: f64,
    candidates: Candidates<'w>,
    /// Every interval beginning before this ray parameter has been found.
    frontier: f64,
    /// Objects solid to this band bit are tested part by part.
    by_parts: u8,
    q: &'q mut RayQuery,
}

impl OrderedIntervals<'_, '_> {
    /// Tests the next parts (a grid cell's, or a fan's next one) and moves the frontier;
    /// `false` when none remain.
    fn advance(&mut self) -> bool {
        let world = self.world;
        match &mut self.candidates {
            Candidates::Grid(walk) => {
                let Some((cell, t_exit)) = walk.next_cell(&world.grid) else {
                    self.frontier = f64::INFINITY;
                    return false;
                };
                if world.has_meshes {
                    // A cell's parts four at once, as in `World::first_solid`.
                    let (a, b) = (world.group_starts[cell], world.group_starts[cell + 1]);
                    for group in &world.reach_groups[a as usize..b as usize] {
                        let mut met = self.q.box_ray.may_meet_group(group, &self.q.stretch);
                        world.prefetch_group(group, met);
                        while met != 0 {
                            let part = group.part(met.trailing_zeros() as usize);
                            met &= met - 1;
                            if first_visit(&mut self.q.reached, part, self.q.stamp) {
                                world.file_part(part, self.ray, self.t_max, self.by_parts, self.q);
                            }
                        }
                    }
                } else {
                    for &part in world.grid.cell(cell) {
                        world.test_part(part, self.ray, self.t_max, self.by_parts, self.q);
                    }
                }
                self.frontier = t_exit;
            }
            Candidates::Fan(list) => {
                let Some((&(_, part), rest)) = list.split_first() else {
                    self.frontier = f64::INFINITY;
                    return false;
                };
                *list = rest;
                world.test_part(part, self.ray, self.t_max, self.by_parts, self.q);
                // Parts the ray may start in have the lower bound 0, and their intervals begin
                // before it (t_in < 0): nothing is final until all of them are tested.
                self.frontier = match rest.first() {
                    None => f64::INFINITY,
                    Some(&(lower, _)) if lower > 0.0 => lower,
                    Some(_) => f64::NEG_INFINITY,
                };
            }
        }
        true
    }
}

impl IntervalSource for OrderedIntervals<'_, '_> {
    fn peek(&mut self, need: f64) -> Option<Interval> {
        loop {
            if let Some(iv) = self.q.intervals.last()
                && iv.t_in < self.frontier
            {
                return Some(*iv);
            }
            if self.frontier > need || !self.advance() {
                // All found intervals begin at or after the frontier (after `need`); with the
                // walk over, the frontier is infinite and none remains.
                return self
                    .q
                    .intervals
                    .last()
                    .copied()
                    .filter(|_| self.frontier.is_infinite());
            }
        }
    }

    fn pop(&mut self) {
        self.q.intervals.pop();
    }
}

/// What the grid lists: a segment of a wall, or a whole object; with what a ray query needs
/// of it close at hand (the objects themselves are large and far apart in memory).
#[derive(Clone, Copy, Debug)]
struct Part {
    object: u32,
    /// The wall segment, or [`WHOLE`].
    segment: u32,
    /// A sphere's centre and radius: tested here, without the object.
    sphere: Option<(DVec3, f64)>,
    material: MaterialId,
}

const WHOLE: u32 = u32::MAX;

fn band_bit(band: Band) -> u8 {
    match band {
        Band::Radar => 1,
        Band::Laser => 2,
        Band::Surface => 4,
    }
}

/// Object indices in Morton (z-curve) order of their footprints' centres: parts numbered in
/// this order lie near each other in memory when they lie near each other in the world, so a
/// ray's cells read few cache lines. An object's parts stay together.
fn spatial_order(aabbs: &[(DVec3, DVec3)]) -> Vec<usize> {
    let centres: Vec<DVec2> = aabbs
        .iter()
        .map(|(a, b)| ((*a + *b) * 0.5).truncate())
        .collect();
    let (lo, hi) = centres
        .iter()
        .filter(|c| c.is_finite())
        .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(*c), hi.max(*c))
        });
    let scale = DVec2::splat(65535.0) / (hi - lo).max(DVec2::splat(1e-9));
    let spread = |v: u32| {
        // The bits of a 16-bit number spread to the even bits of 32.
        let mut v = u64::from(v) & 0xffff;
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    };
    let key = |c: DVec2| {
        let q = ((c - lo) * scale).clamp(DVec2::ZERO, DVec2::splat(65535.0));
        spread(q.x as u32) | (spread(q.y as u32) << 1)
    };
    let mut order: Vec<usize> = (0..aabbs.len()).collect();
    order.sort_by_key(|&i| (key(centres[i]), i));
    order
}

/// Objects, their materials and the grid over them.
#[derive(Clone)]
pub struct World {
    materials: MaterialTable,
    objects: Vec<Object>,
    /// Per object, axis-aligned bounds `(min, max)`.
    aabbs: Vec<(DVec3, DVec3)>,
    /// Per object that is a mesh, its [`mesh::Reach`]: a ray is tested against it (here,
    /// side by side) before the mesh is looked at.
    mesh_reach: Vec<Option<mesh::Reach>>,
    /// Whether some object is a mesh: only then does a ray need its direction's reciprocal.
    has_meshes: bool,
    /// Per part, [`mesh::Reach::single`] of its object if a mesh, else
    /// [`mesh::SingleReach::UNBOUNDED`]: what a ray query tests a mesh part against before
    /// anything else of it (only in a world with meshes; [`World::reach_passes`]).
    part_reach: Vec<mesh::SingleReach>,
    /// In a world with meshes, per grid cell the [`mesh::ReachGroup`]s of the parts it lists
    /// (in its order, four to a group): cell `c`'s are
    /// `reach_groups[group_starts[c]..group_starts[c + 1]]`. Empty without meshes.
    reach_groups: Vec<mesh::ReachGroup>,
    group_starts: Vec<u32>,
    /// Per part, where a search of its mesh begins to read (default for other shapes): asked
    /// of the memory when a ray passes the part's reach.
    search_starts: Vec<mesh::SearchStart>,
    /// Per object, bit `band_bit(b)` set when its material is solid to band `b`.
    solid: Vec<u8>,
    parts: Vec<Part>,
    /// Per part, its xy bounds `(min, max)`.
    part_rects: Vec<(DVec2, DVec2)>,
    grid: Grid,
    ground: MaterialId,
    /// Whether some object is an aerosol to a laser (§7.6).
    laser_aerosols: bool,
    /// Bit `band_bit(b)` set when every object is solid or transparent to band `b`.
    binary: u8,
    /// Per material, the one-way dB a radar ray loses crossing its surface, 10·log10(1/(1−ρ)),
    /// and the same as a two-way power factor, (1−ρ)².
    transmission: Vec<(f64, f64)>,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("materials", &self.materials)
            .field("objects", &self.objects)
            .finish_non_exhaustive()
    }
}

impl World {
    /// A world of `objects` whose material ids refer to `materials`.
    pub fn new(materials: MaterialTable, objects: Vec<Object>) -> Self {
        let aabbs: Vec<(DVec3, DVec3)> = objects.iter().map(|o| o.shape.aabb()).collect();
        let mesh_reach: Vec<Option<mesh::Reach>> = (objects.iter().zip(&aabbs))
            .map(|(o, &b)| matches!(o.shape, Shape::Mesh(_)).then(|| mesh::Reach::of(b)))
            .collect();
        let solid = objects
            .iter()
            .map(|o| {
                let m = materials.get(o.material);
                [Band::Radar, Band::Laser, Band::Surface]
                    .into_iter()
                    .filter(|b| m.attenuation_db_per_m(*b).is_infinite())
                    .map(band_bit)
                    .sum()
            })
            .collect();
        // A wall is listed segment by segment, so that a ray that stops at it tests only the
        // segments in the cells it crosses.
        let mut parts = Vec::new();
        let mut rects = Vec::new();
        for i in spatial_order(&aabbs) {
            let o = &objects[i];
            let boxes = o.shape.part_aabbs();
            let whole = boxes.len() == 1 && !matches!(o.shape, Shape::Wall { .. });
            let sphere = match o.shape {
                Shape::Sphere { center, radius } => Some((center, radius)),
                _ => None,
            };
            for (k, (lo, hi)) in boxes.into_iter().enumerate() {
                rects.push((parts.len() as u32, lo.truncate(), hi.truncate()));
                parts.push(Part {
                    object: i as u32,
                    segment: if whole { WHOLE } else { k as u32 },
                    sphere,
                    material: o.material,
                });
            }
        }
        let grid = Grid::new(&rects);
        let part_reach: Vec<mesh::SingleReach> = parts
            .iter()
            .map(|p| {
                mesh_reach[p.object as usize]
                    .as_ref()
                    .map_or(mesh::SingleReach::UNBOUNDED, mesh::Reach::single)
            })
            .collect();
        let has_meshes = mesh_reach.iter().any(Option::is_some);
        let (reach_groups, group_starts) = if has_meshes {
            reach_groups(&grid, &part_reach)
        } else {
            (Vec::new(), Vec::new())
        };
        let search_starts: Vec<mesh::SearchStart> = (parts.iter())
            .map(|p| match &objects[p.object as usize].shape {
                Shape::Mesh(m) => mesh::SearchStart::of(m),
                _ => mesh::SearchStart::default(),
            })
            .collect();
        let part_rects = rects.iter().map(|&(_, lo, hi)| (lo, hi)).collect();
        let ground = materials.id("ground").expect("built-ins are never removed");
        let laser_aerosols = objects
            .iter()
            .any(|o| materials.get(o.material).laser_aerosol());
        let binary = [Band::Radar, Band::Laser, Band::Surface]
            .into_iter()
            .filter(|b| {
                objects.iter().all(|o| {
                    let a = materials.get(o.material).attenuation_db_per_m(*b);
                    a == 0.0 || a.is_infinite()
                })
            })
            .map(band_bit)
            .sum();
        let transmission = materials
            .iter()
            .map(|(_, m)| {
                let rho = m.radar_reflectivity;
                if rho > 0.0 && rho < 1.0 {
                    (-10.0 * (1.0 - rho).log10(), (1.0 - rho) * (1.0 - rho))
                } else {
                    (0.0, 1.0)
                }
            })
            .collect();
        // A ray through a large mesh world reads a few lines of many pages: ask for huge
        // pages under what it reads, so those reads stop waiting on page walks.
        if has_meshes {
            let meshes = objects.iter().filter_map(|o| match &o.shape {
                Shape::Mesh(m) => Some(m.search_spans()),
                _ => None,
            });
            pages::collapse(meshes.flatten().chain(grid.spans()).chain([
                pages::span(&parts),
                pages::span(&part_reach),
                pages::span(&reach_groups),
                pages::span(&search_starts),
                pages::span(&objects),
            ]));
        }
        Self {
            laser_aerosols,
            binary,
            transmission,
            materials,
            objects,
            aabbs,
            has_meshes,
            mesh_reach,
            part_reach,
            reach_groups,
            group_starts,
            search_starts,
            solid,
            parts,
            part_rects,
            grid,
            ground,
        }
    }

    /// The one-way loss, dB, of a radar ray entering material `id` through its surface:
    /// 10·log10(1/(1−ρ)) for a reflectivity ρ in (0, 1), else 0 (DESIGN §7.2); and the same
    /// loss as a two-way power factor, (1−ρ)² (else 1).
    pub fn radar_transmission(&self, id: MaterialId) -> (f64, f64) {
        self.transmission[usize::from(id.0)]
    }

    /// Whether some object is an aerosol a laser may return from (DESIGN §7.6).
    pub fn has_laser_aerosols(&self) -> bool {
        self.laser_aerosols
    }

    /// The material table.
    pub fn materials(&self) -> &MaterialTable {
        &self.materials
    }

    /// The material of the ground plane z = 0, which lies under every world.
    pub fn ground_material(&self) -> MaterialId {
        self.ground
    }

    /// The objects, in scenario order.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Axis-aligned bounds of all objects, or `None` for an empty world.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        (!self.objects.is_empty()).then(|| {
            self.aabbs.iter().fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), (a, b)| (lo.min(*a), hi.max(*b)),
            )
        })
    }

    /// Every interval where `ray` is inside an object and that overlaps `(0, t_max)`, in entry
    /// order (by `t_in`, then object index, then `t_out`).
    pub fn ray_intervals<'q>(&self, ray: &Ray, t_max: f64, q: &'q mut RayQuery) -> &'q [Interval] {
        let mut ordered = self.ordered_intervals(ray, t_max, None, q);
        while ordered.advance() {}
        q.intervals.reverse();
        &q.intervals
    }

    /// The same intervals as [`World::ray_intervals`], revealed front to back as far as the
    /// consumer asks ([`IntervalSource`]): the query behind every sensor ray.
    ///
    /// With `stop_band`, an object solid to that band may come part by part (a wall segment
    /// by segment, overlapping at its joints) rather than merged: a walk that ends at the
    /// first solid entry ends at the same place and material, and tests fewer segments.
    pub fn ordered_intervals<'w, 'q>(
        &'w self,
        ray: &'q Ray,
        t_max: f64,
        stop_band: Option<Band>,
        q: &'q mut RayQuery,
    ) -> OrderedIntervals<'w, 'q> {
        self.start_ray(ray, t_max, q);
        OrderedIntervals {
            world: self,
            ray,
            t_max,
            candidates: Candidates::Grid(CellWalk::new(&self.grid, ray, t_max)),
            frontier: f64::NEG_INFINITY,
            by_parts: stop_band.map_or(0, band_bit),
            q,
        }
    }

    /// [`World::ordered_intervals`] for a ray from `fan`'s origin ([`World::fan`] built for
    /// at least `t_max`) whose direction has bearing `heading`: the parts of its sector,
    /// nearest first, instead of a walk through the grid.
    pub fn fan_intervals<'w, 'q>(
        &'w self,
        fan: &'w Fan,
        ray: &'q Ray,
        heading: f64,
        t_max: f64,
        stop_band: Option<Band>,
        q: &'q mut RayQuery,
    ) -> OrderedIntervals<'w, 'q> {
        debug_assert_eq!(ray.origin, fan.origin());
        self.start_ray(ray, t_max, q);
        OrderedIntervals {
            world: self,
            ray,
            t_max,
            candidates: Candidates::Fan(fan.candidates(heading)),
            frontier: f64::NEG_INFINITY,
            by_parts: stop_band.map_or(0, band_bit),
            q,
        }
    }

    /// Readies `q` for a new ray.
    fn start_ray(&self, ray: &Ray, t_max: f64, q: &mut RayQuery) {
        q.next_ray(self.objects.len() + self.parts.len());
        if self.has_meshes {
            q.box_ray = BoxRay::of(ray);
            q.stretch = q.box_ray.single_stretch(t_max);
        }
    }

    /// Same result as [`World::ray_intervals`], testing every object: the reference the
    /// accelerated query is checked against.
    pub fn ray_intervals_exhaustive<'q>(
        &self,
        ray: &Ray,
        t_max: f64,
        q: &'q mut RayQuery,
    ) -> &'q [Interval] {
        q.intervals.clear();
        let box_ray = BoxRay::of(ray);
        for i in 0..self.objects.len() {
            let (spans, out) = (&mut q.spans, &mut q.intervals);
            self.object_intervals(i as u32, ray, &box_ray, t_max, None, spans, |iv| {
                out.push(iv)
            });
        }
        q.intervals.sort_by(entry_order);
        &q.intervals
    }

    /// Tests grid part `part` against `ray` (once per ray: `q`'s stamps) and files its
    /// intervals in `q`'s pending list: the part alone when its object is solid to a band of
    /// `by_parts`, else the whole object.
    // Inlined into both callers: the call's own frame cost about a tenth of a forest ray.
    #[inline(always)]
    fn test_part(&self, part: u32, ray: &Ray, t_max: f64, by_parts: u8, q: &mut RayQuery) {
        if self.reach_passes(part, &q.box_ray, &q.stretch) {
            self.file_part(part, ray, t_max, by_parts, q);
        }
    }

    /// [`World::test_part`] for a part known to pass [`World::reach_passes`].
    #[inline(always)]
    fn file_part(&self, part: u32, ray: &Ray, t_max: f64, by_parts: u8, q: &mut RayQuery) {
        let pending = &mut q.intervals;
        // The interval goes on field by field, in registers: handed over whole, it went
        // through memory, its fields written one by one and read back sixteen bytes at a time,
        // which stalls the store buffer at every interval found.
        let take = |iv: Interval| {
            insert_pending(
                pending,
                iv.t_in,
                iv.t_out,
                iv.object,
                iv.material,
                iv.segment,
            );
        };
        self.test_part_with(
            part,
            ray,
            &q.box_ray,
            t_max,
            Need::Overlapping,
            by_parts,
            &mut q.stamps,
            q.stamp,
            &mut q.spans,
            take,
        );
    }

    /// [`World::test_part`] handing each interval to `take` instead of filing it.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn test_part_with(
        &self,
        part: u32,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: f64,
        need: Need,
        by_parts: u8,
        stamps: &mut [u32],
        stamp: u32,
        spans: &mut Vec<(f64, f64)>,
        mut take: impl FnMut(Interval),
    ) {
        let Part {
            object,
            segment,
            sphere,
            material,
        } = self.parts[part as usize];
        if let Some((center, radius)) = sphere {
            // The commonest object of forests, in one piece: its slot is the object's.
            if stamps[object as usize] != stamp {
                stamps[object as usize] = stamp;
                if let Some((t_in, t_out)) = sphere_interval(center, radius, ray)
                    && t_out > 0.0
                    && t_in < t_max
                {
                    take(Interval {
                        t_in,
                        t_out,
                        object,
                        material,
                        segment: Interval::WHOLE,
                    });
                }
            }
            return;
        }
        let by_part = segment != WHOLE && self.solid[object as usize] & by_parts != 0;
        let slot = if by_part {
            self.objects.len() + part as usize
        } else {
            object as usize
        };
        if stamps[slot] == stamp {
            return;
        }
        stamps[slot] = stamp;
        if by_part {
            let obj = &self.objects[object as usize];
            let Shape::Wall { segments, .. } = &obj.shape else {
                unreachable!("only walls are split into parts")
            };
            match segments[segment as usize].interval(ray) {
                // The ray starts in this segment: the merged interval may begin further back
                // (in a segment behind the origin), and among objects the ray starts in, the
                // one entered first is reported. Only the whole wall gives that entry.
                Some((t_in, t_out))
                    if t_in <= 0.0 && t_out > 0.0 && stamps[object as usize] != stamp =>
                {
                    stamps[object as usize] = stamp;
                    self.object_intervals(object, ray, box_ray, t_max, Some(need), spans, take);
                }
                // Its merged intervals are filed already.
                Some((t_in, t_out)) if t_in <= 0.0 && t_out > 0.0 => {}
                Some((t_in, t_out)) if t_out > 0.0 && t_in < t_max => take(Interval {
                    t_in,
                    t_out,
                    object,
                    material: obj.material,
                    // A wall of more segments than that (beyond the point limit of scenario
                    // files) finds its normal by the nearest face instead.
                    segment: u16::try_from(segment).unwrap_or(Interval::WHOLE),
                }),
                _ => {}
            }
        } else {
            self.object_intervals(object, ray, box_ray, t_max, Some(need), spans, take);
        }
    }

    /// Whether every object is either solid or fully transparent to `band` (attenuation
    /// infinite or zero): then a ray without aerosol draws ends at its first solid entry, and
    /// [`World::first_solid`] finds it without the penetration walk.
    pub fn is_binary(&self, band: Band) -> bool {
        self.binary & band_bit(band) != 0
    }

    /// The entry distance and material of the first interval, in entry order, of an object
    /// solid to `band` that `ray` meets before `t_max`: the interval a walk of
    /// [`World::ordered_intervals`] stops at when every other object is transparent to `band`
    /// ([`World::is_binary`]). Through `fan` (its origin the ray's, with the ray's bearing)
    /// when given, else along the grid. Objects transparent to `band` are not tested at all.
    ///
    /// Only those two fields are returned: the whole interval, its fields stored one by one
    /// while the search ran, was copied out sixteen bytes at a time, which stalls the store
    /// buffer once per ray (a twentieth of a whole run).
    pub fn first_solid(
        &self,
        fan: Option<(&Fan, f64)>,
        ray: &Ray,
        t_max: f64,
        band: Band,
        q: &mut RayQuery,
    ) -> Option<(f64, MaterialId)> {
        self.start_ray(ray, t_max, q);
        let bit = band_bit(band);
        let mut best: Option<Interval> = None;
        let (stamps, stamp, spans, box_ray) = (&mut q.stamps, q.stamp, &mut q.spans, &q.box_ray);
        let reached = &mut q.reached;
        let mut stretch = q.stretch;
        // Tests a part (objects not solid to the band are skipped) and keeps in `best`
        // whichever interval comes first in entry order.
        let mut test = |part: u32, best: &mut Option<Interval>| {
            if self.solid[self.parts[part as usize].object as usize] & bit == 0 {
                return;
            }
            // Past the best entry so far nothing can come first: a mesh stops looking there.
            let t_max = best.map_or(t_max, |b| t_max.min(b.t_in.next_up()));
            let keep = |iv: Interval| {
                if best.is_none_or(|b| entry_order(&iv, &b) == Ordering::Less) {
                    *best = Some(iv);
                }
            };
            self.test_part_with(
                part,
                ray,
                box_ray,
                t_max,
                Need::FirstEntry,
                bit,
                stamps,
                stamp,
                spans,
                keep,
            );
        };
        match fan {
            Some((fan, heading)) => {
                debug_assert_eq!(ray.origin, fan.origin());
                for &(lower, part) in fan.candidates(heading) {
                    // The rest begin at or after `lower`: past the best entry they cannot come
                    // first. A lower bound of 0 may hide an interval that began behind the
                    // origin (as in `OrderedIntervals`), so it is always tested.
                    if let Some(b) = best
                        && lower > 0.0
                        && lower > b.t_in
                    {
                        break;
                    }
                    if self.part_may_meet(part, box_ray, t_max, best, &mut stretch) {
                        test(part, &mut best);
                    }
                }
            }
            None => {
                let mut walk = CellWalk::new(&self.grid, ray, t_max);
                while let Some((cell, t_exit)) = walk.next_cell(&self.grid) {
                    if self.has_meshes {
                        // A cell's parts four at once: the stretch shrinks as `best` moves, so
                        // a group's answer (taken on the stretch at its start) may pass more
                        // than the part-by-part test would, never fewer.
                        let (a, b) = (self.group_starts[cell], self.group_starts[cell + 1]);
                        for group in &self.reach_groups[a as usize..b as usize] {
                            refresh_stretch(box_ray, t_max, best, &mut stretch);
                            let mut met = box_ray.may_meet_group(group, &stretch);
                            self.prefetch_group(group, met);
                            while met != 0 {
                                let part = group.part(met.trailing_zeros() as usize);
                                met &= met - 1;
                                if first_visit(reached, part, stamp) {
                                    test(part, &mut best);
                                }
                            }
                        }
                    } else {
                        for &part in self.grid.cell(cell) {
                            test(part, &mut best);
                        }
                    }
                    // Every interval beginning before the cell's exit has been found.
                    if best.is_some_and(|b| b.t_in < t_exit) {
                        break;
                    }
                }
            }
        }
        best.map(|b| (b.t_in, b.material))
    }

    /// Asks the memory for what the searches of the parts of `group` in `met` (bit `j` for its
    /// part `j`) read first, before the first of them begins.
    #[inline(always)]
    fn prefetch_group(&self, group: &mesh::ReachGroup, mut met: u32) {
        while met != 0 {
            let part = group.part(met.trailing_zeros() as usize);
            met &= met - 1;
            self.search_starts[part as usize].prefetch();
            // The object, whose shape leads to the mesh.
            let object = self.parts[part as usize].object as usize;
            mesh::prefetch_line(self.objects.as_ptr().wrapping_add(object));
        }
    }

    /// Whether part `part` may hold what [`World::first_solid`] looks for, given the `best`
    /// interval found so far: [`World::reach_passes`] on the ray's stretch up to `t_max`, or
    /// to just past the best entry. `stretch` is that stretch, remade here when `best` has
    /// moved its end.
    #[inline(always)]
    fn part_may_meet(
        &self,
        part: u32,
        box_ray: &BoxRay,
        t_max: f64,
        best: Option<Interval>,
        stretch: &mut SingleStretch,
    ) -> bool {
        if !self.has_meshes {
            return true;
        }
        refresh_stretch(box_ray, t_max, best, stretch);
        self.reach_passes(part, box_ray, stretch)
    }

    /// Whether the ray of `box_ray` may have an interval of part `part` within `stretch`:
    /// false only for a mesh part it passes by ([`BoxRay::may_meet_single`]), tested before
    /// anything else of the part is fetched.
    #[inline(always)]
    fn reach_passes(&self, part: u32, box_ray: &BoxRay, stretch: &SingleStretch) -> bool {
        !self.has_meshes || box_ray.may_meet_single(&self.part_reach[part as usize], stretch)
    }

    /// Hands each interval of object `index` on `ray` that overlaps `(0, t_max)` to `take`:
    /// for a mesh, what `need` asks of them (`None`: every one, from its whole line's
    /// crossings, as the exhaustive reference does).
    #[allow(clippy::too_many_arguments)]
    fn object_intervals(
        &self,
        index: u32,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: f64,
        need: Option<Need>,
        spans: &mut Vec<(f64, f64)>,
        mut take: impl FnMut(Interval),
    ) {
        // The cells along a ray list many meshes it passes by: their bounds first. The
        // accelerated queries (`need` given) have tested them already, in single precision
        // ([`World::reach_passes`], [`BoxRay::may_meet_group`]); the double-precision test
        // turns away few more and cost a tenth of a laser ray's mesh search.
        if need.is_none()
            && let Some(reach) = &self.mesh_reach[index as usize]
            && !reach.may_meet(box_ray, t_max)
        {
            return;
        }
        let obj = &self.objects[index as usize];
        spans.clear();
        match (&obj.shape, need) {
            (Shape::Mesh(m), Some(need)) => m.intervals_until(ray, box_ray, t_max, need, spans),
            (shape, _) => shape.ray_intervals(ray, spans),
        }
        for &(t_in, t_out) in spans.iter() {
            if t_out > 0.0 && t_in < t_max {
                take(Interval {
                    t_in,
                    t_out,
                    object: index,
                    material: obj.material,
                    segment: Interval::WHOLE,
                });
            }
        }
    }

    /// The outward unit normal where the ray of `iv` enters it at `p`: the entered segment's
    /// face for a wall tested segment by segment, else [`Shape::normal_at`] of the object.
    #[inline]
    pub fn normal_at(&self, iv: &Interval, p: DVec3) -> DVec3 {
        let shape = &self.objects[iv.object as usize].shape;
        match shape {
            Shape::Wall { segments, .. } if iv.segment != Interval::WHOLE => {
                segments[iv.segment as usize].face_at(p).1
            }
            _ => shape.normal_at(p),
        }
    }

    /// The first object (lowest index) that a robot cannot drive through and that overlaps
    /// `body`; traversable materials (smoke, dust, the ground) never block.
    pub fn blocking_object(&self, body: &OrientedBox) -> Option<usize> {
        self.overlapping_object(body, |m| !m.traversable)
    }

    /// The first object (lowest index) whose material satisfies `select` and that overlaps
    /// `body`.
    pub fn overlapping_object(
        &self,
        body: &OrientedBox,
        select: impl Fn(&Material) -> bool,
    ) -> Option<usize> {
        let (lo, hi) = body.aabb();
        let pad = self.grid.pad();
        self.grid
            .in_rect(lo.truncate(), hi.truncate())
            .map(|p| self.parts[p as usize].object as usize)
            .filter(|&i| {
                let (a, b) = self.aabbs[i];
                let o = &self.objects[i];
                a.cmple(hi + pad).all()
                    && (lo - pad).cmple(b).all()
                    && select(self.materials.get(o.material))
                    && o.shape.overlaps_box(body)
            })
            .min()
    }

    /// Indices of the objects containing point `p`, each once, in no particular order.
    pub fn objects_at(&self, p: DVec3) -> impl Iterator<Item = usize> + '_ {
        let mut last = None;
        self.grid
            .at_point(p)
            .iter()
            .map(|&part| self.parts[part as usize].object as usize)
            // An object's parts have adjacent numbers and a cell lists parts in order, so its
            // parts in this cell come one after the other.
            .filter(move |&i| last.replace(i) != Some(i))
            .filter(move |&i| self.objects[i].shape.contains(p))
    }
}

/// Random worlds and rays for the property tests of the ray queries.
#[cfg(test)]
pub(crate) mod strategies {
    use super::*;
    use glam::DVec2;
    use proptest::prelude::*;

    /// A world of built-in materials from (shape, material name) pairs.
    pub(crate) fn world_of(objects: &[(Shape, &str)]) -> World {
        let materials = MaterialTable::default();
        let objects = objects
            .iter()
            .map(|(shape, m)| Object {
                name: None,
                shape: shape.clone(),
                material: materials.id(m).expect("a built-in material"),
            })
            .collect();
        World::new(materials, objects)
    }

    /// Any of the five shapes, in an area of 16 × 16 m.
    pub(crate) fn arb_shape() -> impl Strategy<Value = Shape> {
        let c = (-8.0..8.0f64, -8.0..8.0f64, 0.0..3.0f64);
        let p2 = (-8.0..8.0f64, -8.0..8.0f64);
        prop_oneof![
            (c.clone(), 0.1..3.0f64).prop_map(|((x, y, z), r)| Shape::sphere(
                DVec3::new(x, y, z),
                r
            )
            .unwrap()),
            (
                c.clone(),
                (0.1..4.0f64, 0.1..4.0f64, 0.1..4.0f64),
                -3.2..3.2f64
            )
                .prop_map(|((x, y, z), (a, b, h), yaw)| Shape::cuboid(
                    DVec3::new(x, y, z),
                    DVec3::new(a, b, h),
                    yaw
                )
                .unwrap()),
            (c, 0.1..2.0f64, 0.2..4.0f64).prop_map(|((x, y, z), r, h)| Shape::cylinder(
                DVec3::new(x, y, z),
                r,
                h
            )
            .unwrap()),
            (
                prop::collection::vec(p2.clone(), 2..5),
                0.05..0.5f64,
                0.5..3.0f64
            )
                .prop_filter_map("distinct points", |(pts, t, h)| Shape::wall(
                    pts.into_iter().map(|(x, y)| DVec2::new(x, y)).collect(),
                    t,
                    h
                )
                .ok()),
            // Star-shaped polygons are simple by construction, and often concave.
            (
                (-6.0..6.0f64, -6.0..6.0f64),
                prop::collection::vec(0.3..3.0f64, 3..9),
                0.0..1.0f64,
                0.2..3.0f64
            )
                .prop_filter_map("valid prism", |((cx, cy), radii, z0, h)| {
                    let n = radii.len();
                    let poly = radii
                        .iter()
                        .enumerate()
                        .map(|(i, r)| {
                            let a = i as f64 / n as f64 * std::f64::consts::TAU;
                            DVec2::new(cx + r * a.cos(), cy + r * a.sin())
                        })
                        .collect();
                    Shape::prism(poly, z0, z0 + h).ok()
                }),
        ]
    }

    /// A ray from anywhere in 20 × 20 m (often inside a shape), any direction within ±17° of
    /// level.
    pub(crate) fn arb_ray() -> impl Strategy<Value = Ray> {
        (
            (-10.0..10.0f64, -10.0..10.0f64, 0.0..3.0f64),
            (-1.0..1.0f64, -1.0..1.0f64, -0.3..0.3f64),
        )
            .prop_filter_map("non-zero direction", |((x, y, z), (dx, dy, dz))| {
                let d = DVec3::new(dx, dy, dz);
                (d.length() > 1e-3).then(|| Ray::new(DVec3::new(x, y, z), d))
            })
    }

    /// Rays that stress the grid walk: from points on the grid of whole metres, along the
    /// axes or the diagonals, or anywhere ([`arb_ray`]).
    pub(crate) fn arb_hard_ray() -> impl Strategy<Value = Ray> {
        prop_oneof![
            arb_ray(),
            ((-10i32..10, -10i32..10, 0i32..3), 0usize..8).prop_map(|((x, y, z), k)| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                let (s, c) = a.sin_cos();
                // Exact axis directions: no 1e-17 components from sin/cos.
                let (c, s) = if k % 2 == 0 {
                    (c.round(), s.round())
                } else {
                    (c, s)
                };
                Ray::new(
                    DVec3::new(f64::from(x), f64::from(y), f64::from(z) * 0.5),
                    DVec3::new(c, s, 0.0),
                )
            }),
        ]
    }

    /// Small spheres and boxes, many to a cell of the grid.
    fn arb_small_shape() -> impl Strategy<Value = Shape> {
        let c = (-8.0..8.0f64, -8.0..8.0f64, 0.0..1.0f64);
        prop_oneof![
            (c.clone(), 0.05..0.4f64).prop_map(|((x, y, z), r)| Shape::sphere(
                DVec3::new(x, y, z),
                r
            )
            .unwrap()),
            (c, 0.05..0.6f64, -3.2..3.2f64).prop_map(|((x, y, z), a, yaw)| {
                Shape::cuboid(DVec3::new(x, y, z), DVec3::new(a, a * 0.7, 1.0), yaw).unwrap()
            }),
        ]
    }

    /// A world of 1-40 shapes of any size, or 50-400 small ones, each of any built-in
    /// material.
    pub(crate) fn arb_world() -> impl Strategy<Value = World> {
        let materials = MaterialTable::default().names().len();
        let objects = prop_oneof![
            prop::collection::vec((arb_shape(), 0..materials), 1..40),
            prop::collection::vec((arb_small_shape(), 0..materials), 50..400),
        ];
        objects.prop_map(|objects| {
            let table = MaterialTable::default();
            let objects = objects
                .into_iter()
                .map(|(shape, m)| Object {
                    name: None,
                    shape,
                    material: MaterialId(m as u16),
                })
                .collect();
            World::new(table, objects)
        })
    }

    /// [`arb_world`] of materials that are solid or transparent to every band only, so that
    /// every band takes [`World::first_solid`]'s way.
    pub(crate) fn arb_binary_world() -> impl Strategy<Value = World> {
        let table = MaterialTable::default();
        let binary: Vec<u16> = table
            .iter()
            .filter(|(_, m)| {
                [Band::Radar, Band::Laser, Band::Surface].iter().all(|b| {
                    let a = m.attenuation_db_per_m(*b);
                    a == 0.0 || a.is_infinite()
                })
            })
            .map(|(id, _)| id.0)
            .collect();
        assert!(
            binary.len() >= 2,
            "built-ins solid or transparent to all bands"
        );
        let objects = prop_oneof![
            prop::collection::vec((arb_shape(), 0..binary.len()), 1..40),
            prop::collection::vec((arb_small_shape(), 0..binary.len()), 50..400),
        ];
        objects.prop_map(move |objects| {
            let objects = objects
                .into_iter()
                .map(|(shape, m)| Object {
                    name: None,
                    shape,
                    material: MaterialId(binary[m]),
                })
                .collect();
            World::new(MaterialTable::default(), objects)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::strategies::{arb_hard_ray, arb_ray, arb_shape};
    use super::*;
    use parry3d_f64::query::Ray as ParryRay;
    use proptest::prelude::*;

    fn world_of(shapes: Vec<Shape>) -> World {
        let objects = shapes
            .into_iter()
            .map(|shape| Object {
                name: None,
                shape,
                material: MaterialId(0),
            })
            .collect();
        World::new(MaterialTable::default(), objects)
    }

    proptest! {
        #[test]
        fn grid_query_equals_exhaustive(shapes in prop::collection::vec(arb_shape(), 1..40),
                                        rays in prop::collection::vec(arb_hard_ray(), 1..20),
                                        t_max in 1.0..30.0f64) {
            let world = world_of(shapes);
            let (mut a, mut b) = (RayQuery::default(), RayQuery::default());
            for ray in rays {
                let fast = world.ray_intervals(&ray, t_max, &mut a);
                let slow = world.ray_intervals_exhaustive(&ray, t_max, &mut b);
                prop_assert_eq!(fast, slow);
            }
        }

        /// A wall solid to the radar is met segment by segment, and the normal where a ray
        /// enters it is the entered segment's face: the point lies on that face, and wherever
        /// one face of the whole wall is clearly the nearest, it is the nearest-face normal.
        #[test]
        fn wall_entry_normal_is_the_entered_segments_face(
            walls in prop::collection::vec(arb_shape(), 1..12),
            rays in prop::collection::vec(arb_hard_ray(), 1..30),
        ) {
            let walls: Vec<_> = walls
                .into_iter()
                .filter(|s| matches!(s, Shape::Wall { .. }))
                .map(|s| (s, "concrete"))
                .collect();
            let world = strategies::world_of(&walls);
            let mut q = RayQuery::default();
            for ray in rays {
                let mut source = world.ordered_intervals(&ray, 30.0, Some(Band::Radar), &mut q);
                let Some(iv) = source.peek(f64::INFINITY).filter(|iv| iv.t_in > 0.0) else {
                    continue;
                };
                let Shape::Wall { segments, .. } = &world.objects()[iv.object as usize].shape
                else {
                    unreachable!("only walls here")
                };
                prop_assert!(iv.segment != Interval::WHOLE, "{:?}", iv);
                let p = ray.at(iv.t_in);
                let n = world.normal_at(&iv, p);
                let (d, face) = segments[iv.segment as usize].face_at(p);
                prop_assert!(d.abs() < 1e-9, "{p} is {d} m off the entered face");
                prop_assert_eq!(n, face);
                let mut dist: Vec<f64> = segments.iter().map(|s| s.face_at(p).0.abs()).collect();
                dist.sort_by(f64::total_cmp);
                if dist.len() == 1 || dist[1] > 1e-6 {
                    prop_assert_eq!(n, world.objects()[iv.object as usize].shape.normal_at(p));
                }
            }
        }

        /// Every sample point along the ray is inside the shape exactly when it lies in one of
        /// the reported intervals (points within 1e-7 of an interval end are not judged).
        #[test]
        fn intervals_match_point_membership(shape in arb_shape(), ray in arb_ray()) {
            let mut iv = Vec::new();
            shape.ray_intervals(&ray, &mut iv);
            for w in iv.windows(2) {
                prop_assert!(w[0].1 < w[1].0, "not disjoint and sorted: {:?}", iv);
            }
            for k in 0..400 {
                let t = -20.0 + k as f64 * 0.1 + 0.0123;
                if iv.iter().any(|&(a, b)| (t - a).abs() < 1e-7 || (t - b).abs() < 1e-7) {
                    continue;
                }
                let in_iv = iv.iter().any(|&(a, b)| t > a && t < b);
                prop_assert_eq!(in_iv, shape.contains(ray.at(t)), "t = {}, intervals {:?}", t, iv);
            }
        }
    }

    proptest! {
        /// An independent implementation agrees on where a ray first enters a convex shape:
        /// parry3d's own ray casts on Ball, Cuboid and Cylinder (parry's cylinder axis is y,
        /// turned to z here).
        #[test]
        fn first_entry_matches_parry(shape in arb_shape(), ray in arb_ray()) {
            use parry3d_f64::math::Pose as PPose;
            use parry3d_f64::query::RayCast;
            use parry3d_f64::shape::{Ball, Cuboid, Cylinder};
            let pray = ParryRay::new(ray.origin, ray.dir);
            let theirs = match &shape {
                Shape::Sphere { center, radius } => {
                    Ball::new(*radius).cast_ray(&PPose::new(*center, DVec3::ZERO), &pray, 100.0, true)
                }
                Shape::Box(b) => Cuboid::new(b.half).cast_ray(
                    &PPose::new(b.center, DVec3::new(0.0, 0.0, b.yaw)), &pray, 100.0, true),
                Shape::Cylinder { center, radius, half_height } => Cylinder::new(*half_height, *radius)
                    .cast_ray(&PPose::new(*center, DVec3::new(std::f64::consts::FRAC_PI_2, 0.0, 0.0)),
                              &pray, 100.0, true),
                _ => return Ok(()),
            };
            let mut iv = Vec::new();
            shape.ray_intervals(&ray, &mut iv);
            let ours = iv.iter().find(|(_, b)| *b > 0.0).map(|(a, _)| a.max(0.0)).filter(|t| *t <= 100.0);
            match (ours, theirs) {
                (Some(a), Some(b)) => prop_assert!((a - b).abs() < 1e-6, "ours {} parry {}", a, b),
                (None, None) => {}
                // Only a grazing touch may be seen by one side alone.
                (Some(a), None) => {
                    let chord: f64 = iv.iter().map(|(x, y)| y - x).sum();
                    prop_assert!(chord < 1e-6, "ours {} parry none, intervals {:?}", a, iv);
                }
                (None, Some(b)) => {
                    prop_assert!(!shape.contains(ray.at(b + 1e-4)), "parry {} ours none", b);
                }
            }
        }
    }

    proptest! {
        /// The grid's box and point queries find what testing every object finds.
        #[test]
        fn box_and_point_queries_equal_exhaustive(
            w in strategies::arb_world(),
            boxes in prop::collection::vec(((-10.0..10.0f64, -10.0..10.0f64), (0.01..3.0f64, 0.01..3.0f64), -3.2..3.2f64), 1..30),
        ) {
            for ((x, y), (a, b), yaw) in boxes {
                let body = OrientedBox::new(DVec3::new(x, y, 0.3), DVec3::new(a, b, 0.6), yaw);
                let brute = (0..w.objects().len()).find(|&i| {
                    let o = &w.objects()[i];
                    !w.materials().get(o.material).traversable && o.shape.overlaps_box(&body)
                });
                prop_assert_eq!(w.blocking_object(&body), brute);
                let p = DVec3::new(x, y, 0.3);
                let inside: Vec<usize> = (0..w.objects().len()).filter(|&i| w.objects()[i].shape.contains(p)).collect();
                let mut found: Vec<usize> = w.objects_at(p).collect();
                found.sort_unstable();
                prop_assert_eq!(found, inside);
            }
        }
    }

    #[test]
    fn floor_i64_is_floor_as_i64() {
        let edge = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1e-300,
            -1e-300,
            4503599627370495.5,
            -4503599627370495.5,
            9.3e18,
            -9.3e18,
            // Just inside i64 (2^63 − 1024), its lower end, and just below it.
            (i64::MAX - 1023) as f64,
            i64::MIN as f64,
            i64::MIN as f64 - 2048.0,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut x = 0x1234_5678_9abc_def0_u64;
        let random = (0..100_000).map(|_| {
            // xorshift: any bit pattern, NaNs and infinities included.
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            f64::from_bits(x)
        });
        for v in edge.into_iter().chain(random) {
            assert_eq!(floor_i64(v), v.floor() as i64, "{v:e}");
        }
        for k in -2000..2000 {
            let v = f64::from(k) * 0.05;
            assert_eq!(floor_i64(v), v.floor() as i64, "{v}");
            assert_eq!(floor_i64(v / 0.05), (v / 0.05).floor() as i64, "{v}");
        }
    }

    #[test]
    fn objects_at_finds_containing_objects() {
        let w = world_of(vec![
            Shape::sphere(DVec3::new(0.0, 0.0, 1.0), 1.0).unwrap(),
            Shape::cuboid(DVec3::new(0.5, 0.0, 1.0), DVec3::ONE, 0.0).unwrap(),
        ]);
        let mut hits: Vec<_> = w.objects_at(DVec3::new(0.6, 0.0, 1.0)).collect();
        hits.sort();
        assert_eq!(hits, vec![0, 1]);
        assert_eq!(w.objects_at(DVec3::new(5.0, 0.0, 1.0)).count(), 0);
    }
}
