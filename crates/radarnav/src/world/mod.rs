//! The 3D world: objects (shape + material) and the ray query every sensor is built on.

pub mod forest;
pub mod material;
pub mod overlap;
pub mod shape;

pub use material::{Band, Material, MaterialId, MaterialTable, builtin_materials};
pub use shape::{OrientedBox, Ray, Shape, ShapeError};

use glam::DVec3;
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
use parry3d_f64::query::Ray as ParryRay;

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
}

/// Reusable buffers for [`World::ray_intervals`], so that casting many rays allocates nothing.
#[derive(Clone, Debug, Default)]
pub struct RayQuery {
    spans: Vec<(f64, f64)>,
    intervals: Vec<Interval>,
}

/// Objects, their materials and a bounding-volume hierarchy over them.
#[derive(Clone)]
pub struct World {
    materials: MaterialTable,
    objects: Vec<Object>,
    bvh: Bvh,
    /// Per object, bit `band_bit(b)` set when its material is solid to band `b`.
    solid: Vec<u8>,
    ground: MaterialId,
}

fn band_bit(band: Band) -> u8 {
    match band {
        Band::Radar => 1,
        Band::Laser => 2,
        Band::Surface => 4,
    }
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
        let aabbs: Vec<Aabb> = objects
            .iter()
            .map(|o| {
                let (lo, hi) = o.shape.aabb();
                Aabb::new(lo, hi)
            })
            .collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
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
        let ground = materials.id("ground").expect("built-ins are never removed");
        Self {
            materials,
            objects,
            bvh,
            solid,
            ground,
        }
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
            self.objects.iter().map(|o| o.shape.aabb()).fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
            )
        })
    }

    /// Every interval where `ray` is inside an object and that overlaps `(0, t_max)`, sorted by
    /// entry distance. Only objects whose bounding boxes the ray meets within `t_max` are tested.
    pub fn ray_intervals<'q>(&self, ray: &Ray, t_max: f64, q: &'q mut RayQuery) -> &'q [Interval] {
        self.gather(ray, t_max, 0, q)
    }

    /// Like [`World::ray_intervals`], but without the intervals that begin beyond the nearest
    /// entry into a material solid to `band`: no ray of that band gets past it, so the
    /// traversal skips every subtree behind it. The walk of a sensor ray over these intervals
    /// ends exactly where it would over all of them.
    pub fn ray_intervals_to_solid<'q>(
        &self,
        ray: &Ray,
        t_max: f64,
        band: Band,
        q: &'q mut RayQuery,
    ) -> &'q [Interval] {
        self.gather(ray, t_max, band_bit(band), q)
    }

    /// The BVH query behind both public ones; `stop_bits` selects which solids bound the search
    /// (0: none).
    fn gather<'q>(
        &self,
        ray: &Ray,
        t_max: f64,
        stop_bits: u8,
        q: &'q mut RayQuery,
    ) -> &'q [Interval] {
        q.intervals.clear();
        let pray = ParryRay::new(ray.origin, ray.dir);
        let bound = std::cell::Cell::new(t_max);
        for leaf in self
            .bvh
            .leaves(|node| node.cast_ray(&pray, bound.get()) <= bound.get())
        {
            let start = q.intervals.len();
            self.push_object(leaf, ray, bound.get(), &mut q.spans, &mut q.intervals);
            if self.solid[leaf as usize] & stop_bits != 0 {
                for iv in &q.intervals[start..] {
                    bound.set(bound.get().min(iv.t_in.max(0.0)));
                }
            }
        }
        // Intervals gathered before the bound tightened are dropped too, so the result does
        // not depend on the traversal order.
        let bound = bound.get();
        if bound < t_max {
            q.intervals.retain(|iv| iv.t_in.max(0.0) <= bound);
        }
        sort_intervals(&mut q.intervals);
        &q.intervals
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
        for i in 0..self.objects.len() {
            self.push_object(i as u32, ray, t_max, &mut q.spans, &mut q.intervals);
        }
        sort_intervals(&mut q.intervals);
        &q.intervals
    }

    fn push_object(
        &self,
        index: u32,
        ray: &Ray,
        t_max: f64,
        spans: &mut Vec<(f64, f64)>,
        out: &mut Vec<Interval>,
    ) {
        let obj = &self.objects[index as usize];
        spans.clear();
        obj.shape.ray_intervals(ray, spans);
        out.extend(
            spans
                .iter()
                .filter(|(t_in, t_out)| *t_out > 0.0 && *t_in < t_max)
                .map(|&(t_in, t_out)| Interval {
                    t_in,
                    t_out,
                    object: index,
                    material: obj.material,
                }),
        );
    }

    /// The first object (lowest index) that a robot cannot drive through and that overlaps
    /// `body`; traversable materials (smoke, dust, the ground) never block.
    pub fn blocking_object(&self, body: &OrientedBox) -> Option<usize> {
        let (lo, hi) = body.aabb();
        self.bvh
            .leaves(move |node| node.mins().cmple(hi).all() && lo.cmple(node.maxs()).all())
            .map(|i| i as usize)
            .filter(|&i| {
                let o = &self.objects[i];
                !self.materials.get(o.material).traversable && o.shape.overlaps_box(body)
            })
            .min()
    }

    /// Indices of the objects containing point `p`.
    pub fn objects_at(&self, p: DVec3) -> impl Iterator<Item = usize> + '_ {
        self.bvh
            .leaves(move |node| node.mins().cmple(p).all() && p.cmple(node.maxs()).all())
            .map(|i| i as usize)
            .filter(move |&i| self.objects[i].shape.contains(p))
    }
}

fn sort_intervals(out: &mut [Interval]) {
    out.sort_by(|a, b| {
        a.t_in
            .total_cmp(&b.t_in)
            .then(a.object.cmp(&b.object))
            .then(a.t_out.total_cmp(&b.t_out))
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use proptest::prelude::*;

    fn arb_shape() -> impl Strategy<Value = Shape> {
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

    fn arb_ray() -> impl Strategy<Value = Ray> {
        (
            (-10.0..10.0f64, -10.0..10.0f64, 0.0..3.0f64),
            (-1.0..1.0f64, -1.0..1.0f64, -0.3..0.3f64),
        )
            .prop_filter_map("non-zero direction", |((x, y, z), (dx, dy, dz))| {
                let d = DVec3::new(dx, dy, dz);
                (d.length() > 1e-3).then(|| Ray::new(DVec3::new(x, y, z), d))
            })
    }

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
        fn bvh_query_equals_exhaustive(shapes in prop::collection::vec(arb_shape(), 1..40),
                                        rays in prop::collection::vec(arb_ray(), 1..20),
                                        t_max in 1.0..30.0f64) {
            let world = world_of(shapes);
            let (mut a, mut b) = (RayQuery::default(), RayQuery::default());
            for ray in rays {
                let fast = world.ray_intervals(&ray, t_max, &mut a);
                let slow = world.ray_intervals_exhaustive(&ray, t_max, &mut b);
                prop_assert_eq!(fast, slow);
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
