//! Triangle meshes (DESIGN §2 `mesh`): detailed trees, bushes and buildings.
//!
//! A closed (watertight, consistently wound) mesh is a volume: a ray's line is inside it
//! between an entry and an exit crossing, so a foliage crown is entered and left like a
//! sphere and spends a penetration budget over its chord. An open mesh is a surface: every
//! crossing is a thin solid sheet ([`SURFACE_THICKNESS`]); a scenario refuses an open mesh of
//! a penetrable material.
//!
//! Crossings use the watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013): each
//! triangle's vertices are sheared into a frame where the ray runs along one axis, and the
//! three edge functions decide. The edge function of an edge shared by two triangles is
//! computed from the same sheared vertices, so its two values are exact negatives; a ray
//! through the edge itself (value 0) is given to exactly one of the two by a top-left rule.
//! A ray through a closed mesh therefore crosses it an even number of times, whatever edges
//! or vertices it meets. The triangles sit in a bounding-volume hierarchy of their own, four
//! children to a node. A sensor's query searches it front to back along the ray's line and
//! stops once the crossings found settle what the query needs ([`TriMesh::intervals_until`]):
//! the answer is the one the whole line's crossings give, found without most of them.

use std::collections::HashMap;
use std::mem::MaybeUninit;
use std::ptr::without_provenance;

use glam::{DVec2, DVec3};
use thiserror::Error;

use super::shape::{OrientedBox, Ray};

/// Thickness given to an open mesh's surface at each crossing, m.
pub const SURFACE_THICKNESS: f64 = 1e-6;

/// How many sheets' thickness behind the origin a search of an open mesh still looks: its
/// crossings further back cannot join a sheet that reaches past the origin unless one lies
/// in between ([`TriMesh::intervals_until`]).
const BEHIND_SHEETS: f64 = 4.0;

/// Most triangles in one mesh (DESIGN §12).
pub const MAX_TRIANGLES: usize = crate::limits::MESH_TRIANGLES.max as usize;

/// Triangles per leaf of the hierarchy.
const LEAF_SIZE: usize = 4;

/// Why a mesh cannot be built.
#[derive(Debug, Error, PartialEq)]
pub enum MeshError {
    /// No triangle left (after dropping those with a repeated vertex).
    #[error("the mesh has no triangle")]
    Empty,
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} names vertex {index}, but there are {vertices} vertices")]
    BadIndex {
        /// The triangle.
        triangle: usize,
        /// The index it names.
        index: u32,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("vertex {0} has a coordinate that is not a finite number")]
    NotFinite(usize),
    /// More triangles than [`MAX_TRIANGLES`].
    #[error("{0} triangles; at most {MAX_TRIANGLES} are allowed")]
    TooLarge(usize),
}

/// Triangles that share one material name (`None`: none given), before they become a
/// [`TriMesh`]: one part of a mesh file or of a generated plant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshPart {
    /// The material name the file gives these faces.
    pub material: Option<String>,
    /// Vertices.
    pub vertices: Vec<DVec3>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// How much of a ray's intervals a caller of [`TriMesh::intervals_until`] needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Need {
    /// Every interval overlapping `(0, t_max)`, each with its exact ends: what a penetration
    /// walk spends its budget over.
    Overlapping,
    /// Only the entry of the first interval overlapping `(0, t_max)`: what a first-hit query
    /// keeps. The interval's second end is then a point inside it, not its exit.
    FirstEntry,
}

/// Whether the crossings found so far settle what a caller needs.
enum Settled {
    /// Not yet: a crossing still to be found may change it, or a frontier at `recheck`.
    No {
        /// The nearest frontier at which the crossings found so far may settle it.
        recheck: f64,
    },
    /// Yes: the answer has been appended.
    Yes,
    /// The crossings of a closed mesh leave it more often than they enter it (a grazed rim):
    /// the whole line must be classified instead.
    Unbalanced,
}

/// A box of the hierarchy and what it holds: triangles `corners_in_order[link..link + count]`
/// (a leaf), or node `link` (`count` 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Child {
    /// Bounds `[min x, y, z, max x, y, z]` in single precision, rounded outward: the box holds
    /// every point of its triangles, so a query visits all it visited in double precision
    /// (and at most a few more).
    bounds: [f32; 6],
    link: u32,
    count: u32,
}

impl Child {
    fn lo(&self) -> DVec3 {
        DVec3::new(
            self.bounds[0].into(),
            self.bounds[1].into(),
            self.bounds[2].into(),
        )
    }

    fn hi(&self) -> DVec3 {
        DVec3::new(
            self.bounds[3].into(),
            self.bounds[4].into(),
            self.bounds[5].into(),
        )
    }
}

/// Children of an inner node, at most.
const WIDTH: usize = 4;

/// Bins of the surface area heuristic's cuts, per axis.
const SAH_BINS: usize = 16;

/// Levels of nodes below which the surface area heuristic cuts; deeper, median splits keep
/// the depth in bounds whatever the triangles (the heuristic may cut one off at a time).
const SAH_DEPTH: usize = 12;

/// The bin of the heuristic's `SAH_BINS` that a centre at `c` falls in, over centres from
/// `lo` spanning `ext`.
fn sah_bin(c: f64, lo: f64, ext: f64) -> usize {
    (((c - lo) / ext * SAH_BINS as f64) as usize).min(SAH_BINS - 1)
}

/// Boxes a depth-first search of a hierarchy holds at most: at most `SAH_DEPTH` levels of
/// heuristic cuts, then median splits (log4(triangles / 4) ≤ 11 more levels), each level
/// leaving at most three children behind. A fixed stack, no allocation per query.
const STACK: usize = 3 * (SAH_DEPTH + 12) + 1;

/// A box still to search: where the ray's line enters it (less a rounding slack), and its
/// [`Child::link`] and [`Child::count`].
type Queued = (f64, u32, u32);

/// An inner node of the hierarchy: the boxes of its (up to four) children coordinate by
/// coordinate in two cache lines, so that a search tests all four with one memory access and
/// a few vector operations, and descends half as many levels as in a binary tree (searches of
/// large scenes wait on memory, not on arithmetic). Unused children come last, with `link`
/// [`Node::NONE`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Node {
    /// `lo[axis][child]`: the children's lower bounds, as in [`Child::bounds`].
    lo: [[f32; WIDTH]; 3],
    /// `hi[axis][child]`: their upper bounds.
    hi: [[f32; WIDTH]; 3],
    link: [u32; WIDTH],
    count: [u32; WIDTH],
}

impl Node {
    /// The `link` of an unused child.
    const NONE: u32 = u32::MAX;

    /// A node of `children` (at most [`WIDTH`]).
    fn of(children: &[Child]) -> Self {
        let mut n = Node {
            lo: [[0.0; WIDTH]; 3],
            hi: [[0.0; WIDTH]; 3],
            link: [Self::NONE; WIDTH],
            count: [0; WIDTH],
        };
        for (j, c) in children.iter().enumerate() {
            for axis in 0..3 {
                n.lo[axis][j] = c.bounds[axis];
                n.hi[axis][j] = c.bounds[axis + 3];
            }
            n.link[j] = c.link;
            n.count[j] = c.count;
        }
        n
    }

    /// Child `j`, if in use.
    fn child(&self, j: usize) -> Option<Child> {
        (self.link[j] != Self::NONE).then(|| Child {
            bounds: [0, 1, 2, 3, 4, 5].map(|i| {
                if i < 3 {
                    self.lo[i][j]
                } else {
                    self.hi[i - 3][j]
                }
            }),
            link: self.link[j],
            count: self.count[j],
        })
    }

    /// Where the line of `ray` enters each child's box, or a little nearer (`None` where it
    /// misses the box or there is no child): all four at once, axis by axis. In single
    /// precision when the ray allows it ([`BoxRay::single`]) and `single` (the mesh's
    /// coordinates are small enough), with bounds that keep it conservative; else in double
    /// precision with the arithmetic of [`BoxRay::line_entry`]. Boxes the line leaves before
    /// the parameter `from` count as missed (all the line's boxes for `-∞`; kept where
    /// rounding leaves it in doubt).
    fn entries(&self, ray: &BoxRay, single: bool, from: f64) -> [Option<f64>; WIDTH] {
        if single && let Some(s) = &ray.single {
            #[cfg(target_arch = "x86_64")]
            return self.entries_single(s, from);
            #[cfg(not(target_arch = "x86_64"))]
            return self.entries_single_scalar(s, from);
        }
        let mut t0 = [f64::NEG_INFINITY; WIDTH];
        let mut t1 = [f64::INFINITY; WIDTH];
        let mut inside = [true; WIDTH];
        for axis in 0..3 {
            let (o, inv) = (ray.origin[axis], ray.inv[axis]);
            let (lo, hi) = (&self.lo[axis], &self.hi[axis]);
            if ray.parallel[axis] {
                for j in 0..WIDTH {
                    inside[j] &= f64::from(lo[j]) <= o && o <= f64::from(hi[j]);
                }
                continue;
            }
            for j in 0..WIDTH {
                let a = (f64::from(lo[j]) - o) * inv;
                let b = (f64::from(hi[j]) - o) * inv;
                let (near, far) = if a < b { (a, b) } else { (b, a) };
                t0[j] = if near > t0[j] { near } else { t0[j] };
                t1[j] = if far < t1[j] { far } else { t1[j] };
            }
        }
        std::array::from_fn(|j| {
            let met = inside[j] && t0[j] <= t1[j] && from <= t1[j];
            (met && self.link[j] != Self::NONE).then_some(t0[j])
        })
    }

    /// The children whose boxes the line of `ray` meets, as `(entry, child)` with the entry of
    /// [`Node::entries`], farthest first (equal entries in child order), and how many: pushed
    /// in this order, the nearest is searched next. In single precision the four are put in
    /// order by a sorting network on integer keys, without a branch on the entries (an
    /// insertion sort's branches were a quarter of a mesh search's mispredictions); children
    /// not met sort last, past the count.
    fn farthest_first(
        &self,
        ray: &BoxRay,
        single: bool,
        from: f64,
    ) -> ([(f64, usize); WIDTH], usize) {
        #[cfg(target_arch = "x86_64")]
        if single && let Some(s) = &ray.single {
            use std::arch::x86_64::{
                _mm_add_ps, _mm_and_si128, _mm_castps_si128, _mm_castsi128_ps, _mm_cmpeq_epi32,
                _mm_loadu_ps, _mm_loadu_si128, _mm_movemask_ps, _mm_or_si128, _mm_set_epi32,
                _mm_set1_epi32, _mm_setzero_ps, _mm_srai_epi32, _mm_storeu_si128, _mm_xor_si128,
            };
            let (inside, entry) = self.entries_single_bits(s, from);
            // A key per child that orders as the entries do, reversed (farthest first), and
            // all bits set for a child not met (or unused), which then sorts last; its index
            // goes in the low bits below (child order among equal entries). `+ 0.0` makes a
            // zero positive, as `<` does not tell them apart. Four at once in SSE registers.
            let mut keys = [0u32; WIDTH];
            // SAFETY: SSE and SSE2, which these intrinsics need, are part of every x86-64
            // processor. The loads read the 16 bytes of `entry` and of `self.link` (`[f32; 4]`,
            // `[u32; 4]`), the store writes the 16 bytes of `keys` (unaligned forms).
            let met = unsafe {
                let none = _mm_cmpeq_epi32(
                    _mm_loadu_si128(self.link.as_ptr().cast()),
                    _mm_set1_epi32(-1),
                );
                let used = !(_mm_movemask_ps(_mm_castsi128_ps(none)) as u32) & 0xf;
                let met = inside & used;
                let lane = _mm_set_epi32(8, 4, 2, 1);
                let met_lanes =
                    _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(met as i32), lane), lane);
                let bits =
                    _mm_castps_si128(_mm_add_ps(_mm_loadu_ps(entry.as_ptr()), _mm_setzero_ps()));
                // Ascending order of the floats as unsigned integers: a negative number's bits
                // all flipped, a positive number's sign bit set; reversed, all flipped again.
                let flip = _mm_or_si128(_mm_srai_epi32::<31>(bits), _mm_set1_epi32(i32::MIN));
                let descending = _mm_xor_si128(_mm_xor_si128(bits, flip), _mm_set1_epi32(-1));
                let all = _mm_set1_epi32(-1);
                let key = _mm_or_si128(descending, _mm_xor_si128(met_lanes, all));
                _mm_storeu_si128(keys.as_mut_ptr().cast(), key);
                met
            };
            let mut k: [u64; WIDTH] =
                std::array::from_fn(|j| (u64::from(keys[j]) << 32) | j as u64);
            for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                let (x, y) = (k[a].min(k[b]), k[a].max(k[b]));
                (k[a], k[b]) = (x, y);
            }
            let out = k.map(|k| {
                let j = (k & 3) as usize;
                (f64::from(entry[j]), j)
            });
            return (out, met.count_ones() as usize);
        }
        farthest_first(self.entries(ray, single, from))
    }

    /// [`Node::entries`] in single precision, conservative ([`boxes_single`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn entries_single(&self, ray: &SingleRay, from: f64) -> [Option<f64>; WIDTH] {
        let (inside, entry) = self.entries_single_bits(ray, from);
        std::array::from_fn(|j| {
            (inside & (1 << j) != 0 && self.link[j] != Self::NONE).then_some(entry[j].into())
        })
    }

    /// [`Node::entries_single`] as a mask of the boxes met (bit `j` for child `j`, unused
    /// children not cleared) and each box's entry.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn entries_single_bits(&self, ray: &SingleRay, from: f64) -> (u32, [f32; WIDTH]) {
        // The usual whole line without the cut's two comparisons.
        if from == f64::NEG_INFINITY {
            boxes_single::<false>(&self.lo, &self.hi, ray, (0.0, 0.0))
        } else {
            boxes_single::<true>(&self.lo, &self.hi, ray, (f32_down(from), f32::INFINITY))
        }
    }

    /// [`Node::entries_single`] lane by lane: where the SSE form is not written, and the
    /// reference it is tested against.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    fn entries_single_scalar(&self, ray: &SingleRay, from: f64) -> [Option<f64>; WIDTH] {
        let from = f32_down(from);
        let mut t0 = [f32::NEG_INFINITY; WIDTH];
        let mut t1 = [f32::INFINITY; WIDTH];
        let mut inside = [true; WIDTH];
        for axis in 0..3 {
            let (lo, hi) = (&self.lo[axis], &self.hi[axis]);
            let l = &ray.lanes;
            if ray.parallel(axis) {
                // Exact: against bounds in single precision, `lo <= o` is `lo <= o rounded up`.
                let (down, up) = (l.origin_down[axis], l.origin_up[axis]);
                for j in 0..WIDTH {
                    inside[j] &= lo[j] <= up && down <= hi[j];
                }
                continue;
            }
            let (o, inv, err) = (l.origin[axis], l.inv[axis], l.err[axis]);
            for j in 0..WIDTH {
                let a = (lo[j] - o) * inv;
                let b = (hi[j] - o) * inv;
                let (near, far) = if a < b { (a, b) } else { (b, a) };
                let near = near - (err + near.abs() * SingleRay::RELATIVE);
                let far = far + (err + far.abs() * SingleRay::RELATIVE);
                t0[j] = if near > t0[j] { near } else { t0[j] };
                t1[j] = if far < t1[j] { far } else { t1[j] };
            }
        }
        std::array::from_fn(|j| {
            let met = inside[j] && t0[j] <= t1[j] && from <= t1[j];
            (met && self.link[j] != Self::NONE).then_some(t0[j].into())
        })
    }
}

/// Four boxes, given axis by axis (`lo[axis][box]`, `hi[axis][box]`), against the line of
/// `ray` in single precision: a mask of those it meets (bit `j` for box `j`) and where it
/// enters each. Each axis' distances are widened by a bound on their error (the origin's
/// rounding to `f32` times the reciprocal, plus a few units in the last place of the
/// distance), so a box the line meets is never missed and its entry is never put too far.
/// With `STRETCH`, a box counts as met only where its stretch of the line overlaps `s0..=s1`
/// (the test of [`BoxRay::may_meet_single`], four boxes at once). The four boxes in the four
/// lanes of SSE registers, operation for operation as `Node::entries_single_scalar` (the same
/// result to the bit): the compiler did not vectorise that loop, and it took 160
/// instructions a node.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn boxes_single<const STRETCH: bool>(
    lo: &[[f32; WIDTH]; 3],
    hi: &[[f32; WIDTH]; 3],
    ray: &SingleRay,
    (s0, s1): (f32, f32),
) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::{
        _mm_and_ps, _mm_castsi128_ps, _mm_cmple_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps,
        _mm_movemask_ps, _mm_mul_ps, _mm_set1_epi32, _mm_set1_ps, _mm_storeu_ps, _mm_sub_ps,
    };
    let b = &ray.broadcast;
    let mut entry = [0.0f32; WIDTH];
    // SAFETY: SSE and SSE2, which these intrinsics need, are part of every x86-64
    // processor (the target enables them). Each load reads the 16 bytes of one
    // `[f32; 4]` behind a reference, the store writes the 16 bytes of `entry` (unaligned
    // forms: no alignment needed).
    let met = unsafe {
        // One axis narrows each box's stretch `(t0, t1)` and its `inside` mask. Called
        // for the three axes in turn, unrolled (as a loop it was not).
        let axis = |axis: usize, (t0, t1, inside)| {
            let lo = _mm_loadu_ps(lo[axis].as_ptr());
            let hi = _mm_loadu_ps(hi[axis].as_ptr());
            if ray.parallel(axis) {
                let down = _mm_loadu_ps(b.origin_down[axis].as_ptr());
                let up = _mm_loadu_ps(b.origin_up[axis].as_ptr());
                let within = _mm_and_ps(_mm_cmple_ps(lo, up), _mm_cmple_ps(down, hi));
                return (t0, t1, _mm_and_ps(inside, within));
            }
            let o = _mm_loadu_ps(b.origin[axis].as_ptr());
            let inv = _mm_loadu_ps(b.inv[axis].as_ptr());
            let err = _mm_loadu_ps(b.err[axis].as_ptr());
            let a = _mm_mul_ps(_mm_sub_ps(lo, o), inv);
            let c = _mm_mul_ps(_mm_sub_ps(hi, o), inv);
            // `minps(x, y)` is `x < y ? x : y` and `maxps(x, y)` is `x > y ? x : y`, so
            // each line below is the scalar form's comparison, NaN included.
            let near = _mm_min_ps(a, c);
            let far = _mm_max_ps(c, a);
            let (near, far) = widen(near, far, err);
            (_mm_max_ps(near, t0), _mm_min_ps(far, t1), inside)
        };
        let all = (
            _mm_set1_ps(f32::NEG_INFINITY),
            _mm_set1_ps(f32::INFINITY),
            _mm_castsi128_ps(_mm_set1_epi32(-1)),
        );
        let (t0, t1, inside) = axis(2, axis(1, axis(0, all)));
        _mm_storeu_ps(entry.as_mut_ptr(), t0);
        let mut met = _mm_and_ps(inside, _mm_cmple_ps(t0, t1));
        if STRETCH {
            let within = _mm_and_ps(
                _mm_cmple_ps(t0, _mm_set1_ps(s1)),
                _mm_cmple_ps(_mm_set1_ps(s0), t1),
            );
            met = _mm_and_ps(met, within);
        }
        _mm_movemask_ps(met)
    };
    (met as u32, entry)
}

/// Four stretches `(near, far)` of single-precision distances along a line, each end moved
/// outward by its error bound: `err` (the origin's rounding times the reciprocal) plus
/// [`SingleRay::RELATIVE`] of its size. The one widening of every single-precision box test
/// ([`boxes_single`], `SingleRay::stretch_in`), so that none narrows a box the line meets.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn widen(
    near: std::arch::x86_64::__m128,
    far: std::arch::x86_64::__m128,
    err: std::arch::x86_64::__m128,
) -> (std::arch::x86_64::__m128, std::arch::x86_64::__m128) {
    use std::arch::x86_64::{
        _mm_add_ps, _mm_and_ps, _mm_castsi128_ps, _mm_mul_ps, _mm_set1_epi32, _mm_set1_ps,
        _mm_sub_ps,
    };
    // SAFETY: SSE and SSE2, which these intrinsics need, are part of every x86-64 processor;
    // no memory is read or written.
    unsafe {
        let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff));
        let rel = _mm_set1_ps(SingleRay::RELATIVE);
        let near = _mm_sub_ps(
            near,
            _mm_add_ps(err, _mm_mul_ps(_mm_and_ps(near, abs), rel)),
        );
        let far = _mm_add_ps(far, _mm_add_ps(err, _mm_mul_ps(_mm_and_ps(far, abs), rel)));
        (near, far)
    }
}

/// The boxes met among `entries` (as from [`Node::entries`]), farthest first, equal entries in
/// child order, and how many: an insertion sort, the reference [`Node::farthest_first`] keeps.
fn farthest_first(entries: [Option<f64>; WIDTH]) -> ([(f64, usize); WIDTH], usize) {
    let mut met = [(0.0, 0usize); WIDTH];
    let mut n = 0;
    for (j, e) in entries.into_iter().enumerate() {
        if let Some(e) = e {
            let mut k = n;
            while k > 0 && met[k - 1].0 < e {
                met[k] = met[k - 1];
                k -= 1;
            }
            met[k] = (e, j);
            n += 1;
        }
    }
    (met, n)
}

/// A ray in single precision for [`Node::entries_single`]: its origin rounded (and rounded
/// down and up, for the parallel axes), its reciprocal direction, and per axis a bound on the
/// error the origin's rounding puts into a distance. Held once, in the four-lane form the
/// SSE tests load (the scalar forms read its first three lanes), and each axis' numbers again
/// repeated across four lanes for the node test.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SingleRay {
    lanes: Lanes,
    /// Each axis' numbers in all four lanes, for [`Node::entries_single`].
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    broadcast: Broadcast,
}

/// [`SingleRay`]'s numbers of each axis repeated in four lanes: `origin[axis]` is
/// `[lanes.origin[axis]; 4]`, and so on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
// Read only by the SSE form of the node test (elsewhere the scalar form runs).
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
struct Broadcast {
    origin: [[f32; 4]; 3],
    origin_down: [[f32; 4]; 3],
    origin_up: [[f32; 4]; 3],
    inv: [[f32; 4]; 3],
    err: [[f32; 4]; 3],
}

impl SingleRay {
    /// Coordinates (of origins and of meshes) up to this size, m, are tested in single
    /// precision: every distance then stays far inside `f32`'s range.
    const COORDINATES: f64 = 1e6;
    /// Reciprocal direction components up to this size likewise (a line nearer parallel to
    /// an axis is tested in double precision).
    const RECIPROCAL: f64 = 1e30;
    /// The relative error bound of a distance: (o − lo)·(1/d) takes three roundings, 3·2⁻²⁴;
    /// widening adds two more. Taken as 2⁻¹⁹, far above.
    const RELATIVE: f32 = 1.0 / (1u32 << 19) as f32;

    /// `ray` in single precision, if its numbers allow.
    fn of(origin: [f64; 3], inv: [f64; 3], parallel: [bool; 3]) -> Option<Self> {
        let fits = (0..3).all(|a| {
            origin[a].abs() <= Self::COORDINATES
                && (parallel[a] || inv[a].abs() <= Self::RECIPROCAL)
        });
        fits.then(|| {
            let o32 = origin.map(|o| o as f32);
            let down = origin.map(f32_down);
            let up = origin.map(f32_up);
            let inv32 = inv.map(|i| if i.is_finite() { i as f32 } else { 0.0 });
            // |o − o32|·|1/d|, and a little more for the rounding of the reciprocal.
            let err: [f32; 3] = std::array::from_fn(|a| {
                if parallel[a] {
                    0.0
                } else {
                    f32_up((origin[a] - f64::from(o32[a])).abs() * inv[a].abs() * (1.0 + 1e-6))
                }
            });
            let lane = |v: [f32; 3], fourth: f32| [v[0], v[1], v[2], fourth];
            let each = |v: [f32; 3]| v.map(|x| [x; 4]);
            Self {
                lanes: Lanes {
                    origin: lane(o32, 0.0),
                    origin_down: lane(down, 0.0),
                    origin_up: lane(up, 0.0),
                    inv: lane(inv32, 1.0),
                    err: lane(err, 0.0),
                    parallel: [0, 1, 2, 3].map(|a| if a < 3 && parallel[a] { u32::MAX } else { 0 }),
                    any_parallel: parallel.contains(&true),
                },
                broadcast: Broadcast {
                    origin: each(o32),
                    origin_down: each(down),
                    origin_up: each(up),
                    inv: each(inv32),
                    err: each(err),
                },
            }
        })
    }
}

/// A ray as box tests take it: its origin and reciprocal direction by axis, and which axes it
/// runs parallel to (a zero or subnormal component: no finite reciprocal), where a box is met
/// only if the origin lies within the box's extent. Made once per ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BoxRay {
    origin: [f64; 3],
    inv: [f64; 3],
    parallel: [bool; 3],
    /// The ray for the hierarchy's box tests in single precision, if its numbers allow.
    single: Option<SingleRay>,
}

impl BoxRay {
    /// `ray` prepared for box tests.
    pub fn of(ray: &Ray) -> Self {
        let inv = ray.dir.recip().to_array();
        let origin = ray.origin.to_array();
        let parallel = inv.map(|i| !i.is_finite());
        Self {
            origin,
            inv,
            parallel,
            single: SingleRay::of(origin, inv, parallel),
        }
    }

    /// The part of the stretch `t0..=t1` of the ray's line inside the box `lo..hi`, if any.
    /// Each axis narrows the stretch to where the line is between the box's two planes; the
    /// reciprocal is finite on the other axes and the bounds are finite or infinite, so no
    /// value is NaN and plain comparisons serve as `min` and `max`.
    fn stretch_in(&self, lo: DVec3, hi: DVec3, (t0, t1): (f64, f64)) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (t0, t1);
        let (lo, hi) = (lo.to_array(), hi.to_array());
        let mut inside = true;
        for axis in 0..3 {
            let o = self.origin[axis];
            if self.parallel[axis] {
                inside &= lo[axis] <= o && o <= hi[axis];
                continue;
            }
            let inv = self.inv[axis];
            let (a, b) = ((lo[axis] - o) * inv, (hi[axis] - o) * inv);
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            t0 = if near > t0 { near } else { t0 };
            t1 = if far < t1 { far } else { t1 };
        }
        (inside && t0 <= t1).then_some((t0, t1))
    }

    /// Where the ray's whole line enters the box `lo..hi`, if it meets it.
    fn line_entry(&self, lo: DVec3, hi: DVec3) -> Option<f64> {
        (self.stretch_in(lo, hi, (f64::NEG_INFINITY, f64::INFINITY))).map(|(t0, _)| t0)
    }
}

/// A triangle mesh in world coordinates, with its hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    vertices: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Watertight and consistently wound (wound outward, then).
    closed: bool,
    /// Edges used by only one triangle (0 for a closed mesh).
    boundary_edges: usize,
    /// Exact bounds `(min, max)` of the vertices.
    bounds: (DVec3, DVec3),
    /// The whole mesh's box (a leaf when it has few triangles).
    root: Child,
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// The corners of triangle `order[k]` at `k`: a leaf's triangles side by side.
    corners_in_order: Vec<[DVec3; 3]>,
    /// Whether the vertices are small enough for box tests in single precision
    /// ([`SingleRay::COORDINATES`]).
    small: bool,
}

/// One crossing of a line with a mesh: where, and whether the line enters there.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Crossing {
    t: f64,
    entering: bool,
}

/// The ray in the sheared frame of the watertight test.
struct Sheared {
    origin: DVec3,
    k: [usize; 3],
    s: DVec3,
}

impl Sheared {
    fn of(ray: &Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Keep the winding: a negative main axis swaps the other two.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin: ray.origin,
            k: [kx, ky, kz],
            s: DVec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]),
        }
    }

    /// A vertex relative to the ray, sheared: (x, y) across the ray, z along it (scaled).
    #[inline(always)]
    fn vertex(&self, v: DVec3) -> DVec3 {
        // An array, not the vector, is indexed: a vector's index is a match per access.
        let p = (v - self.origin).to_array();
        let [kx, ky, kz] = self.k;
        DVec3::new(
            p[kx] - self.s.x * p[kz],
            p[ky] - self.s.y * p[kz],
            self.s.z * p[kz],
        )
    }

    /// The crossing of the ray's whole line with triangle `abc`, if any.
    #[inline(always)]
    fn cross(&self, a: DVec3, b: DVec3, c: DVec3) -> Option<Crossing> {
        let (a, b, c) = (self.vertex(a), self.vertex(b), self.vertex(c));
        // Edge functions: `edge(p, q)` for the edge p → q; reversed, the exact negative.
        let edge = |p: DVec3, q: DVec3| q.x * p.y - q.y * p.x;
        let (u, v, w) = (edge(b, c), edge(c, a), edge(a, b));
        // No edge function zero (the usual case): the line crosses the inside exactly where
        // all three share a sign, which is then the determinant's (a sum of numbers of one
        // sign is never zero); the rules below give the same answer. Tested with `&`, not
        // `&&`: one branch on the outcome, not one per edge (most of a search's mispredicted
        // branches were these).
        if (u != 0.0) & (v != 0.0) & (w != 0.0) {
            let same = ((u > 0.0) & (v > 0.0) & (w > 0.0)) | ((u < 0.0) & (v < 0.0) & (w < 0.0));
            if !same {
                return None;
            }
            let det = u + v + w;
            return Some(Crossing {
                t: (u * a.z + v * b.z + w * c.z) / det,
                entering: det > 0.0,
            });
        }
        let det = u + v + w;
        if det == 0.0 {
            return None; // seen edge-on (or degenerate): the line grazes it
        }
        let sign = det.signum();
        let inside = |e: f64, p: DVec3, q: DVec3| {
            let e = e * sign;
            if e != 0.0 {
                return e > 0.0;
            }
            // On the edge: the top-left rule, on the edge as wound counter-clockwise.
            let d = (q - p) * sign;
            d.y > 0.0 || (d.y == 0.0 && d.x < 0.0)
        };
        if !(inside(u, b, c) && inside(v, c, a) && inside(w, a, b)) {
            return None;
        }
        let t = (u * a.z + v * b.z + w * c.z) / det;
        // Outward winding is counter-clockwise seen from outside: a line entering sees the
        // front, whose sheared winding gives a positive determinant.
        Some(Crossing {
            t,
            entering: det > 0.0,
        })
    }
}

/// Crossings in line order, an entry before an exit at the same point (so that touching
/// shells make one interval and a grazed vertex an empty one).
fn crossing_order(a: &Crossing, b: &Crossing) -> std::cmp::Ordering {
    a.t.total_cmp(&b.t).then(b.entering.cmp(&a.entering))
}

/// Where a search of a mesh begins to read: the mesh's own fields and its root's box (a node,
/// or a leaf's triangles), as addresses, so that a query can ask the memory for them when a
/// ray passes the mesh's bounds, before the search gets there. In a scene of many meshes these
/// were a search's first and longest waits (a sixth of a laser search's time on 1 300 plants).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SearchStart {
    /// The address of the [`TriMesh`] (0: none).
    mesh: usize,
    /// The address and size of the root's node or triangles.
    root: (usize, usize),
}

impl SearchStart {
    /// The start of `mesh`'s searches. The addresses stay valid while the mesh lives (it is
    /// never changed once built); a hint at a stale one would only be wasted.
    pub fn of(mesh: &TriMesh) -> Self {
        let (root, bytes) = mesh.box_bytes(mesh.root.link, mesh.root.count);
        Self {
            mesh: std::ptr::from_ref(mesh) as usize,
            root: (root as usize, bytes),
        }
    }

    /// Asks the memory for the mesh's fields and its root's box.
    #[inline(always)]
    pub fn prefetch(&self) {
        if self.mesh == 0 {
            return;
        }
        let (mesh, root) = (
            without_provenance::<u8>(self.mesh),
            without_provenance::<u8>(self.root.0),
        );
        const FIELDS: usize = size_of::<TriMesh>().div_ceil(64) + 1;
        for line in 0..FIELDS {
            prefetch_line(mesh.wrapping_add((line * 64).min(size_of::<TriMesh>() - 1)));
        }
        for line in 0..2 {
            prefetch_line(root.wrapping_add((line * 64).min(self.root.1 - 1)));
        }
    }
}

/// Asks the memory for the cache line holding `p` ahead of its use. Only a hint: nothing is
/// read that the program sees, and no address faults, so `p` may be any pointer (dangling, or
/// without provenance); it is never dereferenced.
#[inline(always)]
pub(crate) fn prefetch_line<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing the program sees and cannot fault, whatever the
    // address. SSE, which it needs, is part of every x86-64 processor.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// A mesh's bounds grown for the cheap test a ray passes before the mesh is searched
/// ([`Reach::may_meet`]): by a sheet and far more than rounding at the mesh's coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reach {
    lo: DVec3,
    hi: DVec3,
    pad: f64,
}

impl Reach {
    /// The reach of a mesh whose vertices lie in `bounds` (`(min, max)`).
    pub fn of((lo, hi): (DVec3, DVec3)) -> Self {
        let pad = 2.0 * SURFACE_THICKNESS + 1e-9 * lo.abs().max(hi.abs()).max_element();
        Self {
            lo: lo - pad,
            hi: hi + pad,
            pad,
        }
    }

    /// Whether the mesh can have an interval on `ray` that ends past the origin and begins
    /// before `t_max` (overlapping `(0, t_max)`; with a negative `t_max`, as a first-hit
    /// query may pass once it knows an interval begun behind the origin, covering
    /// `(t_max, 0)`): the ray's stretch between the two, a little widened, meets the grown
    /// bounds, where every crossing lies. A cheap test before the crossings: the cells along a
    /// ray list many meshes it passes by.
    pub fn may_meet(&self, ray: &BoxRay, t_max: f64) -> bool {
        // Rounding grows with the distance too.
        let far = 1e-9 * t_max.abs();
        let pad = self.pad + far;
        let stretch = (t_max.min(0.0) - pad, t_max.max(0.0) + pad);
        (ray.stretch_in(self.lo - far, self.hi + far, stretch)).is_some()
    }
}

/// A [`Reach`] in single precision for [`BoxRay::may_meet_single`]: its bounds by axis, the
/// fourth lane unbounded (so that four lanes test the three axes), 32 bytes side by side
/// with the next part's.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct SingleReach {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl SingleReach {
    /// Bounds that every ray passes.
    pub const UNBOUNDED: Self = Self {
        lo: [f32::NEG_INFINITY; 4],
        hi: [f32::INFINITY; 4],
    };
}

/// The [`SingleReach`]es of up to four parts side by side, axis by axis as a node holds its
/// children's boxes, with the parts' ids: a grid cell's parts in this form are tested four at
/// once ([`BoxRay::may_meet_group`]), with one branch on the outcome where one part at a time
/// took a branch per part, each mispredicted about as often as not.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct ReachGroup {
    lo: [[f32; WIDTH]; 3],
    hi: [[f32; WIDTH]; 3],
    part: [u32; WIDTH],
    /// Bit `j` set where lane `j` holds a part.
    used: u32,
}

impl ReachGroup {
    /// The group of `parts` (at most four: id and reach), in their order.
    pub fn of(parts: &[(u32, SingleReach)]) -> Self {
        assert!(
            parts.len() <= WIDTH,
            "a reach group holds at most {WIDTH} parts"
        );
        let mut g = Self {
            lo: [[0.0; WIDTH]; 3],
            hi: [[0.0; WIDTH]; 3],
            part: [u32::MAX; WIDTH],
            used: 0,
        };
        for (j, (part, reach)) in parts.iter().enumerate() {
            for axis in 0..3 {
                g.lo[axis][j] = reach.lo[axis];
                g.hi[axis][j] = reach.hi[axis];
            }
            g.part[j] = *part;
            g.used |= 1 << j;
        }
        g
    }

    /// The part in lane `j`.
    pub fn part(&self, j: usize) -> u32 {
        self.part[j]
    }

    /// Lane `j`'s reach.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    fn reach(&self, j: usize) -> SingleReach {
        let mut r = SingleReach::UNBOUNDED;
        for axis in 0..3 {
            r.lo[axis] = self.lo[axis][j];
            r.hi[axis] = self.hi[axis][j];
        }
        r
    }
}

impl Reach {
    /// Stretches up to this long (`|t_max|`, m) are tested by [`BoxRay::may_meet_single`];
    /// longer ones always pass it.
    pub const SINGLE_STRETCH: f64 = 1e6;
    /// What [`Reach::single`] adds around the reach, m: more than [`Reach::may_meet`] widens
    /// the bounds by for any stretch up to [`Reach::SINGLE_STRETCH`] (1e-9 of it).
    pub const SINGLE_PAD: f64 = 1e-3;

    /// The reach in single precision for [`BoxRay::may_meet_single`], grown by
    /// [`Reach::SINGLE_PAD`] and rounded outward; unbounded (every ray passes) for a mesh
    /// beyond the coordinates single precision takes, whose pad is larger than that test
    /// allows for.
    pub fn single(&self) -> SingleReach {
        if self.lo.abs().max(self.hi.abs()).max_element() > SingleRay::COORDINATES {
            return SingleReach::UNBOUNDED;
        }
        let (lo, hi) = (self.lo - Self::SINGLE_PAD, self.hi + Self::SINGLE_PAD);
        SingleReach {
            lo: [
                f32_down(lo.x),
                f32_down(lo.y),
                f32_down(lo.z),
                f32::NEG_INFINITY,
            ],
            hi: [f32_up(hi.x), f32_up(hi.y), f32_up(hi.z), f32::INFINITY],
        }
    }
}

/// The stretch of a ray that [`BoxRay::may_meet_single`] tests bounds against, made once per
/// `t_max` ([`BoxRay::single_stretch`]). The default passes every box.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SingleStretch {
    /// The `t_max` it was made for.
    t_max: f64,
    /// Its ends in single precision, grown; `None`: every box passes.
    ends: Option<(f32, f32)>,
}

impl BoxRay {
    /// The stretch of the ray from its origin to `t_max` for [`BoxRay::may_meet_single`],
    /// grown more than [`Reach::may_meet`] grows it; for rays whose numbers do not allow
    /// single precision, and for stretches longer than [`Reach::SINGLE_STRETCH`], one that
    /// every box passes.
    pub fn single_stretch(&self, t_max: f64) -> SingleStretch {
        let ends = (self.single.is_some() && t_max.abs() <= Reach::SINGLE_STRETCH).then(|| {
            // More than every pad `may_meet` puts on the stretch (a reach's pad is below
            // 1.002e-3 m at the coordinates single precision takes, plus 1e-9 of the stretch)
            // and the roundings of the stretch's ends to single precision (6e-8 of it each).
            let grow = (2e-3 + 1e-6 * t_max.abs()) as f32;
            (t_max.min(0.0) as f32 - grow, t_max.max(0.0) as f32 + grow)
        });
        SingleStretch { t_max, ends }
    }

    /// A cheaper [`Reach::may_meet`] that passes at least every ray it passes: whether the
    /// ray's line meets the box of `reach` ([`Reach::single`]) within `stretch`, in single
    /// precision with the widening of the hierarchy's node test (a box the line meets is
    /// never missed, its stretch never narrowed). It reads only the bounds, side by side in one
    /// array: a ray along the cells of a scene of many meshes passes by far more meshes than
    /// it meets, and the full test first fetched the part, its object and its stamp, a few
    /// cache lines each (1 M triangles of generated plants, laser rays: 4 % fewer
    /// instructions, 19 % fewer data reads and 15 % fewer first-level cache misses,
    /// callgrind).
    #[inline(always)]
    pub fn may_meet_single(&self, reach: &SingleReach, stretch: &SingleStretch) -> bool {
        match (&self.single, stretch.ends) {
            (Some(ray), Some((s0, s1))) => {
                // No end is NaN: the two stretches overlap.
                let (t0, t1) = ray.stretch_in(reach);
                t0 <= t1 && t0 <= s1 && s0 <= t1
            }
            _ => true,
        }
    }
}

impl BoxRay {
    /// [`BoxRay::may_meet_single`] for the parts of `group`, four at once: bit `j` set where
    /// lane `j` holds a part that passes (the same answer, part by part: a property test).
    #[inline(always)]
    pub fn may_meet_group(&self, group: &ReachGroup, stretch: &SingleStretch) -> u32 {
        match (&self.single, stretch.ends) {
            #[cfg(target_arch = "x86_64")]
            (Some(ray), Some(ends)) => {
                boxes_single::<true>(&group.lo, &group.hi, ray, ends).0 & group.used
            }
            #[cfg(not(target_arch = "x86_64"))]
            (Some(_), Some(_)) => {
                (0..WIDTH).fold(0, |m, j| {
                    let pass = self.may_meet_single(&group.reach(j), stretch);
                    m | u32::from(pass) << j
                }) & group.used
            }
            _ => group.used,
        }
    }
}

impl SingleStretch {
    /// The `t_max` it was made for.
    pub fn t_max(&self) -> f64 {
        self.t_max
    }
}

/// The lanes of [`SingleRay`]'s four-lane form: axes x, y, z, and a lane that every box of
/// [`SingleReach`] leaves unbounded.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Lanes {
    origin: [f32; 4],
    origin_down: [f32; 4],
    origin_up: [f32; 4],
    /// The reciprocal, 1 in the fourth lane and 0 on parallel axes (which `parallel` masks).
    inv: [f32; 4],
    err: [f32; 4],
    /// All bits set on the axes the ray runs parallel to (the SSE test's mask).
    parallel: [u32; 4],
    /// Whether it runs parallel to some axis.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    any_parallel: bool,
}

impl SingleRay {
    /// Whether the ray runs parallel to `axis` (0–2): read from the lanes' mask.
    #[inline(always)]
    fn parallel(&self, axis: usize) -> bool {
        self.lanes.parallel[axis] != 0
    }

    /// The stretch `(t0, t1)` of the ray's line inside the box of `reach`, widened as in
    /// [`Node::entries_single`] (`t0 > t1`: it misses the box). Four lanes at once: the
    /// scalar form took a hundred instructions a box, with a branch per axis.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn stretch_in(&self, reach: &SingleReach) -> (f32, f32) {
        use std::arch::x86_64::{
            _mm_and_ps, _mm_andnot_ps, _mm_castsi128_ps, _mm_cmple_ps, _mm_cvtss_f32, _mm_loadu_ps,
            _mm_loadu_si128, _mm_max_ps, _mm_min_ps, _mm_movehl_ps, _mm_mul_ps, _mm_or_ps,
            _mm_set1_ps, _mm_shuffle_ps, _mm_sub_ps,
        };
        let l = &self.lanes;
        // SAFETY: SSE and SSE2, which these intrinsics need, are part of every x86-64
        // processor (the target enables them). Each load reads the 16 bytes of one
        // `[f32; 4]` or `[u32; 4]` behind a reference (unaligned loads: no alignment needed).
        unsafe {
            let lo = _mm_loadu_ps(reach.lo.as_ptr());
            let hi = _mm_loadu_ps(reach.hi.as_ptr());
            let o = _mm_loadu_ps(l.origin.as_ptr());
            let inv = _mm_loadu_ps(l.inv.as_ptr());
            let err = _mm_loadu_ps(l.err.as_ptr());
            let a = _mm_mul_ps(_mm_sub_ps(lo, o), inv);
            let b = _mm_mul_ps(_mm_sub_ps(hi, o), inv);
            let (near, far) = widen(_mm_min_ps(a, b), _mm_max_ps(a, b), err);
            // A parallel axis: the whole line if the origin is within the box's extent, else
            // none of it (rare: the branch goes the same way for every box of a ray).
            let (near, far) = if l.any_parallel {
                let (inf, neg) = (_mm_set1_ps(f32::INFINITY), _mm_set1_ps(f32::NEG_INFINITY));
                let up = _mm_loadu_ps(l.origin_up.as_ptr());
                let down = _mm_loadu_ps(l.origin_down.as_ptr());
                let inside = _mm_and_ps(_mm_cmple_ps(lo, up), _mm_cmple_ps(down, hi));
                let pick = |m, x, y| _mm_or_ps(_mm_and_ps(m, x), _mm_andnot_ps(m, y));
                let par = _mm_castsi128_ps(_mm_loadu_si128(l.parallel.as_ptr().cast()));
                (
                    pick(par, pick(inside, neg, inf), near),
                    pick(par, pick(inside, inf, neg), far),
                )
            } else {
                (near, far)
            };
            // The largest entry and the smallest exit of the four lanes.
            let n = _mm_max_ps(near, _mm_movehl_ps(near, near));
            let n = _mm_max_ps(n, _mm_shuffle_ps::<0b01>(n, n));
            let f = _mm_min_ps(far, _mm_movehl_ps(far, far));
            let f = _mm_min_ps(f, _mm_shuffle_ps::<0b01>(f, f));
            (_mm_cvtss_f32(n), _mm_cvtss_f32(f))
        }
    }

    /// [`SingleRay::stretch_in`] lane by lane, where the four-lane form is not written.
    #[cfg(not(target_arch = "x86_64"))]
    fn stretch_in(&self, reach: &SingleReach) -> (f32, f32) {
        let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
        for axis in 0..3 {
            let (lo, hi) = (reach.lo[axis], reach.hi[axis]);
            let l = &self.lanes;
            if self.parallel(axis) {
                if !(lo <= l.origin_up[axis] && l.origin_down[axis] <= hi) {
                    return (f32::INFINITY, f32::NEG_INFINITY);
                }
                continue;
            }
            let (o, inv, err) = (l.origin[axis], l.inv[axis], l.err[axis]);
            let (a, b) = ((lo - o) * inv, (hi - o) * inv);
            let (near, far) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(near - (err + near.abs() * Self::RELATIVE));
            t1 = t1.min(far + (err + far.abs() * Self::RELATIVE));
        }
        (t0, t1)
    }
}

/// The largest `f32` at or below `x`.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x { f.next_down() } else { f }
}

/// The smallest `f32` at or above `x`.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x { f.next_up() } else { f }
}

impl TriMesh {
    /// A mesh of `triangles` (vertex indices) over `vertices`, in world coordinates. Vertices
    /// at exactly the same position are merged (file formats split them at seams), triangles
    /// with a repeated vertex dropped. The mesh is closed when every edge is shared by exactly
    /// two triangles that can be wound alike; it is then wound outward.
    pub fn new(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        if triangles.len() > MAX_TRIANGLES {
            return Err(MeshError::TooLarge(triangles.len()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(MeshError::NotFinite(i));
        }
        for (k, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(MeshError::BadIndex {
                    triangle: k,
                    index,
                    vertices: vertices.len(),
                });
            }
        }
        // Weld by exact position (-0 and +0 alike).
        let mut id: HashMap<[u64; 3], u32> = HashMap::with_capacity(vertices.len());
        let mut welded = Vec::with_capacity(vertices.len());
        let remap: Vec<u32> = vertices
            .iter()
            .map(|v| {
                let key = (*v + DVec3::ZERO).to_array().map(f64::to_bits);
                *id.entry(key).or_insert_with(|| {
                    welded.push(*v);
                    (welded.len() - 1) as u32
                })
            })
            .collect();
        let mut triangles: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
            .collect();
        if triangles.is_empty() {
            return Err(MeshError::Empty);
        }
        let (closed, boundary_edges) = orient(&mut triangles);
        let mut mesh = Self {
            vertices: welded,
            triangles,
            closed,
            boundary_edges,
            bounds: (DVec3::ZERO, DVec3::ZERO),
            root: Child::default(),
            nodes: Vec::new(),
            order: Vec::new(),
            corners_in_order: Vec::new(),
            small: false,
        };
        if closed && mesh.signed_volume() < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
        }
        mesh.build();
        Ok(mesh)
    }

    /// Whether the mesh is watertight and consistently wound: a volume.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Edges used by a single triangle (a closed mesh has none).
    pub fn boundary_edges(&self) -> usize {
        self.boundary_edges
    }

    /// A closed mesh cut into pieces that lie apart: its connected shells, grouped wherever
    /// their bounds meet (nested or overlapping shells stay one volume), so that no line
    /// passes through two pieces over one stretch. Each piece is closed, its triangles wound
    /// as here, and every ray's intervals are those of the whole (a line's crossings of one
    /// piece all lie within that piece's bounds, apart from the others'); but a ray query
    /// finds each piece in the world's grid instead of searching one hierarchy spread over
    /// the whole scene, behind the sensor as well. An open mesh, or one of a single group,
    /// is returned whole.
    pub fn into_apart(self) -> Vec<TriMesh> {
        if !self.closed || self.triangles.len() < 2 {
            return vec![self];
        }
        // Shells: triangles joined by shared vertices.
        let mut shells = UnionFind::new(self.vertices.len());
        for t in &self.triangles {
            shells.union(t[0] as usize, t[1] as usize);
            shells.union(t[0] as usize, t[2] as usize);
        }
        let mut shell_of_root: HashMap<usize, usize> = HashMap::new();
        let mut boxes: Vec<(DVec3, DVec3)> = Vec::new();
        let shell: Vec<usize> = (self.triangles.iter())
            .map(|t| {
                let root = shells.find(t[0] as usize);
                let next = shell_of_root.len();
                let k = *shell_of_root.entry(root).or_insert(next);
                if k == boxes.len() {
                    boxes.push((DVec3::INFINITY, DVec3::NEG_INFINITY));
                }
                for &i in t {
                    let v = self.vertices[i as usize];
                    boxes[k] = (boxes[k].0.min(v), boxes[k].1.max(v));
                }
                k
            })
            .collect();
        // Groups: shells whose boxes meet (touching counts), by a sweep along the axis the
        // shells spread most over (so that a row of them is not all open at once).
        let (lo_min, lo_max) = (boxes.iter())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), s| {
                (a.min(s.0), b.max(s.0))
            });
        let axis = (lo_max - lo_min).max_position();
        let mut groups = UnionFind::new(boxes.len());
        let mut order: Vec<usize> = (0..boxes.len()).collect();
        order.sort_by(|&a, &b| boxes[a].0[axis].total_cmp(&boxes[b].0[axis]));
        let mut open: Vec<usize> = Vec::new();
        for &k in &order {
            let (lo, hi) = boxes[k];
            open.retain(|&j| boxes[j].1[axis] >= lo[axis]);
            for &j in &open {
                let (a, b) = boxes[j];
                if a.cmple(hi).all() && lo.cmple(b).all() {
                    groups.union(j, k);
                }
            }
            open.push(k);
        }
        let mut group_of_root: HashMap<usize, usize> = HashMap::new();
        // Per piece: its vertices, its triangles, and where each of this mesh's vertices went.
        type Piece = (Vec<DVec3>, Vec<[u32; 3]>, HashMap<u32, u32>);
        let mut pieces: Vec<Piece> = Vec::new();
        for (t, &k) in self.triangles.iter().zip(&shell) {
            let root = groups.find(k);
            let next = group_of_root.len();
            let g = *group_of_root.entry(root).or_insert(next);
            if g == pieces.len() {
                pieces.push((Vec::new(), Vec::new(), HashMap::new()));
            }
            let (vertices, triangles, index) = &mut pieces[g];
            let t = t.map(|i| {
                *index.entry(i).or_insert_with(|| {
                    vertices.push(self.vertices[i as usize]);
                    (vertices.len() - 1) as u32
                })
            });
            triangles.push(t);
        }
        if pieces.len() < 2 {
            return vec![self];
        }
        let apart: Result<Vec<TriMesh>, MeshError> = (pieces.into_iter())
            .map(|(v, t, _)| TriMesh::new(v, t))
            .collect();
        match apart {
            Ok(apart) if apart.iter().all(TriMesh::is_closed) => apart,
            // Not expected (each shell of a closed mesh is closed); whole is always right.
            _ => vec![self],
        }
    }

    /// Why the mesh is not closed, in words (empty when it is).
    pub fn why_open(&self) -> String {
        match (self.closed, self.boundary_edges) {
            (true, _) => String::new(),
            (false, 0) => {
                "edges shared by more than two triangles, or faces that cannot be wound alike"
                    .to_owned()
            }
            (false, n) => format!("{n} edges belong to one triangle only"),
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The vertices, world coordinates.
    pub fn vertices(&self) -> &[DVec3] {
        &self.vertices
    }

    /// The triangles as vertex indices (wound outward when closed).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    fn corners(&self, k: usize) -> [DVec3; 3] {
        self.triangles[k].map(|i| self.vertices[i as usize])
    }

    fn signed_volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|k| {
                let [a, b, c] = self.corners(k);
                a.dot(b.cross(c))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn aabb(&self) -> (DVec3, DVec3) {
        self.bounds
    }

    fn build(&mut self) {
        let boxes: Vec<(DVec3, DVec3, DVec3)> = (0..self.triangles.len())
            .map(|k| {
                let [a, b, c] = self.corners(k);
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                (lo, hi, (lo + hi) * 0.5)
            })
            .collect();
        self.order = (0..self.triangles.len() as u32).collect();
        self.nodes.clear();
        let n = self.order.len();
        self.root = self.split(&boxes, 0, n, 0);
        self.corners_in_order = (self.order.iter())
            .map(|&k| self.corners(k as usize))
            .collect();
        let (lo, hi) = self.bounds;
        self.small = lo.abs().max(hi.abs()).max_element() <= SingleRay::COORDINATES;
    }

    /// The box of `order[start..end]` at `depth` nodes below the root, and below it its
    /// nodes: two levels of splits ([`TriMesh::halve`]) give a node's children.
    fn split(
        &mut self,
        boxes: &[(DVec3, DVec3, DVec3)],
        start: usize,
        end: usize,
        depth: usize,
    ) -> Child {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &k in &self.order[start..end] {
            let (a, b, _) = boxes[k as usize];
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        if start == 0 && end == self.order.len() {
            self.bounds = (lo, hi);
        }
        let [lx, ly, lz] = lo.to_array().map(f32_down);
        let [hx, hy, hz] = hi.to_array().map(f32_up);
        let bounds = [lx, ly, lz, hx, hy, hz];
        if end - start <= LEAF_SIZE {
            return Child {
                bounds,
                link: start as u32,
                count: (end - start) as u32,
            };
        }
        let sah = depth < SAH_DEPTH;
        let mid = self.halve(boxes, start, end, sah);
        let mut ranges = Vec::with_capacity(WIDTH);
        for (a, b) in [(start, mid), (mid, end)] {
            if b - a > LEAF_SIZE {
                let m = self.halve(boxes, a, b, sah);
                ranges.extend([(a, m), (m, b)]);
            } else {
                ranges.push((a, b));
            }
        }
        let me = self.nodes.len();
        self.nodes.push(Node::of(&[]));
        let children: Vec<Child> = (ranges.into_iter())
            .map(|(a, b)| self.split(boxes, a, b, depth + 1))
            .collect();
        self.nodes[me] = Node::of(&children);
        Child {
            bounds,
            link: me as u32,
            count: 0,
        }
    }

    /// Splits `order[start..end]` in two and returns where the second part begins: where the
    /// surface area heuristic puts it (`sah`; binned centres on each axis, the cut that
    /// least weighs each part's box area by its triangles), else, or when it finds no cut,
    /// about the median along the longest axis of the centres.
    fn halve(
        &mut self,
        boxes: &[(DVec3, DVec3, DVec3)],
        start: usize,
        end: usize,
        sah: bool,
    ) -> usize {
        let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &k in &self.order[start..end] {
            let c = boxes[k as usize].2;
            (clo, chi) = (clo.min(c), chi.max(c));
        }
        let ext = chi - clo;
        if sah && let Some((axis, cut)) = self.sah_cut(boxes, start, end, clo, ext) {
            let bin = |k: u32| sah_bin(boxes[k as usize].2[axis], clo[axis], ext[axis]);
            let mut mid = start;
            for j in start..end {
                if bin(self.order[j]) <= cut {
                    self.order.swap(mid, j);
                    mid += 1;
                }
            }
            if mid > start && mid < end {
                return mid;
            }
        }
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            boxes[a as usize].2[axis].total_cmp(&boxes[b as usize].2[axis])
        });
        mid
    }

    /// The best cut of `order[start..end]` by the surface area heuristic: the axis and the
    /// last bin of the first part, if any cut leaves both parts some triangles.
    fn sah_cut(
        &self,
        boxes: &[(DVec3, DVec3, DVec3)],
        start: usize,
        end: usize,
        clo: DVec3,
        ext: DVec3,
    ) -> Option<(usize, usize)> {
        let area = |lo: DVec3, hi: DVec3| {
            let d = (hi - lo).max(DVec3::ZERO);
            d.x * d.y + d.y * d.z + d.z * d.x
        };
        let mut best: Option<(f64, usize, usize)> = None;
        for axis in 0..3 {
            if ext[axis] <= 0.0 {
                continue;
            }
            let mut bins = [(0usize, DVec3::INFINITY, DVec3::NEG_INFINITY); SAH_BINS];
            for &k in &self.order[start..end] {
                let (lo, hi, c) = boxes[k as usize];
                let b = &mut bins[sah_bin(c[axis], clo[axis], ext[axis])];
                *b = (b.0 + 1, b.1.min(lo), b.2.max(hi));
            }
            // The first part's cost for each cut, then the second's from the other end.
            let mut left = [0.0; SAH_BINS];
            let (mut n, mut lo, mut hi) = (0, DVec3::INFINITY, DVec3::NEG_INFINITY);
            for (i, b) in bins.iter().enumerate() {
                (n, lo, hi) = (n + b.0, lo.min(b.1), hi.max(b.2));
                left[i] = n as f64 * area(lo, hi);
            }
            let (mut n, mut lo, mut hi) = (0, DVec3::INFINITY, DVec3::NEG_INFINITY);
            for cut in (0..SAH_BINS - 1).rev() {
                let b = bins[cut + 1];
                (n, lo, hi) = (n + b.0, lo.min(b.1), hi.max(b.2));
                let cost = left[cut] + n as f64 * area(lo, hi);
                let first = end - start - n;
                if first > 0 && n > 0 && best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, cut));
                }
            }
        }
        best.map(|(_, axis, cut)| (axis, cut))
    }

    /// Calls `f` with the place in `order` of every triangle whose boxes pass `keep`.
    fn visit(&self, keep: impl Fn(DVec3, DVec3) -> bool, f: impl FnMut(usize)) {
        self.visit_nodes(
            keep(self.root.lo(), self.root.hi()),
            |node| std::array::from_fn(|j| node.child(j).is_some_and(|c| keep(c.lo(), c.hi()))),
            f,
        );
    }

    /// Calls `f` with the place in `order` of every triangle below the root (if `keep_root`)
    /// whose boxes pass `keep` (which says for each child of a node whether it passes).
    fn visit_nodes(
        &self,
        keep_root: bool,
        keep: impl Fn(&Node) -> [bool; WIDTH],
        mut f: impl FnMut(usize),
    ) {
        let mut stack = [(0u32, 0u32); STACK];
        let mut top = 0;
        if keep_root {
            stack[0] = (self.root.link, self.root.count);
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let (link, count) = stack[top];
            if count > 0 {
                let s = link as usize;
                (s..s + count as usize).for_each(&mut f);
                continue;
            }
            let node = &self.nodes[link as usize];
            for (j, kept) in keep(node).into_iter().enumerate() {
                if kept {
                    self.prefetch(node.link[j], node.count[j]);
                    stack[top] = (node.link[j], node.count[j]);
                    top += 1;
                }
            }
        }
    }

    /// Asks the memory for what a box just queued holds (a node, or a leaf's triangles)
    /// ahead of its search. A scene of many meshes does not fit in the caches, and a search
    /// otherwise waits on each box's fetch in turn; this way the boxes a node lets through
    /// are fetched together, while the search goes on (1 M triangles of generated plants:
    /// 12–18 % more laser rays and 17–21 % more radar rays per CPU-second).
    #[inline]
    fn prefetch(&self, link: u32, count: u32) {
        let (start, bytes) = self.box_bytes(link, count);
        if count == 0 {
            // A node: its two lines.
            prefetch_line(start);
            prefetch_line(start.wrapping_add(64));
        } else {
            // A fixed count of hints, each at most at the last byte: a loop to the leaf's end
            // was a mispredicted exit per leaf (four triangles span at most six lines).
            const LINES: usize = (LEAF_SIZE * size_of::<[DVec3; 3]>()).div_ceil(64) + 1;
            for line in 0..LINES {
                prefetch_line(start.wrapping_add((line * 64).min(bytes - 1)));
            }
        }
    }

    /// Where the arrays a ray search reads lie in memory: the nodes and the triangles'
    /// corners ([`super::pages::span`]).
    pub(crate) fn search_spans(&self) -> [(usize, usize); 2] {
        [
            super::pages::span(&self.nodes),
            super::pages::span(&self.corners_in_order),
        ]
    }

    /// Where what the box `(link, count)` holds lies in memory, and its size: node `link`
    /// (`count` 0), or the leaf's triangles from `link`. For memory hints only.
    #[inline(always)]
    fn box_bytes(&self, link: u32, count: u32) -> (*const u8, usize) {
        if count == 0 {
            let node = self.nodes.as_ptr().wrapping_add(link as usize);
            (node.cast(), size_of::<Node>())
        } else {
            let leaf = self.corners_in_order.as_ptr().wrapping_add(link as usize);
            (leaf.cast(), count as usize * size_of::<[DVec3; 3]>())
        }
    }

    /// Every crossing of the ray's whole line with the mesh, unsorted.
    fn crossings(&self, ray: &Ray, box_ray: &BoxRay, out: &mut Vec<Crossing>) {
        let sheared = Sheared::of(ray);
        self.visit_nodes(
            box_ray.line_entry(self.root.lo(), self.root.hi()).is_some(),
            |node| (node.entries(box_ray, self.small, f64::NEG_INFINITY)).map(|e| e.is_some()),
            |k| {
                let [a, b, c] = self.corners_in_order[k];
                out.extend(sheared.cross(a, b, c));
            },
        );
    }

    /// Appends to `out` the disjoint intervals, in increasing order, where the ray's whole
    /// line is inside the mesh: between entries and exits for a closed mesh (by winding, so
    /// nested shells are one volume), a [`SURFACE_THICKNESS`] sheet at each crossing of an
    /// open one.
    pub fn ray_intervals(&self, ray: &Ray, out: &mut Vec<(f64, f64)>) {
        thread_local! {
            /// The crossings of the current ray, kept from ray to ray.
            static HITS: std::cell::RefCell<Vec<Crossing>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        HITS.with_borrow_mut(|hits| {
            hits.clear();
            self.crossings(ray, &BoxRay::of(ray), hits);
            self.intervals_of(ray, hits, out);
        });
    }

    /// Appends to `out` what `need` asks of the intervals of [`TriMesh::ray_intervals`] that
    /// overlap `(0, t_max)`, finding only the crossings that decide it: the hierarchy is
    /// searched front to back along the ray's line, and the search stops once every crossing
    /// not yet found lies beyond the point that settles the answer (a laser's first entry is
    /// settled by the next crossing after it; a walk's intervals by the exit of the last one
    /// to begin before `t_max`). A line whose crossings up to there do not balance (a grazed
    /// rim) is classified whole, as [`TriMesh::ray_intervals`] does.
    pub fn intervals_until(
        &self,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: f64,
        need: Need,
        out: &mut Vec<(f64, f64)>,
    ) {
        thread_local! {
            /// The crossings found, sorted, and the boxes still to search, farthest first.
            static SEARCH: std::cell::RefCell<(Vec<Crossing>, Vec<Queued>)> =
                const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
        }
        let (lo, hi) = self.bounds;
        // A crossing's computed distance may fall short of its box's computed entry by
        // rounding: boxes count as reaching this much nearer (far more than rounding), and the
        // mesh's bounds this much wider.
        let slack = 1e-9 * (1.0 + lo.abs().max(hi.abs()).max_element())
            + 1e-9 * ray.origin.abs().max_element();
        let whole = (f64::NEG_INFINITY, f64::INFINITY);
        let Some((t_enter, t_leave)) = box_ray.stretch_in(lo - slack, hi + slack, whole) else {
            return;
        };
        // Every interval ends at a crossing, or a sheet's thickness past one, and every
        // crossing lies within the bounds: a mesh the line leaves behind the origin has none
        // reaching ahead of it.
        if t_leave < -SURFACE_THICKNESS {
            return;
        }
        // A closed mesh needs the crossings behind the origin (they say whether it starts
        // inside), an open one does not: its sheets that reach past the origin are those of
        // the crossings ahead, unless a crossing lies within a few sheets' thickness of the
        // origin (then the search falls back to the whole line). So a search from inside an
        // open mesh's bounds (a robot in a building) skips every box the line leaves before
        // `from` and every crossing there.
        let from = if self.closed || t_enter > slack {
            f64::NEG_INFINITY
        } else {
            -(BEHIND_SHEETS * SURFACE_THICKNESS + slack)
        };
        // A mesh wholly ahead of the ray (the usual case for a sensor outside it) has no
        // crossing behind the origin, nor an open one past the cut: its first entry is its
        // nearest crossing.
        if need == Need::FirstEntry
            && (t_enter > slack || from > f64::NEG_INFINITY)
            && self.first_entry_ahead(ray, box_ray, (t_enter, slack), from, t_max, out)
        {
            return;
        }
        SEARCH.with_borrow_mut(|(hits, queue)| {
            hits.clear();
            if need == Need::Overlapping && t_leave <= t_max && from == f64::NEG_INFINITY {
                // Every crossing lies before `t_max`: all of them are needed (but those behind
                // the origin, rarely many), so the plain search is the cheaper.
                self.crossings(ray, box_ray, hits);
                self.keep_overlapping(ray, hits, t_max, need, out);
                return;
            }
            queue.clear();
            let sheared = Sheared::of(ray);
            let enqueue = |t: f64, link: u32, count: u32, queue: &mut Vec<Queued>| {
                let t = t - slack;
                let at = queue.partition_point(|&(u, _, _)| u > t);
                queue.insert(at, (t, link, count));
            };
            let root = &self.root;
            if let Some(t) = box_ray.line_entry(root.lo(), root.hi()) {
                enqueue(t, root.link, root.count, queue);
            }
            // The search settles nothing new before the frontier reaches `recheck` or a
            // crossing is found.
            let mut recheck = f64::NEG_INFINITY;
            'search: loop {
                // Every crossing not found yet lies at or beyond the nearest node left.
                let frontier = queue.last().map_or(f64::INFINITY, |&(t, _, _)| t);
                if frontier >= recheck {
                    match self.settle(ray, hits, frontier, t_max, need, out) {
                        Settled::Yes => return,
                        Settled::Unbalanced => break,
                        Settled::No { recheck: r } => recheck = r,
                    }
                }
                // Settled once nothing is left (unless `t_max` is not a number).
                let Some((_, link, count)) = queue.pop() else {
                    break;
                };
                if count == 0 {
                    let node = &self.nodes[link as usize];
                    let entries = node.entries(box_ray, self.small, from);
                    for (j, t) in entries.into_iter().enumerate() {
                        if let Some(t) = t {
                            self.prefetch(node.link[j], node.count[j]);
                            enqueue(t, node.link[j], node.count[j], queue);
                        }
                    }
                } else {
                    let s = link as usize;
                    for corners in &self.corners_in_order[s..s + count as usize] {
                        let [a, b, c] = *corners;
                        if let Some(h) = sheared.cross(a, b, c) {
                            if h.t < from {
                                continue;
                            }
                            // Near the origin the sheets behind it may matter.
                            if h.t <= 0.0 && from > f64::NEG_INFINITY {
                                break 'search;
                            }
                            let at = hits.partition_point(|x| crossing_order(x, &h).is_lt());
                            hits.insert(at, h);
                            recheck = f64::NEG_INFINITY;
                        }
                    }
                }
            }
            hits.clear();
            self.crossings(ray, box_ray, hits);
            self.keep_overlapping(ray, hits, t_max, need, out);
        })
    }

    /// [`TriMesh::intervals_until`] for [`Need::FirstEntry`] on a line whose every crossing
    /// lies ahead of the ray's origin, entering the mesh's bounds (grown by `slack`, the
    /// rounding allowance of [`TriMesh::intervals_until`]) at `t_enter`, or of an open mesh
    /// whose crossings before `from` do not matter: a nearest-box-first search for the
    /// nearest crossing at or past `from`, on a plain stack, with no list of crossings kept in
    /// order. Boxes beyond the nearest crossing found so far, and boxes the line leaves before
    /// `from`, are not searched. True once the answer is appended (or there is none before
    /// `t_max`); false, with nothing appended, where the nearest crossing does not settle it
    /// (of an open mesh: one at or behind the origin; of a closed mesh: an exit, an entry with
    /// no crossing or box left behind it, or a second crossing at its point or within rounding
    /// of it: a grazed rim), which the general search then decides as it always has. As there,
    /// the second end of the interval is a point inside it: the nearest of what lies beyond
    /// the entry.
    fn first_entry_ahead(
        &self,
        ray: &Ray,
        box_ray: &BoxRay,
        (t_enter, slack): (f64, f64),
        from: f64,
        t_max: f64,
        out: &mut Vec<(f64, f64)>,
    ) -> bool {
        let sheared = Sheared::of(ray);
        let mut stack = [MaybeUninit::<Queued>::uninit(); STACK];
        // The root's box holds the bounds: the line enters it no later.
        stack[0].write((t_enter - slack, self.root.link, self.root.count));
        let mut top = 1;
        // The nearest crossing (in `crossing_order`), the nearest of the other crossings
        // found, and the nearest of those and of the boxes left unsearched.
        let mut first: Option<Crossing> = None;
        let mut next = f64::INFINITY;
        let mut beyond = f64::INFINITY;
        while top > 0 {
            top -= 1;
            // SAFETY: every slot below `top` has been written (slot 0 above, the rest as
            // boxes are pushed), and `top` only falls to slots written before.
            let (t, link, count) = unsafe { stack[top].assume_init() };
            // A box's crossings lie at or beyond its queued entry: none there can come first
            // (or before `t_max`, while nothing is found).
            if t > first.map_or(t_max, |f| f.t.min(t_max)) {
                beyond = beyond.min(t);
                continue;
            }
            if count == 0 {
                let node = &self.nodes[link as usize];
                // Nearest last, so that it is searched next.
                let (met, n) = node.farthest_first(box_ray, self.small, from);
                for &(e, j) in &met[..n] {
                    self.prefetch(node.link[j], node.count[j]);
                    stack[top].write((e - slack, node.link[j], node.count[j]));
                    top += 1;
                }
            } else {
                let s = link as usize;
                for corners in &self.corners_in_order[s..s + count as usize] {
                    let [a, b, c] = *corners;
                    let Some(h) = sheared.cross(a, b, c).filter(|h| h.t >= from) else {
                        continue;
                    };
                    match first {
                        Some(f) if crossing_order(&h, &f).is_ge() => {
                            next = next.min(h.t);
                            beyond = beyond.min(h.t);
                        }
                        _ => {
                            if let Some(f) = first {
                                next = next.min(f.t);
                                beyond = beyond.min(f.t);
                            }
                            first = Some(h);
                        }
                    }
                }
            }
        }
        // Nothing before `t_max` (also where it is not a number): no answer, settled.
        let Some(f) = first.filter(|f| f.t < t_max) else {
            return true;
        };
        if !self.closed {
            // A sheet at the origin or just behind it may join sheets further back.
            if f.t <= 0.0 {
                return false;
            }
            out.push((f.t, f.t + SURFACE_THICKNESS));
            return true;
        }
        // Another crossing at the same point, or within rounding of it (a vertex or edge the
        // line grazes, its crossings computed from different triangles), leaves it to the
        // general search. Every crossing within `slack` of the first has been found: a box
        // is skipped only where it begins more than `slack` past the nearest crossing.
        let twin = next - f.t <= slack;
        if f.entering && !twin && beyond < f64::INFINITY {
            out.push((f.t, beyond));
            return true;
        }
        false
    }

    /// Whether the sorted crossings `hits`, complete below `frontier`, settle what `need` asks
    /// of the intervals overlapping `(0, t_max)`; if so, appends it to `out`. If not, says
    /// from which frontier on (with no crossing found meanwhile) it could be.
    #[allow(clippy::too_many_arguments)]
    fn settle(
        &self,
        ray: &Ray,
        hits: &mut [Crossing],
        frontier: f64,
        t_max: f64,
        need: Need,
        out: &mut Vec<(f64, f64)>,
    ) -> Settled {
        let known = hits.partition_point(|h| h.t < frontier);
        // The prefix of known crossings grows once the frontier passes the next one.
        let next_hit = hits.get(known).map_or(f64::INFINITY, |h| h.t);
        let done = frontier == f64::INFINITY;
        if !self.closed {
            // Sheets merge while crossings lie within one thickness of the last.
            let mut chain: Option<(f64, f64)> = None;
            for h in &hits[..known] {
                chain = match chain {
                    Some((s, e)) if h.t <= e => Some((s, h.t + SURFACE_THICKNESS)),
                    _ => Some((h.t, h.t + SURFACE_THICKNESS)),
                };
                if need == Need::FirstEntry
                    && let Some((s, e)) = chain
                    && e > 0.0
                {
                    if s < t_max {
                        out.push((s, e));
                    }
                    return Settled::Yes;
                }
            }
            let chain_end = chain.map_or(f64::NEG_INFINITY, |(_, e)| e);
            return match need {
                Need::FirstEntry if frontier >= t_max => Settled::Yes,
                Need::Overlapping if frontier >= t_max && frontier > chain_end => {
                    self.keep_overlapping(ray, &mut hits[..known], t_max, need, out);
                    Settled::Yes
                }
                Need::FirstEntry => Settled::No {
                    recheck: next_hit.min(t_max),
                },
                Need::Overlapping => Settled::No {
                    recheck: next_hit.min(t_max.max(chain_end)),
                },
            };
        }
        let mut depth = 0u32;
        let mut entry = f64::NAN;
        for h in &hits[..known] {
            // An interval open at `entry` and still open past both it and the ray's origin is
            // not empty and overlaps the ray: the first one is the first entry asked for.
            if need == Need::FirstEntry && depth > 0 && h.t > entry && h.t > 0.0 {
                if entry < t_max {
                    out.push((entry, h.t));
                }
                return Settled::Yes;
            }
            if h.entering {
                if depth == 0 {
                    entry = h.t;
                }
                depth += 1;
            } else if depth == 0 {
                return Settled::Unbalanced;
            } else {
                depth -= 1;
            }
        }
        if done && depth > 0 {
            return Settled::Unbalanced;
        }
        match need {
            // Every crossing to come lies past both the open interval's entry and the origin.
            Need::FirstEntry if depth > 0 && frontier > entry && frontier > 0.0 => {
                if entry < t_max {
                    out.push((entry, frontier));
                }
                Settled::Yes
            }
            Need::FirstEntry | Need::Overlapping if depth == 0 && frontier >= t_max => {
                if need == Need::Overlapping {
                    self.keep_overlapping(ray, &mut hits[..known], t_max, need, out);
                }
                Settled::Yes
            }
            Need::FirstEntry if depth > 0 => Settled::No {
                recheck: next_hit.min(entry.max(0.0)),
            },
            _ if depth == 0 => Settled::No {
                recheck: next_hit.min(t_max),
            },
            _ => Settled::No { recheck: next_hit },
        }
    }

    /// Appends what `need` asks of the intervals of the crossings `hits` (all of them up to
    /// some point past `t_max`) that overlap `(0, t_max)`.
    fn keep_overlapping(
        &self,
        ray: &Ray,
        hits: &mut [Crossing],
        t_max: f64,
        need: Need,
        out: &mut Vec<(f64, f64)>,
    ) {
        let start = out.len();
        self.intervals_of(ray, hits, out);
        let mut kept = start;
        for k in start..out.len() {
            let (a, b) = out[k];
            if b > 0.0 && a < t_max && (need == Need::Overlapping || kept == start) {
                out[kept] = (a, b);
                kept += 1;
            }
        }
        out.truncate(kept);
    }

    /// The intervals of `hits` (crossings of `ray`'s line), appended to `out`.
    fn intervals_of(&self, ray: &Ray, hits: &mut [Crossing], out: &mut Vec<(f64, f64)>) {
        if hits.is_empty() {
            return;
        }
        hits.sort_by(crossing_order);
        let start = out.len();
        if !self.closed {
            for h in hits.iter() {
                match out[start..].last_mut() {
                    Some(last) if h.t <= last.1 => last.1 = h.t + SURFACE_THICKNESS,
                    _ => out.push((h.t, h.t + SURFACE_THICKNESS)),
                }
            }
            return;
        }
        let mut depth = 0i32;
        let mut entry = 0.0;
        let mut balanced = true;
        for h in hits.iter() {
            if h.entering {
                if depth == 0 {
                    entry = h.t;
                }
                depth += 1;
            } else {
                depth -= 1;
                if depth == 0 && h.t > entry {
                    match out[start..].last_mut() {
                        Some(last) if entry <= last.1 => last.1 = h.t,
                        _ => out.push((entry, h.t)),
                    }
                }
                balanced &= depth >= 0;
                depth = depth.max(0);
            }
        }
        if balanced && depth == 0 {
            return;
        }
        // A line can never leave more often than it entered, and it ends outside. The
        // watertight test counts a crossing once wherever the line goes *through* the surface;
        // a line lying in the plane of a face and touching the solid only at that face's
        // rim (a corner grazed) may get one crossing of the pair. Then each stretch between
        // two crossings is classified by its midpoint instead (rare, so the extra cost is too).
        out.truncate(start);
        let mut ts: Vec<f64> = hits.iter().map(|h| h.t).collect();
        ts.dedup();
        for w in ts.windows(2) {
            if self.contains(ray.at(0.5 * (w[0] + w[1]))) {
                match out[start..].last_mut() {
                    Some(last) if w[0] <= last.1 => last.1 = w[1],
                    _ => out.push((w[0], w[1])),
                }
            }
        }
    }

    /// Whether `p` is inside the closed mesh (on the boundary counts either way); an open
    /// mesh contains nothing.
    pub fn contains(&self, p: DVec3) -> bool {
        if !self.closed {
            return false;
        }
        // A direction no axis-aligned or diagonal edge of a modelled object lies along.
        let ray = Ray::new(p, DVec3::new(0.577_215_664_9, 0.618_033_988_7, 0.529_918_2));
        let mut hits = Vec::new();
        self.crossings(&ray, &BoxRay::of(&ray), &mut hits);
        let winding: i32 = hits
            .iter()
            .filter(|h| h.t > 0.0)
            .map(|h| if h.entering { -1 } else { 1 })
            .sum();
        winding > 0
    }

    /// The unit normal of the triangle nearest to `p` (outward for a closed mesh).
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        // Nodes farther than the nearest triangle found so far are skipped.
        let best = std::cell::Cell::new((f64::INFINITY, 0usize));
        self.visit(
            |lo, hi| (p.clamp(lo, hi) - p).length_squared() <= best.get().0,
            |k| {
                let [a, b, c] = self.corners_in_order[k];
                let d = (closest_on_triangle(p, a, b, c) - p).length_squared();
                if d < best.get().0 {
                    best.set((d, k));
                }
            },
        );
        let best = best.get();
        let [a, b, c] = self.corners_in_order[best.1];
        (b - a).cross(c - a).try_normalize().unwrap_or(DVec3::Z)
    }

    /// Whether the mesh meets `body` (a box rotated about z): a triangle touches it, or the
    /// body lies inside a closed mesh.
    pub fn overlaps_box(&self, body: &OrientedBox) -> bool {
        let (blo, bhi) = body.aabb();
        let hit = std::cell::Cell::new(false);
        self.visit(
            |lo, hi| !hit.get() && lo.cmple(bhi).all() && hi.cmpge(blo).all(),
            |k| {
                if !hit.get() {
                    let [a, b, c] = self.corners_in_order[k];
                    hit.set(triangle_meets_box(a, b, c, body));
                }
            },
        );
        hit.get() || self.contains(body.center)
    }

    /// The cut of the mesh by the level plane at height `z`: closed polygons in the xy plane
    /// (of a closed mesh; an open one gives open chains too), for drawing what a level scan at
    /// that height meets.
    pub fn section(&self, z: f64) -> Vec<Vec<DVec2>> {
        // Each triangle the plane crosses gives a segment between two of its edges; segments
        // meet at shared edges, so chaining them by edge gives the loops. A vertex exactly at
        // `z` counts as above, so no segment degenerates to a point.
        let above = |v: u32| self.vertices[v as usize].z >= z;
        let cut = |a: u32, b: u32| {
            let (p, q) = (self.vertices[a as usize], self.vertices[b as usize]);
            let t = (z - p.z) / (q.z - p.z);
            (p + (q - p) * t).truncate()
        };
        let key = |a: u32, b: u32| (a.min(b), a.max(b));
        // Ordered, so the loops (and the figures drawn from them) come out the same each run.
        let mut next: std::collections::BTreeMap<(u32, u32), ((u32, u32), DVec2)> =
            std::collections::BTreeMap::new();
        for t in &self.triangles {
            // In winding order, the segment runs from the edge that rises through the plane
            // to the edge that falls through it; a neighbour runs their shared edge the other
            // way, so its segment carries on where this one ends.
            let (mut rise, mut fall) = (None, None);
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                match (above(a), above(b)) {
                    (false, true) => rise = Some(key(a, b)),
                    (true, false) => fall = Some((key(a, b), cut(a, b))),
                    _ => {}
                }
            }
            if let (Some(r), Some(f)) = (rise, fall) {
                next.insert(r, f);
            }
        }
        let mut loops = Vec::new();
        while let Some((&start, _)) = next.first_key_value() {
            let mut poly = Vec::new();
            let mut at = start;
            while let Some((to, p)) = next.remove(&at) {
                poly.push(p);
                at = to;
            }
            if poly.len() >= 3 {
                loops.push(poly);
            }
        }
        loops
    }

    /// The outline in the xy plane: the convex hull of the vertices, for drawing top-down.
    pub fn footprint(&self) -> Vec<DVec2> {
        let mut pts: Vec<DVec2> = self.vertices.iter().map(|v| v.truncate()).collect();
        pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        pts.dedup();
        if pts.len() < 3 {
            return pts;
        }
        // Andrew's monotone chain.
        let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
        let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
        for pass in 0..2 {
            let floor = hull.len();
            let walk = |p: DVec2, hull: &mut Vec<DVec2>| {
                while hull.len() >= floor + 2
                    && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
                {
                    hull.pop();
                }
                hull.push(p);
            };
            if pass == 0 {
                pts.iter().for_each(|&p| walk(p, &mut hull));
            } else {
                pts.iter().rev().for_each(|&p| walk(p, &mut hull));
            }
            hull.pop();
        }
        hull
    }
}

/// Makes the winding of `triangles` consistent across shared edges where it can; returns
/// whether the mesh is closed (every edge shared by exactly two triangles, all wound alike)
/// and how many edges only one triangle uses.
fn orient(triangles: &mut [[u32; 3]]) -> (bool, usize) {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut users: HashMap<(u32, u32), Vec<u32>> = HashMap::with_capacity(triangles.len() * 2);
    for (k, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            users
                .entry(key(t[e], t[(e + 1) % 3]))
                .or_default()
                .push(k as u32);
        }
    }
    let boundary = users.values().filter(|u| u.len() == 1).count();
    let manifold = users.values().all(|u| u.len() == 2);
    // Flood over shared edges, flipping a neighbour that runs the edge the same way.
    let mut seen = vec![false; triangles.len()];
    let mut consistent = true;
    for seed in 0..triangles.len() {
        if seen[seed] {
            continue;
        }
        seen[seed] = true;
        let mut stack = vec![seed];
        while let Some(k) = stack.pop() {
            let t = triangles[k];
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                for &n in &users[&key(a, b)] {
                    let n = n as usize;
                    if n == k {
                        continue;
                    }
                    let same_way = (0..3).any(|f| {
                        let u = triangles[n];
                        u[f] == a && u[(f + 1) % 3] == b
                    });
                    if seen[n] {
                        consistent &= !same_way;
                    } else {
                        seen[n] = true;
                        if same_way {
                            triangles[n].swap(1, 2);
                        }
                        stack.push(n);
                    }
                }
            }
        }
    }
    (manifold && consistent, boundary)
}

/// The point of triangle `abc` nearest to `p` (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Whether triangle `abc` meets the box (separating axes: the box's three axes, the
/// triangle's normal and the nine cross products of their edges; touching counts).
fn triangle_meets_box(a: DVec3, b: DVec3, c: DVec3, body: &OrientedBox) -> bool {
    let (s, co) = body.yaw.sin_cos();
    let axes = [DVec3::new(co, s, 0.0), DVec3::new(-s, co, 0.0), DVec3::Z];
    // The triangle in the box's frame, centred.
    let local = |p: DVec3| {
        let d = p - body.center;
        DVec3::new(d.dot(axes[0]), d.dot(axes[1]), d.dot(axes[2]))
    };
    let v = [local(a), local(b), local(c)];
    let h = body.half;
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separated = |axis: DVec3| {
        if axis.length_squared() < 1e-24 {
            return false;
        }
        let p = v.map(|q| q.dot(axis));
        let r = h.x * axis.x.abs() + h.y * axis.y.abs() + h.z * axis.z.abs();
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    let box_axes = [DVec3::X, DVec3::Y, DVec3::Z];
    if box_axes.iter().any(|&u| separated(u)) {
        return false;
    }
    if separated(edges[0].cross(edges[1])) {
        return false;
    }
    !box_axes
        .iter()
        .any(|&u| edges.iter().any(|&e| separated(u.cross(e))))
}

/// Disjoint sets of `0..n`, with path halving and union by size.
struct UnionFind {
    parent: Vec<usize>,
    size: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
            size: vec![1; n],
        }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a;
        self.size[a] += self.size[b];
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};

    /// An icosphere-like UV sphere: `stacks` × `slices` quads, poles as fans; closed.
    pub(crate) fn uv_sphere(center: DVec3, r: f64, stacks: u32, slices: u32) -> TriMesh {
        let mut v = vec![center + DVec3::Z * r, center - DVec3::Z * r];
        for i in 1..stacks {
            let phi = std::f64::consts::PI * i as f64 / stacks as f64;
            for j in 0..slices {
                let th = std::f64::consts::TAU * j as f64 / slices as f64;
                v.push(
                    center + r * DVec3::new(phi.sin() * th.cos(), phi.sin() * th.sin(), phi.cos()),
                );
            }
        }
        let ring = |i: u32, j: u32| 2 + (i - 1) * slices + j % slices;
        let mut t = Vec::new();
        for j in 0..slices {
            t.push([0, ring(1, j), ring(1, j + 1)]);
            t.push([1, ring(stacks - 1, j + 1), ring(stacks - 1, j)]);
            for i in 1..stacks - 1 {
                t.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
                t.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
            }
        }
        TriMesh::new(v, t).expect("a sphere mesh")
    }

    /// A unit cube of corners `lo..hi` as 12 triangles, wound as `flip` says.
    pub(crate) fn cube(lo: DVec3, hi: DVec3, flip: bool) -> TriMesh {
        let v: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut t = Vec::new();
        for q in quads {
            let (a, b) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
            t.push(if flip { [a[0], a[2], a[1]] } else { a });
            t.push(if flip { [b[0], b[2], b[1]] } else { b });
        }
        TriMesh::new(v, t).expect("a cube")
    }

    /// A random ray's origin and direction, `snap` 1 putting the origin on the integer lattice
    /// (through cube vertices, in their faces' planes), 2 the direction along x.
    fn snapped(o: [f64; 3], d: [f64; 3], snap: usize) -> (DVec3, DVec3) {
        let origin = DVec3::from(o);
        let dir = DVec3::from(d);
        match snap {
            1 => (origin.round(), dir),
            2 => (origin, DVec3::X * dir.x.signum()),
            _ => (origin, dir),
        }
    }

    fn intervals(m: &TriMesh, ray: &Ray) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        m.ray_intervals(ray, &mut out);
        out
    }

    #[test]
    fn a_closed_mesh_comes_apart_where_its_shells_lie_apart_and_only_there() {
        let join = |parts: &[TriMesh]| {
            let (mut v, mut t) = (Vec::new(), Vec::new());
            for m in parts {
                let base = v.len() as u32;
                v.extend_from_slice(m.vertices());
                t.extend(m.triangles().iter().map(|x| x.map(|i| i + base)));
            }
            TriMesh::new(v, t).expect("a mesh")
        };
        let a = cube(DVec3::ZERO, DVec3::ONE, false);
        let far = cube(DVec3::splat(5.0), DVec3::splat(6.0), true);
        let inner = uv_sphere(DVec3::splat(0.5), 0.3, 5, 8);
        // Face to face with `a`, sharing no vertex.
        let touching = cube(DVec3::new(1.0, 0.2, 0.2), DVec3::new(2.0, 0.8, 0.8), false);
        let counts = |m: TriMesh| {
            let (total, closed) = (m.triangle_count(), m.is_closed());
            let pieces = m.into_apart();
            assert!(pieces.iter().all(|p| p.is_closed() == closed));
            assert_eq!(
                pieces.iter().map(TriMesh::triangle_count).sum::<usize>(),
                total
            );
            pieces.len()
        };
        assert_eq!(counts(join(&[a.clone(), far.clone()])), 2);
        // A shell inside another is one volume with it (a cavity, or a nested part).
        assert_eq!(counts(join(&[a.clone(), inner.clone(), far.clone()])), 2);
        // Boxes that touch stay together; a single shell is whole.
        assert_eq!(counts(join(&[a.clone(), touching])), 1);
        assert_eq!(counts(a.clone()), 1);
        // An open mesh is never cut.
        let sheet = TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::splat(9.0),
                DVec3::new(10.0, 9.0, 9.0),
                DVec3::new(9.0, 10.0, 9.0),
            ],
            vec![[0, 1, 2], [3, 4, 5]],
        )
        .expect("two sheets");
        assert_eq!(counts(sheet), 1);
    }

    #[test]
    fn a_cube_is_closed_whichever_way_it_is_wound_and_gives_its_chord() {
        for flip in [false, true] {
            let c = cube(DVec3::ZERO, DVec3::ONE, flip);
            assert!(c.is_closed() && c.boundary_edges() == 0);
            let ray = Ray::new(DVec3::new(-1.0, 0.3, 0.4), DVec3::X);
            assert_eq!(intervals(&c, &ray), vec![(1.0, 2.0)]);
            // Through an edge and along a face diagonal: still one entry and one exit.
            let diag = Ray::new(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 1.0));
            let iv = intervals(&c, &diag);
            assert!(iv.len() <= 1, "{iv:?}");
            let corner = Ray::new(DVec3::splat(-1.0), DVec3::ONE);
            let iv = intervals(&c, &corner);
            assert_eq!(iv.len(), 1, "{iv:?}");
            let s3 = 3f64.sqrt();
            assert!((iv[0].0 - s3).abs() < 1e-12 && (iv[0].1 - 2.0 * s3).abs() < 1e-12);
            assert!(c.contains(DVec3::splat(0.5)) && !c.contains(DVec3::splat(1.5)));
            let n = c.normal_at(DVec3::new(1.0, 0.5, 0.5));
            assert!((n - DVec3::X).length() < 1e-12, "outward {n}");
        }
    }

    #[test]
    fn a_section_of_a_sphere_is_one_loop_on_its_circle() {
        let (c, r) = (DVec3::new(2.0, -1.0, 1.0), 1.0);
        let m = uv_sphere(c, r, 32, 64);
        let loops = m.section(1.4);
        assert_eq!(loops.len(), 1);
        let want = (r * r - 0.4f64 * 0.4).sqrt();
        for p in &loops[0] {
            let d = p.distance(c.truncate());
            assert!(d <= want + 1e-9 && d > want * 0.99, "{d} vs {want}");
        }
        assert!(loops[0].len() >= 64);
        assert!(m.section(2.5).is_empty());
        // Figures drawn from it are the same each run.
        assert_eq!(m.section(1.4), loops);
        let two = two_cubes();
        assert_eq!(two.section(0.5), two.section(0.5));
    }

    #[test]
    fn an_open_mesh_is_a_thin_sheet_and_a_bad_one_is_refused() {
        // One square, two triangles: open.
        let v = vec![
            DVec3::new(2.0, -1.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(2.0, 1.0, 2.0),
            DVec3::new(2.0, -1.0, 2.0),
        ];
        let m = TriMesh::new(v.clone(), vec![[0, 1, 2], [0, 2, 3]]).expect("mesh");
        assert!(!m.is_closed());
        assert_eq!(m.boundary_edges(), 4);
        let ray = Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::X);
        assert_eq!(intervals(&m, &ray), vec![(2.0, 2.0 + SURFACE_THICKNESS)]);
        assert!(!m.contains(DVec3::new(2.0, 0.0, 1.0)));
        assert_eq!(
            TriMesh::new(v.clone(), vec![[0, 1, 9]]),
            Err(MeshError::BadIndex {
                triangle: 0,
                index: 9,
                vertices: 4
            })
        );
        assert_eq!(
            TriMesh::new(v.clone(), vec![[0, 0, 1]]),
            Err(MeshError::Empty)
        );
        let mut bad = v;
        bad[2].y = f64::NAN;
        assert_eq!(
            TriMesh::new(bad, vec![[0, 1, 2]]),
            Err(MeshError::NotFinite(2))
        );
    }

    #[test]
    fn a_fine_sphere_mesh_gives_the_analytic_chord_within_its_tessellation() {
        let (c, r) = (DVec3::new(1.0, 2.0, 1.5), 1.0);
        let m = uv_sphere(c, r, 64, 128);
        assert!(m.is_closed());
        // The mesh lies between the sphere and its inscribed polyhedron: chord ends within
        // r (1 − cos(π/64)) ≈ 1.2 mm of the analytic ones, for rays well inside the rim.
        let tol = r * (1.0 - (std::f64::consts::PI / 64.0).cos()) * 2.0;
        for k in 0..200 {
            let a = k as f64 * 0.731;
            let off = DVec3::new(0.0, 0.8 * (a * 1.3).sin(), 0.8 * (a * 0.7).cos()) * 0.9;
            let dir = DVec3::new(1.0, 0.1 * a.sin(), 0.05 * a.cos()).normalize();
            let ray = Ray::new(c + off - dir * 5.0, dir);
            let exact = super::super::shape::sphere_interval(c, r, &ray);
            let ours = intervals(&m, &ray);
            match exact {
                Some((t0, t1)) if t1 - t0 > 0.2 => {
                    assert_eq!(ours.len(), 1, "ray {k}: {ours:?}");
                    let chord = (t0, t1);
                    // Along the ray the radial error grows by 1/cos of the incidence.
                    let scale = 2.0 * r / (t1 - t0);
                    assert!((ours[0].0 - chord.0).abs() < tol * scale * 2.0, "{k}");
                    assert!((ours[0].1 - chord.1).abs() < tol * scale * 2.0, "{k}");
                }
                _ => {}
            }
        }
    }

    /// The hints point at what a search reads first: the mesh itself, and its root's node
    /// (or, for a mesh of one leaf, its triangles).
    #[test]
    fn a_search_start_points_at_the_mesh_and_its_root() {
        let sphere = uv_sphere(DVec3::ZERO, 1.0, 12, 24);
        let start = SearchStart::of(&sphere);
        assert_eq!(start.mesh, std::ptr::from_ref(&sphere) as usize);
        assert_eq!(sphere.root.count, 0);
        let node = &sphere.nodes[sphere.root.link as usize];
        assert_eq!(
            start.root,
            (std::ptr::from_ref(node) as usize, size_of::<Node>())
        );
        let tetrahedron = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .expect("a tetrahedron");
        let start = SearchStart::of(&tetrahedron);
        assert_eq!(tetrahedron.root.count, 4);
        let first = &tetrahedron.corners_in_order[tetrahedron.root.link as usize];
        let bytes = 4 * size_of::<[DVec3; 3]>();
        assert_eq!(start.root, (std::ptr::from_ref(first) as usize, bytes));
        assert_eq!(SearchStart::default().mesh, 0);
        // A hint at nothing, or at a mesh, changes nothing.
        SearchStart::default().prefetch();
        start.prefetch();
    }

    /// Triangles the surface area heuristic cannot cut (every centre at one point) and one it
    /// would cut off alone at every level: the hierarchy falls back to median splits, stays
    /// within its search stack, and a ray finds every sheet.
    #[test]
    fn a_hierarchy_of_triangles_no_cut_separates_is_still_searched_whole() {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for k in 0..3000u32 {
            // Turned copies of one triangle about the x axis through (1, 0, 0): same centre.
            let a = f64::from(k) * 0.001;
            let (s, c) = a.sin_cos();
            let p = |y: f64, z: f64| DVec3::new(1.0, y * c - z * s, y * s + z * c);
            v.extend([p(-0.3, -0.2), p(0.3, -0.2), p(0.0, 0.4)]);
            t.push([3 * k, 3 * k + 1, 3 * k + 2]);
        }
        for k in 0..40u32 {
            let x = 2.0 + 10f64.powi(k as i32 % 12);
            let n = v.len() as u32;
            v.extend([
                DVec3::new(x, -0.3, -0.2),
                DVec3::new(x, 0.3, -0.2),
                DVec3::new(x, 0.0, 0.4),
            ]);
            t.push([n, n + 1, n + 2]);
        }
        let m = TriMesh::new(v, t).expect("a mesh");
        let ray = Ray::new(DVec3::new(0.0, 0.0, 0.01), DVec3::X);
        let whole = intervals(&m, &ray);
        // All coincident sheets merge into one at x = 1; the far ones each make their own.
        assert_eq!(whole.len(), 1 + 12, "{whole:?}");
        let mut found = Vec::new();
        m.intervals_until(
            &ray,
            &BoxRay::of(&ray),
            f64::INFINITY,
            Need::Overlapping,
            &mut found,
        );
        assert_eq!(found, whole);
    }

    /// The brute-force reference: the winding number of the half-line from the point out
    /// along a second direction (exits count +1, entries −1), over every triangle with a
    /// plain (not watertight) test; overlapping closed parts make one volume.
    fn brute_inside(m: &TriMesh, p: DVec3) -> bool {
        let dir = DVec3::new(0.31, -0.87, 0.38).normalize();
        let mut n = 0;
        for k in 0..m.triangle_count() {
            let [a, b, c] = m.corners(k);
            // Möller–Trumbore.
            let (e1, e2) = (b - a, c - a);
            let pv = dir.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-14 {
                continue;
            }
            let tv = p - a;
            let u = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let v = dir.dot(qv) / det;
            let t = e2.dot(qv) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
                n += if dir.dot(e1.cross(e2)) > 0.0 { 1 } else { -1 };
            }
        }
        n > 0
    }

    fn two_cubes() -> TriMesh {
        // Two cubes and a coarse sphere overlapping one of them, as one mesh.
        let parts = [
            cube(DVec3::ZERO, DVec3::ONE, false),
            cube(DVec3::new(2.0, 0.0, 0.0), DVec3::new(3.0, 2.0, 1.0), true),
            uv_sphere(DVec3::new(0.5, 1.2, 0.5), 0.6, 6, 9),
        ];
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for m in &parts {
            let base = v.len() as u32;
            v.extend_from_slice(m.vertices());
            t.extend(m.triangles().iter().map(|x| x.map(|i| i + base)));
        }
        TriMesh::new(v, t).expect("mesh")
    }

    proptest! {
        /// Inside and outside along random rays (their origins inside objects too): a point
        /// well inside an interval is inside by a brute-force winding number, a point well outside
        /// every interval is outside; the intervals are sorted and disjoint.
        #[test]
        fn intervals_agree_with_brute_force_parity(
            o in prop::array::uniform3(-1.0..4.0f64),
            d in prop::array::uniform3(-1.0..1.0f64),
            snap in 0usize..3,
        ) {
            let m = two_cubes();
            prop_assume!(DVec3::from(d).length() > 0.1);
            let mut origin = DVec3::from(o);
            // Some rays through vertices and along edges' planes.
            if snap == 1 {
                origin = origin.round();
            }
            let ray = Ray::new(origin, DVec3::from(d));
            let iv = intervals(&m, &ray);
            for w in iv.windows(2) {
                prop_assert!(w[0].1 < w[1].0, "{:?}", iv);
            }
            for k in 0..120 {
                let t = -6.0 + k as f64 * 0.1 + 0.0137;
                let near = iv.iter().any(|&(a, b)| (t - a).abs() < 1e-6 || (t - b).abs() < 1e-6);
                let p = ray.at(t);
                // On (or within rounding of) the surface, inside and outside are both right.
                let on_surface = (0..m.triangle_count()).any(|k| {
                    let [a, b, c] = m.corners(k);
                    closest_on_triangle(p, a, b, c).distance(p) < 1e-6
                });
                if near || on_surface {
                    continue;
                }
                let inside = iv.iter().any(|&(a, b)| t > a && t < b);
                prop_assert_eq!(inside, brute_inside(&m, p), "t {} p {}", t, p);
                prop_assert_eq!(inside, m.contains(p), "contains at t {}", t);
            }
        }

        /// A closed mesh's pieces apart ([`TriMesh::into_apart`]) give together the whole's
        /// intervals on every line (rays through vertices and along faces' planes too): two
        /// cubes (one wound inward in the file) and a sphere overlapping one of them make two
        /// pieces.
        #[test]
        fn the_pieces_apart_give_the_wholes_intervals(
            o in prop::array::uniform3(-1.0..4.0f64),
            d in prop::array::uniform3(-1.0..1.0f64),
            snap in 0usize..3,
        ) {
            let whole = two_cubes();
            let pieces = whole.clone().into_apart();
            prop_assert_eq!(pieces.len(), 2);
            prop_assume!(DVec3::from(d).length() > 0.1);
            let (origin, dir) = snapped(o, d, snap);
            let ray = Ray::new(origin, dir);
            let mut apart: Vec<(f64, f64)> = pieces.iter().flat_map(|p| intervals(p, &ray)).collect();
            apart.sort_by(|a, b| a.0.total_cmp(&b.0));
            prop_assert_eq!(apart, intervals(&whole, &ray), "{:?}", ray);
        }

        /// A ray that the mesh's [`Reach`] turns away has no interval overlapping `(0, t_max)`, from
        /// anywhere (inside the bounds too), for open and closed meshes; and the single-precision
        /// node bounds hold every vertex of their triangles.
        #[test]
        fn may_meet_never_turns_away_an_interval(
            o in prop::array::uniform3(-1.0..4.0f64),
            d in prop::array::uniform3(-1.0..1.0f64),
            // Negative: a first-hit query that found an interval begun behind the origin.
            t_max in prop_oneof![0.0..0.3f64, 0.0..6.0f64, -0.3..0.0f64, -3.0..0.0f64],
            snap in 0usize..3,
            open in proptest::bool::ANY,
        ) {
            let m = if open {
                let v = vec![DVec3::new(0.5, 0.5, 0.5), DVec3::new(2.5, 0.5, 0.7), DVec3::new(1.0, 2.5, 1.9)];
                TriMesh::new(v, vec![[0, 1, 2]]).expect("a sheet")
            } else {
                two_cubes()
            };
            prop_assume!(DVec3::from(d).length() > 0.1);
            let (origin, dir) = snapped(o, d, snap);
            let ray = Ray::new(origin, dir);
            if !Reach::of(m.aabb()).may_meet(&BoxRay::of(&ray), t_max) {
                let iv = intervals(&m, &ray);
                // What `World::object_intervals` keeps.
                prop_assert!(
                    !iv.iter().any(|&(a, b)| b > 0.0 && a < t_max),
                    "{:?} turned away, intervals {:?}", ray, iv
                );
            }
            let leaves = (m.nodes.iter())
                .flat_map(|n| (0..WIDTH).filter_map(|j| n.child(j)))
                .chain([m.root]);
            for (i, c) in leaves.filter(|c| c.count > 0).enumerate() {
                for k in c.link..c.link + c.count {
                    for v in m.corners_in_order[k as usize] {
                        prop_assert!(v.cmpge(c.lo()).all() && v.cmple(c.hi()).all(), "leaf {}", i);
                    }
                }
            }
        }

        /// The search that stops once the answer is settled gives what the whole line's
        /// intervals give: every interval overlapping `(0, t_max)` with its exact ends, or the
        /// first one's entry. Closed unions of overlapping shells (a grown bush, cubes and a
        /// sphere), an open sheet; rays from inside and outside the mesh and its bounds, through
        /// vertices and along faces' planes; `t_max` from below zero to infinity. Open meshes
        /// of many triangles too (a bush with faces taken out, a soup of loose leaves), whose
        /// search from inside their bounds skips what lies behind the origin, with rays that
        /// pass a triangle at, just before or just behind the origin (`near`).
        #[test]
        fn a_search_stopped_when_settled_gives_the_whole_lines_intervals(
            kind in 0usize..5,
            seed in 0u64..50,
            o in prop::array::uniform3(-1.0..4.0f64),
            d in prop::array::uniform3(-1.0..1.0f64),
            snap in 0usize..3,
            back in prop_oneof![Just(0.0), 3.0..8.0f64],
            t_max in prop_oneof![-0.5..0.5f64, 0.0..6.0f64, Just(f64::INFINITY)],
            near in prop_oneof![
                Just(None),
                prop::sample::select(vec![0.0, 1e-7, -1e-7, 1.5e-6, -1.5e-6, -3e-6, -5e-6, 2e-9])
                    .prop_map(Some),
            ],
        ) {
            let m = match kind {
                0 => two_cubes(),
                1 => {
                    let part = super::super::procedural::grow(
                        super::super::procedural::Plant::Bush, 2.5, seed);
                    let v = part[0].vertices.iter().map(|v| *v + DVec3::new(1.5, 1.5, 0.0)).collect();
                    TriMesh::new(v, part[0].triangles.clone()).expect("a bush")
                }
                2 => {
                    let v = vec![
                        DVec3::new(0.5, 0.5, 0.5), DVec3::new(2.5, 0.5, 0.7),
                        DVec3::new(1.0, 2.5, 1.9), DVec3::new(2.0, 2.0, 0.2),
                    ];
                    TriMesh::new(v, vec![[0, 1, 2], [1, 3, 2]]).expect("a sheet")
                }
                3 => {
                    let part = super::super::procedural::grow(
                        super::super::procedural::Plant::Bush, 2.5, seed);
                    let v = part[0].vertices.iter().map(|v| *v + DVec3::new(1.5, 1.5, 0.0)).collect();
                    let t = (part[0].triangles.iter().enumerate())
                        .filter(|(k, _)| k % 7 != 3)
                        .map(|(_, t)| *t)
                        .collect();
                    let m = TriMesh::new(v, t).expect("a bush with holes");
                    prop_assert!(!m.is_closed());
                    m
                }
                _ => {
                    // Loose leaves: 300 triangles of 10-30 cm in a 3 m cube.
                    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                    let mut v = Vec::new();
                    for _ in 0..300 {
                        let c = DVec3::new(rng.random(), rng.random(), rng.random()) * 3.0;
                        for _ in 0..3 {
                            let e = DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
                            v.push(c + e * rng.random_range(0.2..0.6));
                        }
                    }
                    let t = (0..300u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
                    TriMesh::new(v, t).expect("a soup")
                }
            };
            prop_assume!(DVec3::from(d).length() > 0.1);
            let (mut origin, dir) = snapped(o, d, snap);
            // Stepped back along the ray, the origin is mostly outside the mesh's bounds (the
            // search of a mesh wholly ahead); as drawn, mostly inside them.
            origin -= dir.normalize() * back;
            // Or placed `offset` before a triangle's centroid along the ray.
            if let Some(offset) = near {
                let k = seed as usize % m.triangle_count();
                let [a, b, c] = m.corners(k);
                origin = (a + b + c) / 3.0 - dir.normalize() * offset;
            }
            let ray = Ray::new(origin, dir);
            let whole: Vec<(f64, f64)> = intervals(&m, &ray)
                .into_iter()
                .filter(|&(a, b)| b > 0.0 && a < t_max)
                .collect();
            let mut all = Vec::new();
            m.intervals_until(&ray, &BoxRay::of(&ray), t_max, Need::Overlapping, &mut all);
            prop_assert_eq!(&all, &whole, "{:?} t_max {}", ray, t_max);
            let mut first = Vec::new();
            m.intervals_until(&ray, &BoxRay::of(&ray), t_max, Need::FirstEntry, &mut first);
            prop_assert_eq!(first.len(), whole.len().min(1), "{:?} t_max {}", ray, t_max);
            if let (Some(f), Some(w)) = (first.first(), whole.first()) {
                prop_assert_eq!(f.0, w.0, "{:?} t_max {}", ray, t_max);
                // The second end is a point inside the interval.
                prop_assert!(f.1 > f.0.max(0.0) && f.1 <= w.1, "{:?} in {:?}", f, w);
            }
        }

        /// A triangle meets a box exactly when sampled points say so, away from touching.
        #[test]
        fn triangle_box_test_agrees_with_parry(
            a in prop::array::uniform3(-2.0..2.0f64),
            b in prop::array::uniform3(-2.0..2.0f64),
            c in prop::array::uniform3(-2.0..2.0f64),
            yaw in -3.2..3.2f64,
        ) {
            use parry3d_f64::math::Pose as PPose;
            use parry3d_f64::query::intersection_test;
            use parry3d_f64::shape::{Cuboid, Triangle};
            let body = OrientedBox::new(DVec3::new(0.2, -0.1, 0.3), DVec3::new(1.0, 0.6, 0.5), yaw);
            let (a, b, c) = (DVec3::from(a), DVec3::from(b), DVec3::from(c));
            prop_assume!((b - a).cross(c - a).length() > 1e-3);
            let ours = triangle_meets_box(a, b, c, &body);
            let pose = PPose::new(body.center, DVec3::new(0.0, 0.0, yaw));
            let identity = PPose::new(DVec3::ZERO, DVec3::ZERO);
            let theirs = intersection_test(&pose, &Cuboid::new(body.half), &identity, &Triangle::new(a, b, c))
                .expect("supported")
                .intersecting;
            prop_assert_eq!(ours, theirs);
        }

        /// The box tests in single precision never miss a box the line meets nor put its
        /// entry past the exact one: boxes near and far from the origin (up to 5 km out),
        /// lines through their corners and faces, near parallel and parallel to the axes. The
        /// SSE node test gives the scalar one's result to the bit, and the single-precision
        /// reach test passes every ray the full one passes, for any stretch.
        #[test]
        fn single_precision_box_tests_are_conservative(
            origin in prop::array::uniform3(-5e3..5e3f64),
            boxes in prop::collection::vec(
                (prop::array::uniform3(-50.0..50.0f64), prop::array::uniform3(1e-3..20.0f64)),
                1..=WIDTH,
            ),
            target in 0..WIDTH,
            corner in prop::array::uniform3(0..3u8),
            tilt in prop::array::uniform3(prop_oneof![
                Just(0.0),
                Just(1e-12),
                -1.0..1.0f64,
            ]),
            behind in -30.0..30.0f64,
            flat in 0..5usize,
            t_max in prop_oneof![0.0..1.0f64, -40.0..40.0f64, Just(f64::INFINITY)],
            same in any::<bool>(),
        ) {
            let origin = DVec3::from(origin);
            // Boxes about a point near the origin; the line aims at a corner, edge midpoint or
            // face of one of them (`corner`: 0 low, 1 middle, 2 high per axis).
            let children: Vec<Child> = (boxes.iter())
                .map(|&(c, h)| {
                    let (lo, hi) = (origin + DVec3::from(c), origin + DVec3::from(c) + DVec3::from(h));
                    let [lx, ly, lz] = lo.to_array().map(f32_down);
                    let [hx, hy, hz] = hi.to_array().map(f32_up);
                    Child { bounds: [lx, ly, lz, hx, hy, hz], link: 0, count: 1 }
                })
                .collect();
            let aim = children[target % children.len()];
            let at = DVec3::from(std::array::from_fn(|a| match corner[a] {
                0 => f64::from(aim.bounds[a]),
                1 => 0.5 * (f64::from(aim.bounds[a]) + f64::from(aim.bounds[a + 3])),
                _ => f64::from(aim.bounds[a + 3]),
            }));
            let mut dir = at - origin + DVec3::from(tilt);
            if flat < 3 {
                dir[flat] = 0.0; // parallel to an axis (a level scan: z)
            }
            let dir = dir.try_normalize();
            prop_assume!(dir.is_some());
            let dir = dir.unwrap_or(DVec3::X);
            let ray = Ray { origin: at - behind * dir, dir };
            let box_ray = BoxRay::of(&ray);
            prop_assume!(box_ray.single.is_some());
            let node = Node::of(&children);
            let exact = node.entries(&box_ray, false, f64::NEG_INFINITY);
            let single = node.entries(&box_ray, true, f64::NEG_INFINITY);
            // The sorting network orders the boxes met as the insertion sort does (child
            // order among equal entries: `same` repeats the first box).
            let (met, n) = node.farthest_first(&box_ray, true, f64::NEG_INFINITY);
            let (want, m) = farthest_first(single);
            prop_assert_eq!(&met[..n], &want[..m]);
            if same {
                let twins = Node::of(&[children[0], children[0], children[0]]);
                let (met, n) = twins.farthest_first(&box_ray, true, f64::NEG_INFINITY);
                let (want, m) = farthest_first(twins.entries(&box_ray, true, f64::NEG_INFINITY));
                prop_assert_eq!(&met[..n], &want[..m]);
            }
            if let Some(s) = &box_ray.single {
                // The SSE form is the scalar one, to the bit.
                prop_assert_eq!(single, node.entries_single_scalar(s, f64::NEG_INFINITY));
            }
            // Cut at `from` (here `t_max`'s values): the exact test drops just the boxes the
            // line leaves before it, the single-precision one keeps every box the exact one
            // keeps, in SSE as in scalar form, and orders them as the reference sort does.
            let from = t_max;
            let exact_cut = node.entries(&box_ray, false, from);
            let single_cut = node.entries(&box_ray, true, from);
            let whole = (f64::NEG_INFINITY, f64::INFINITY);
            for (j, c) in children.iter().enumerate() {
                let leaves = box_ray.stretch_in(c.lo(), c.hi(), whole).map(|(_, t1)| t1);
                prop_assert_eq!(exact_cut[j].is_some(), leaves.is_some_and(|t1| t1 >= from));
                prop_assert!(exact_cut[j].is_none() || single_cut[j].is_some(), "{:?}", c);
            }
            if let Some(s) = &box_ray.single {
                prop_assert_eq!(single_cut, node.entries_single_scalar(s, from));
            }
            let (met, n) = node.farthest_first(&box_ray, true, from);
            let (want, m) = farthest_first(single_cut);
            prop_assert_eq!(&met[..n], &want[..m]);
            for c in &children {
                // The single-precision reach test passes every ray the full one passes.
                let reach = Reach::of((c.lo(), c.hi()));
                if reach.may_meet(&box_ray, t_max) {
                    let stretch = box_ray.single_stretch(t_max);
                    prop_assert!(box_ray.may_meet_single(&reach.single(), &stretch), "{:?}", c);
                }
            }
            // Four parts' reaches at once give each part's answer (an unbounded reach, as a
            // part that is not a mesh has, among them when `same`), for stretches that end
            // before, inside and past the boxes, and for every stretch.
            let mut reaches: Vec<(u32, SingleReach)> = (children.iter().enumerate())
                .map(|(j, c)| (10 + j as u32, Reach::of((c.lo(), c.hi())).single()))
                .collect();
            if same {
                reaches[0].1 = SingleReach::UNBOUNDED;
            }
            let group = ReachGroup::of(&reaches);
            for stretch in [
                box_ray.single_stretch(t_max),
                box_ray.single_stretch(0.5 * behind.abs()),
                SingleStretch::default(),
            ] {
                let met = box_ray.may_meet_group(&group, &stretch);
                prop_assert_eq!(met >> reaches.len(), 0);
                for (j, (part, reach)) in reaches.iter().enumerate() {
                    prop_assert_eq!(group.part(j), *part);
                    let one = box_ray.may_meet_single(reach, &stretch);
                    prop_assert_eq!(met >> j & 1 == 1, one, "lane {} of {:?}", j, stretch);
                }
            }
            for j in 0..children.len() {
                prop_assert_eq!(exact[j], box_ray.line_entry(children[j].lo(), children[j].hi()));
                if let Some(t) = exact[j] {
                    prop_assert!(single[j].is_some_and(|s| s <= t), "box {} exact {} single {:?}", j, t, single[j]);
                }
            }
        }
    }
}
