//! Exact overlap of a shape with a box rotated about z: the vehicle's body against the world.
//!
//! Every analytic shape of the world is a vertical extrusion or a ball, and the body is a
//! z-yawed box, so each test is a height-band overlap plus an exact 2D test (separating axes,
//! closest point, segment clipping) — no sampling, no tolerance beyond touching counting as
//! overlap. A mesh is tested triangle by triangle (separating axes in 3D).

use glam::{DVec2, DVec3};

use super::shape::{OrientedBox, Shape};

/// A rectangle in the xy plane: centre, unit axes and half extents.
#[derive(Clone, Copy, Debug)]
struct Rect {
    center: DVec2,
    axes: [DVec2; 2],
    half: DVec2,
}

impl Rect {
    fn of(b: &OrientedBox) -> Self {
        let (s, c) = b.yaw.sin_cos();
        Self {
            center: b.center.truncate(),
            axes: [DVec2::new(c, s), DVec2::new(-s, c)],
            half: b.half.truncate(),
        }
    }

    fn local(&self, p: DVec2) -> DVec2 {
        let d = p - self.center;
        DVec2::new(d.dot(self.axes[0]), d.dot(self.axes[1]))
    }

    /// Squared distance from `p` to the rectangle (0 inside).
    fn distance_squared(&self, p: DVec2) -> f64 {
        let l = self.local(p);
        let q = l.abs() - self.half;
        q.max(DVec2::ZERO).length_squared()
    }

    /// Half the rectangle's extent projected on unit axis `a`.
    fn radius_on(&self, a: DVec2) -> f64 {
        self.half.x * self.axes[0].dot(a).abs() + self.half.y * self.axes[1].dot(a).abs()
    }

    fn overlaps(&self, o: &Rect) -> bool {
        let d = o.center - self.center;
        self.axes
            .iter()
            .chain(o.axes.iter())
            .all(|&a| d.dot(a).abs() <= self.radius_on(a) + o.radius_on(a))
    }

    /// Whether segment `a`–`b` meets the rectangle (Liang–Barsky clipping in its frame).
    fn meets_segment(&self, a: DVec2, b: DVec2) -> bool {
        let (p, q) = (self.local(a), self.local(b));
        let d = q - p;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for i in 0..2 {
            let (pi, di, h) = (p[i], d[i], self.half[i]);
            if di.abs() < 1e-15 {
                if pi.abs() > h {
                    return false;
                }
            } else {
                let (u, v) = ((-h - pi) / di, (h - pi) / di);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
                if t0 > t1 {
                    return false;
                }
            }
        }
        true
    }
}

fn z_overlap(lo: f64, hi: f64, b: &OrientedBox) -> bool {
    lo <= b.center.z + b.half.z && hi >= b.center.z - b.half.z
}

/// Two z-yawed boxes overlap when their height bands and their footprints do.
fn box_overlap(b: &OrientedBox, rect: &Rect, body: &OrientedBox) -> bool {
    z_overlap(b.center.z - b.half.z, b.center.z + b.half.z, body) && rect.overlaps(&Rect::of(b))
}

impl Shape {
    /// Whether the shape and the box share a point (touching counts).
    pub fn overlaps_box(&self, body: &OrientedBox) -> bool {
        let rect = Rect::of(body);
        match self {
            Self::Sphere { center, radius } => {
                // Distance from the centre to the box, in 3D: the box is z-aligned.
                let dz = (center.z - body.center.z).abs() - body.half.z;
                let dz = dz.max(0.0);
                rect.distance_squared(center.truncate()) + dz * dz <= radius * radius
            }
            Self::Box(b) => box_overlap(b, &rect, body),
            Self::Cylinder {
                center,
                radius,
                half_height,
            } => {
                z_overlap(center.z - half_height, center.z + half_height, body)
                    && rect.distance_squared(center.truncate()) <= radius * radius
            }
            Self::Wall { segments, .. } => segments.iter().any(|s| box_overlap(s, &rect, body)),
            Self::Mesh(m) => m.overlaps_box(body),
            Self::Prism {
                polygon,
                z_min,
                z_max,
            } => {
                if !z_overlap(*z_min, *z_max, body) {
                    return false;
                }
                // Either an edge meets the rectangle, or one lies wholly inside the other.
                let n = polygon.len();
                (0..n).any(|i| rect.meets_segment(polygon[i], polygon[(i + 1) % n]))
                    || self.contains(rect.center.extend((z_min + z_max) / 2.0))
            }
        }
    }
}

/// The box of a body `length` × `width` × `height` standing on the ground at (x, y, yaw).
pub fn body_box(x: f64, y: f64, yaw: f64, length: f64, width: f64, height: f64) -> OrientedBox {
    OrientedBox::new(
        DVec3::new(x, y, height / 2.0),
        DVec3::new(length, width, height),
        yaw,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn arb_shape() -> impl Strategy<Value = Shape> {
        let c = (-2.0..2.0f64, -2.0..2.0f64, 0.0..1.5f64);
        prop_oneof![
            (c.clone(), 0.05..1.0f64).prop_map(|((x, y, z), r)| Shape::sphere(
                DVec3::new(x, y, z),
                r
            )
            .unwrap()),
            (
                c.clone(),
                (0.05..1.5f64, 0.05..1.5f64, 0.05..1.5f64),
                -3.2..3.2f64
            )
                .prop_map(|((x, y, z), (a, b, h), yaw)| {
                    Shape::cuboid(DVec3::new(x, y, z.max(h / 2.0)), DVec3::new(a, b, h), yaw)
                        .unwrap()
                }),
            (c.clone(), 0.05..1.0f64, 0.05..1.5f64).prop_map(|((x, y, z), r, h)| {
                Shape::cylinder(DVec3::new(x, y, z.max(h / 2.0)), r, h).unwrap()
            }),
            (
                prop::collection::vec((-2.0..2.0f64, -2.0..2.0f64), 2..4),
                0.05..0.4f64
            )
                .prop_filter_map("degenerate wall", |(pts, t)| {
                    let pts = pts.into_iter().map(|(x, y)| DVec2::new(x, y)).collect();
                    Shape::wall(pts, t, 1.0).ok()
                }),
            (
                0.0..0.5f64,
                0.3..1.5f64,
                0.0..std::f64::consts::TAU,
                0.1..0.6f64
            )
                .prop_map(|(z0, dz, rot, dent)| {
                    // A concave "L" (arrowhead) polygon, rotated.
                    let (s, c) = rot.sin_cos();
                    let pts = [
                        (-1.0, -1.0),
                        (1.0, -1.0),
                        (dent, 0.0),
                        (1.0, 1.0),
                        (-1.0, 1.0),
                    ]
                    .iter()
                    .map(|&(x, y)| DVec2::new(c * x - s * y, s * x + c * y))
                    .collect();
                    Shape::prism(pts, z0, z0 + dz).unwrap()
                }),
        ]
    }

    /// Points on a grid through the box, its faces included.
    fn box_points(b: &OrientedBox, n: usize) -> impl Iterator<Item = DVec3> + '_ {
        let (s, c) = b.yaw.sin_cos();
        let f = move |i: usize| i as f64 / (n - 1) as f64 * 2.0 - 1.0;
        (0..n * n * n).map(move |k| {
            let l = DVec3::new(f(k % n), f(k / n % n), f(k / (n * n))) * b.half;
            b.center + DVec3::new(c * l.x - s * l.y, s * l.x + c * l.y, l.z)
        })
    }

    proptest! {
        /// No point of the box may lie inside a shape the test calls clear, and a shape whose
        /// test says "overlap" must come within a grid step of the box.
        #[test]
        fn overlap_agrees_with_point_sampling(
            shape in arb_shape(),
            x in -2.5..2.5f64, y in -2.5..2.5f64, yaw in -3.2..3.2f64,
        ) {
            let body = body_box(x, y, yaw, 0.508, 0.497, 0.277);
            let hit = shape.overlaps_box(&body);
            let sampled = box_points(&body, 9).any(|p| shape.contains(p));
            if sampled {
                prop_assert!(hit, "a box point lies inside the shape");
            }
            if hit {
                let grown = OrientedBox::new(body.center, body.half * 2.0 + 0.2, yaw);
                prop_assert!(box_points(&grown, 25).any(|p| shape.contains(p))
                    || box_points(&body, 41).any(|p| shape.contains(p)),
                    "overlap reported far from the shape");
            }
        }
    }

    #[test]
    fn analytic_cases() {
        let body = body_box(0.0, 0.0, 0.0, 1.0, 1.0, 0.5);
        // Ball 0.1 above the top, radius 0.11 touches it; 0.09 does not.
        let above = |r| Shape::sphere(DVec3::new(0.0, 0.0, 0.6), r).unwrap();
        assert!(above(0.11).overlaps_box(&body));
        assert!(!above(0.09).overlaps_box(&body));
        // Ball near a corner: distance to the corner √2 · 0.1.
        let corner = |r| Shape::sphere(DVec3::new(0.6, 0.6, 0.25), r).unwrap();
        assert!(corner(0.1415).overlaps_box(&body));
        assert!(!corner(0.1413).overlaps_box(&body));
        // A box yawed 45° whose corner pokes in only because of the rotation.
        let diamond = Shape::cuboid(
            DVec3::new(1.2, 0.0, 0.25),
            DVec3::new(1.0, 1.0, 0.5),
            std::f64::consts::FRAC_PI_4,
        )
        .unwrap();
        assert!(diamond.overlaps_box(&body)); // corner at x = 1.2 - 0.707 = 0.49
        let far = Shape::cuboid(
            DVec3::new(1.22, 0.0, 0.25),
            DVec3::new(1.0, 1.0, 0.5),
            std::f64::consts::FRAC_PI_4,
        )
        .unwrap();
        assert!(!far.overlaps_box(&body));
        // A cylinder standing higher than the body's top does not touch it.
        let high = Shape::cylinder(DVec3::new(0.0, 0.0, 1.5), 0.3, 1.0).unwrap();
        assert!(!high.overlaps_box(&body));
        // A body wholly inside a prism overlaps it.
        let big = Shape::prism(
            vec![
                DVec2::new(-5.0, -5.0),
                DVec2::new(5.0, -5.0),
                DVec2::new(5.0, 5.0),
                DVec2::new(-5.0, 5.0),
            ],
            0.0,
            1.0,
        )
        .unwrap();
        assert!(big.overlaps_box(&body));
    }
}
