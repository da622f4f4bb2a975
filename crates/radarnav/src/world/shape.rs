//! The five solid shapes of a world and their exact ray intervals.
//!
//! The sensor models need, for one ray, every stretch `[t_in, t_out]` that lies inside a shape,
//! not only the first hit, so each shape answers that analytically. Concave shapes (walls with
//! corners, concave prisms) may give several disjoint intervals.

use glam::{DVec2, DVec3};
use thiserror::Error;

/// A ray `origin + t · dir`; `dir` has unit length so `t` is a distance in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir` (normalised here).
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Self {
            origin,
            dir: dir.normalize(),
        }
    }

    /// The point at distance `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// Why a shape could not be built.
#[derive(Debug, Error, PartialEq)]
pub enum ShapeError {
    /// A length that must be positive was not.
    #[error("{what} must be > 0 (got {value})")]
    NotPositive {
        /// The offending quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// A value was NaN or infinite.
    #[error("{what} must be finite (got {value})")]
    NotFinite {
        /// The offending quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Too few points for a polyline or polygon.
    #[error("{what} needs at least {min} points (got {got})")]
    TooFewPoints {
        /// The offending list.
        what: &'static str,
        /// Minimum count.
        min: usize,
        /// Actual count.
        got: usize,
    },
    /// A wall segment or polygon edge of zero length.
    #[error("{what} has two equal consecutive points at index {index}")]
    Degenerate {
        /// The offending list.
        what: &'static str,
        /// Index of the repeated point.
        index: usize,
    },
    /// `z_max` not above `z_min`, or a shape reaching below the ground.
    #[error("{0}")]
    BadExtent(String),
}

/// A box rotated about the vertical axis; the building block of boxes and walls.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedBox {
    /// Geometric centre.
    pub center: DVec3,
    /// Half extents along the box's own x, y, z axes.
    pub half: DVec3,
    /// Rotation about z, radians.
    pub yaw: f64,
    cos_sin: DVec2,
}

impl OrientedBox {
    /// A box with centre, full size and yaw.
    pub fn new(center: DVec3, size: DVec3, yaw: f64) -> Self {
        Self {
            center,
            half: size * 0.5,
            yaw,
            cos_sin: DVec2::new(yaw.cos(), yaw.sin()),
        }
    }

    /// World vector into the box frame (rotation only).
    fn local_vec(&self, v: DVec3) -> DVec3 {
        let (c, s) = (self.cos_sin.x, self.cos_sin.y);
        DVec3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z)
    }

    /// The stretch of the ray's line inside the box, `None` for a miss or a grazing touch.
    /// Always inlined (three callers): returned through memory, its two distances were
    /// written one by one and read back sixteen bytes at once, which stalls the store buffer
    /// at every wall segment a ray tests (a twentieth of a whole run).
    #[inline(always)]
    pub(crate) fn interval(&self, ray: &Ray) -> Option<(f64, f64)> {
        let o = self.local_vec(ray.origin - self.center);
        let d = self.local_vec(ray.dir);
        slab_interval(o, d, -self.half, self.half)
    }

    fn contains(&self, p: DVec3) -> bool {
        let l = self.local_vec(p - self.center);
        l.abs().cmple(self.half).all()
    }

    /// How far `p` lies outside the box's surface along its nearest face's normal (negative
    /// inside), and that face's outward normal in the world frame.
    pub(crate) fn face_at(&self, p: DVec3) -> (f64, DVec3) {
        let l = self.local_vec(p - self.center);
        let excess = l.abs() - self.half;
        let (axis, dist) = if excess.x >= excess.y && excess.x >= excess.z {
            (0, excess.x)
        } else if excess.y >= excess.z {
            (1, excess.y)
        } else {
            (2, excess.z)
        };
        let (c, s) = (self.cos_sin.x, self.cos_sin.y);
        let n = match axis {
            0 => DVec3::new(c, s, 0.0) * l.x.signum(),
            1 => DVec3::new(-s, c, 0.0) * l.y.signum(),
            _ => DVec3::new(0.0, 0.0, l.z.signum()),
        };
        (dist, n)
    }

    /// The corners of the footprint grown by `pad` on every side, counter-clockwise.
    pub fn corners(&self, pad: f64) -> [DVec2; 4] {
        let (c, s) = (self.cos_sin.x, self.cos_sin.y);
        let (ax, ay) = (
            DVec2::new(c, s) * (self.half.x + pad),
            DVec2::new(-s, c) * (self.half.y + pad),
        );
        let m = self.center.truncate();
        [m - ax - ay, m + ax - ay, m + ax + ay, m - ax + ay]
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn aabb(&self) -> (DVec3, DVec3) {
        let (c, s) = (self.cos_sin.x.abs(), self.cos_sin.y.abs());
        let ext = DVec3::new(
            c * self.half.x + s * self.half.y,
            s * self.half.x + c * self.half.y,
            self.half.z,
        );
        (self.center - ext, self.center + ext)
    }
}

/// Axis-aligned slab test (Kay–Kajiya) in a local frame; `None` for a miss or a grazing touch.
fn slab_interval(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let mut t0 = f64::NEG_INFINITY;
    let mut t1 = f64::INFINITY;
    for i in 0..3 {
        let (oi, di) = (o[i], d[i]);
        if di.abs() < 1e-15 {
            if oi < lo[i] || oi > hi[i] {
                return None;
            }
        } else {
            let (a, b) = ((lo[i] - oi) / di, (hi[i] - oi) / di);
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
    }
    (t0 < t1).then_some((t0, t1))
}

/// The stretch of the ray's line inside a sphere, `None` for a miss or a grazing touch: the
/// one formula of every sphere query.
#[inline]
pub(crate) fn sphere_interval(center: DVec3, radius: f64, ray: &Ray) -> Option<(f64, f64)> {
    let oc = ray.origin - center;
    let b = oc.dot(ray.dir);
    let disc = b * b - (oc.length_squared() - radius * radius);
    (disc > 0.0).then(|| {
        let s = disc.sqrt();
        (-b - s, -b + s)
    })
}

/// The stretch of the ray's line inside the horizontal slab `z_lo ≤ z ≤ z_hi`.
fn z_slab(ray: &Ray, z_lo: f64, z_hi: f64) -> Option<(f64, f64)> {
    let (oz, dz) = (ray.origin.z, ray.dir.z);
    if dz.abs() < 1e-15 {
        return (oz >= z_lo && oz <= z_hi).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (a, b) = ((z_lo - oz) / dz, (z_hi - oz) / dz);
    Some(if a <= b { (a, b) } else { (b, a) })
}

fn overlap(a: (f64, f64), b: (f64, f64)) -> Option<(f64, f64)> {
    let (lo, hi) = (a.0.max(b.0), a.1.min(b.1));
    (lo < hi).then_some((lo, hi))
}

/// A solid in the world. Build with the checked constructors; all lengths in metres.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A ball.
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// A box rotated about z.
    Box(OrientedBox),
    /// A vertical cylinder.
    Cylinder {
        /// Geometric centre (half-way up the axis).
        center: DVec3,
        /// Radius.
        radius: f64,
        /// Half the height.
        half_height: f64,
    },
    /// A polyline wall standing on the ground; each segment is a box whose ends are extended by
    /// half the thickness, so that joints of up to 90° are closed.
    Wall {
        /// The polyline in the xy plane.
        points: Vec<DVec2>,
        /// Thickness.
        thickness: f64,
        /// Height above the ground.
        height: f64,
        /// One box per segment, derived from the three fields above.
        segments: Vec<OrientedBox>,
    },
    /// A triangle mesh (OBJ or glTF, in world coordinates): a volume when closed, a surface
    /// when open (see [`super::mesh`]).
    Mesh(std::sync::Arc<super::mesh::TriMesh>),
    /// A vertical extrusion of a simple (possibly concave) polygon.
    Prism {
        /// Polygon vertices in the xy plane, either winding.
        polygon: Vec<DVec2>,
        /// Bottom.
        z_min: f64,
        /// Top.
        z_max: f64,
    },
}

fn positive(what: &'static str, value: f64) -> Result<f64, ShapeError> {
    finite(what, value)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(ShapeError::NotPositive { what, value })
    }
}

fn finite(what: &'static str, value: f64) -> Result<f64, ShapeError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ShapeError::NotFinite { what, value })
    }
}

fn finite_vec(what: &'static str, v: &[f64]) -> Result<(), ShapeError> {
    v.iter().try_for_each(|&x| finite(what, x).map(|_| ()))
}

fn distinct_consecutive(what: &'static str, pts: &[DVec2], closed: bool) -> Result<(), ShapeError> {
    let n = pts.len();
    let edges = if closed { n } else { n - 1 };
    for i in 0..edges {
        if pts[i].distance_squared(pts[(i + 1) % n]) < 1e-18 {
            return Err(ShapeError::Degenerate {
                what,
                index: (i + 1) % n,
            });
        }
    }
    Ok(())
}

impl Shape {
    /// A sphere.
    pub fn sphere(center: DVec3, radius: f64) -> Result<Self, ShapeError> {
        finite_vec("center", &center.to_array())?;
        Ok(Self::Sphere {
            center,
            radius: positive("radius", radius)?,
        })
    }

    /// A box of full `size`, rotated by `yaw` radians about its vertical axis.
    pub fn cuboid(center: DVec3, size: DVec3, yaw: f64) -> Result<Self, ShapeError> {
        finite_vec("center", &center.to_array())?;
        for (what, v) in [("size.x", size.x), ("size.y", size.y), ("size.z", size.z)] {
            positive(what, v)?;
        }
        Ok(Self::Box(OrientedBox::new(
            center,
            size,
            finite("yaw", yaw)?,
        )))
    }

    /// A vertical cylinder around its geometric centre.
    pub fn cylinder(center: DVec3, radius: f64, height: f64) -> Result<Self, ShapeError> {
        finite_vec("center", &center.to_array())?;
        Ok(Self::Cylinder {
            center,
            radius: positive("radius", radius)?,
            half_height: positive("height", height)? * 0.5,
        })
    }

    /// A wall along a polyline, from the ground up to `height`.
    pub fn wall(points: Vec<DVec2>, thickness: f64, height: f64) -> Result<Self, ShapeError> {
        if points.len() < 2 {
            return Err(ShapeError::TooFewPoints {
                what: "points",
                min: 2,
                got: points.len(),
            });
        }
        points
            .iter()
            .try_for_each(|p| finite_vec("points", &p.to_array()))?;
        distinct_consecutive("points", &points, false)?;
        let thickness = positive("thickness", thickness)?;
        let height = positive("height", height)?;
        let segments = points
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let mid = (a + b) * 0.5;
                let along = b - a;
                OrientedBox::new(
                    DVec3::new(mid.x, mid.y, height * 0.5),
                    DVec3::new(along.length() + thickness, thickness, height),
                    along.y.atan2(along.x),
                )
            })
            .collect();
        Ok(Self::Wall {
            points,
            thickness,
            height,
            segments,
        })
    }

    /// A prism: `polygon` extruded from `z_min` to `z_max`.
    pub fn prism(polygon: Vec<DVec2>, z_min: f64, z_max: f64) -> Result<Self, ShapeError> {
        if polygon.len() < 3 {
            return Err(ShapeError::TooFewPoints {
                what: "polygon",
                min: 3,
                got: polygon.len(),
            });
        }
        polygon
            .iter()
            .try_for_each(|p| finite_vec("polygon", &p.to_array()))?;
        distinct_consecutive("polygon", &polygon, true)?;
        finite("z_min", z_min)?;
        finite("z_max", z_max)?;
        if z_max <= z_min {
            return Err(ShapeError::BadExtent(format!(
                "z_max ({z_max}) must be above z_min ({z_min})"
            )));
        }
        Ok(Self::Prism {
            polygon,
            z_min,
            z_max,
        })
    }

    /// Short lowercase name of the shape kind.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Sphere { .. } => "sphere",
            Self::Box(_) => "box",
            Self::Cylinder { .. } => "cylinder",
            Self::Wall { .. } => "wall",
            Self::Prism { .. } => "prism",
            Self::Mesh(_) => "mesh",
        }
    }

    /// Appends to `out` the disjoint intervals, in increasing order, where the ray's whole line
    /// (any `t`, negative too) lies inside the shape. Grazing touches give no interval.
    pub fn ray_intervals(&self, ray: &Ray, out: &mut Vec<(f64, f64)>) {
        match self {
            Self::Sphere { center, radius } => out.extend(sphere_interval(*center, *radius, ray)),
            Self::Box(b) => out.extend(b.interval(ray)),
            Self::Cylinder {
                center,
                radius,
                half_height,
            } => {
                let Some(zs) = z_slab(ray, center.z - half_height, center.z + half_height) else {
                    return;
                };
                let (ox, oy) = (ray.origin.x - center.x, ray.origin.y - center.y);
                let (dx, dy) = (ray.dir.x, ray.dir.y);
                let a = dx * dx + dy * dy;
                let c = ox * ox + oy * oy - radius * radius;
                let xy = if a < 1e-24 {
                    if c >= 0.0 {
                        return;
                    }
                    (f64::NEG_INFINITY, f64::INFINITY)
                } else {
                    let b = ox * dx + oy * dy;
                    let disc = b * b - a * c;
                    if disc <= 0.0 {
                        return;
                    }
                    let s = disc.sqrt();
                    ((-b - s) / a, (-b + s) / a)
                };
                out.extend(overlap(xy, zs));
            }
            Self::Wall { segments, .. } => {
                let start = out.len();
                out.extend(segments.iter().filter_map(|b| b.interval(ray)));
                merge_tail(out, start);
            }
            Self::Mesh(m) => m.ray_intervals(ray, out),
            Self::Prism {
                polygon,
                z_min,
                z_max,
            } => {
                let Some(zs) = z_slab(ray, *z_min, *z_max) else {
                    return;
                };
                let o = ray.origin.truncate();
                let d = ray.dir.truncate();
                if d.length_squared() < 1e-24 {
                    if point_in_polygon(polygon, o) {
                        out.push(zs);
                    }
                    return;
                }
                // Crossings of the line with the polygon's edges; the half-open side rule counts
                // a vertex on the line exactly once, so crossings come in entry/exit pairs. They
                // are staged in `out` itself (as `(t, t)`) so that no buffer is allocated per ray.
                let start = out.len();
                let n = polygon.len();
                for i in 0..n {
                    let (a, b) = (polygon[i], polygon[(i + 1) % n]);
                    let (sa, sb) = (d.perp_dot(a - o), d.perp_dot(b - o));
                    if (sa >= 0.0) != (sb >= 0.0) {
                        let e = b - a;
                        let t = (a - o).perp_dot(e) / d.perp_dot(e);
                        out.push((t, t));
                    }
                }
                out[start..].sort_by(|a, b| a.0.total_cmp(&b.0));
                let mut w = start;
                for k in (start..out.len().saturating_sub(1)).step_by(2) {
                    if let Some(iv) = overlap((out[k].0, out[k + 1].0), zs) {
                        out[w] = iv;
                        w += 1;
                    }
                }
                out.truncate(w);
                merge_tail(out, start);
            }
        }
    }

    /// The outward unit normal of the surface nearest to `p`, a point on (or within rounding
    /// of) the surface: where a ray enters, for the incidence angle of its echo and the
    /// direction of a mirrored ray (DESIGN §7.2).
    #[inline]
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        let radial = |c: DVec3| {
            let v = DVec3::new(p.x - c.x, p.y - c.y, 0.0);
            v.try_normalize().unwrap_or(DVec3::X)
        };
        match self {
            // On the surface |p − centre| is the radius (to rounding): one division, where
            // normalising takes a square root as well.
            Self::Sphere { center, radius } => (p - *center) / *radius,
            Self::Box(b) => b.face_at(p).1,
            Self::Cylinder {
                center,
                radius,
                half_height,
            } => {
                let side = p.truncate().distance(center.truncate()) - radius;
                let cap = (p.z - center.z).abs() - half_height;
                if cap > side {
                    DVec3::new(0.0, 0.0, (p.z - center.z).signum())
                } else {
                    radial(*center)
                }
            }
            Self::Wall { segments, .. } => segments
                .iter()
                .map(|b| b.face_at(p))
                .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
                .map_or(DVec3::Z, |f| f.1),
            Self::Mesh(m) => m.normal_at(p),
            Self::Prism {
                polygon,
                z_min,
                z_max,
            } => {
                let q = p.truncate();
                let n = polygon.len();
                let (edge_dist, edge_normal) = (0..n)
                    .map(|i| {
                        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
                        let e = b - a;
                        let t = ((q - a).dot(e) / e.length_squared()).clamp(0.0, 1.0);
                        let d = q.distance(a + e * t);
                        (d, e.perp().normalize_or_zero())
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .unwrap_or((f64::INFINITY, DVec2::X));
                let (cap_dist, up) = if (p.z - z_min).abs() < (z_max - p.z).abs() {
                    ((p.z - z_min).abs(), -1.0)
                } else {
                    ((z_max - p.z).abs(), 1.0)
                };
                if cap_dist < edge_dist {
                    DVec3::new(0.0, 0.0, up)
                } else {
                    // Outward whatever the winding: away from the polygon's inside.
                    let probe = q + edge_normal * 1e-6;
                    let sign = if point_in_polygon(polygon, probe) {
                        -1.0
                    } else {
                        1.0
                    };
                    (edge_normal * sign).extend(0.0)
                }
            }
        }
    }

    /// Whether the point lies inside or on the boundary of the shape.
    pub fn contains(&self, p: DVec3) -> bool {
        match self {
            Self::Sphere { center, radius } => p.distance_squared(*center) <= radius * radius,
            Self::Box(b) => b.contains(p),
            Self::Cylinder {
                center,
                radius,
                half_height,
            } => {
                (p.z - center.z).abs() <= *half_height
                    && p.truncate().distance_squared(center.truncate()) <= radius * radius
            }
            Self::Wall { segments, .. } => segments.iter().any(|b| b.contains(p)),
            Self::Mesh(m) => m.contains(p),
            Self::Prism {
                polygon,
                z_min,
                z_max,
            } => p.z >= *z_min && p.z <= *z_max && point_in_polygon(polygon, p.truncate()),
        }
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn aabb(&self) -> (DVec3, DVec3) {
        match self {
            Self::Sphere { center, radius } => (*center - *radius, *center + *radius),
            Self::Box(b) => b.aabb(),
            Self::Cylinder {
                center,
                radius,
                half_height,
            } => {
                let e = DVec3::new(*radius, *radius, *half_height);
                (*center - e, *center + e)
            }
            Self::Wall { segments, .. } => segments.iter().map(OrientedBox::aabb).fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
            ),
            Self::Mesh(m) => m.aabb(),
            Self::Prism {
                polygon,
                z_min,
                z_max,
            } => {
                let (lo, hi) = polygon
                    .iter()
                    .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), p| {
                        (lo.min(*p), hi.max(*p))
                    });
                (lo.extend(*z_min), hi.extend(*z_max))
            }
        }
    }

    /// Axis-aligned bounds of each part: one per wall segment, the whole shape otherwise. The
    /// acceleration grid lists a wall only in the cells its segments meet.
    pub fn part_aabbs(&self) -> Vec<(DVec3, DVec3)> {
        match self {
            Self::Wall { segments, .. } => segments.iter().map(OrientedBox::aabb).collect(),
            _ => vec![self.aabb()],
        }
    }

    /// Where a mesh is cut by the level plane at height `z` (closed polygons); `None` for
    /// the analytic shapes, whose footprint is the whole story.
    pub fn section(&self, z: f64) -> Option<Vec<Vec<DVec2>>> {
        match self {
            Self::Mesh(m) => Some(m.section(z)),
            _ => None,
        }
    }

    /// The outline in the xy plane, for drawing top-down: a closed polygon per part (a mesh's
    /// convex hull).
    pub fn footprint(&self) -> Vec<Vec<DVec2>> {
        let square = |b: &OrientedBox| b.corners(0.0).to_vec();
        let circle = |m: DVec2, r: f64| {
            (0..48)
                .map(|i| {
                    let a = i as f64 / 48.0 * std::f64::consts::TAU;
                    m + DVec2::new(a.cos(), a.sin()) * r
                })
                .collect()
        };
        match self {
            Self::Sphere { center, radius } => vec![circle(center.truncate(), *radius)],
            Self::Cylinder { center, radius, .. } => vec![circle(center.truncate(), *radius)],
            Self::Box(b) => vec![square(b)],
            Self::Wall { segments, .. } => segments.iter().map(square).collect(),
            Self::Prism { polygon, .. } => vec![polygon.clone()],
            Self::Mesh(m) => vec![m.footprint()],
        }
    }
}

/// Even-odd point-in-polygon test with the same half-open rule as the ray crossings.
fn point_in_polygon(polygon: &[DVec2], p: DVec2) -> bool {
    let n = polygon.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if p.x <= x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Sorts and unions the intervals `out[start..]` in place.
fn merge_tail(out: &mut Vec<(f64, f64)>, start: usize) {
    let tail = &mut out[start..];
    if tail.len() < 2 {
        return;
    }
    tail.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut w = start;
    for r in start + 1..out.len() {
        let cur = out[r];
        if cur.0 <= out[w].1 {
            out[w].1 = out[w].1.max(cur.1);
        } else {
            w += 1;
            out[w] = cur;
        }
    }
    out.truncate(w + 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f64; 3], d: [f64; 3]) -> Ray {
        Ray::new(DVec3::from(o), DVec3::from(d))
    }

    fn intervals(s: &Shape, r: &Ray) -> Vec<(f64, f64)> {
        let mut v = Vec::new();
        s.ray_intervals(r, &mut v);
        v
    }

    fn close(a: (f64, f64), b: (f64, f64)) -> bool {
        (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9
    }

    #[test]
    fn sphere_chord_matches_geometry() {
        let s = Shape::sphere(DVec3::new(5.0, 0.0, 1.0), 1.0).unwrap();
        // Offset 0.6 from the centre: half chord sqrt(1 - 0.36) = 0.8.
        let iv = intervals(&s, &ray([0.0, 0.6, 1.0], [1.0, 0.0, 0.0]));
        assert_eq!(iv.len(), 1);
        assert!(close(iv[0], (4.2, 5.8)), "{iv:?}");
        assert!(intervals(&s, &ray([0.0, 1.0, 1.0], [1.0, 0.0, 0.0])).is_empty());
    }

    #[test]
    fn rotated_box_diagonal() {
        let b = Shape::cuboid(
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::splat(2.0),
            45f64.to_radians(),
        )
        .unwrap();
        // Along x through the centre of a 45° box: corner to corner, half diagonal sqrt(2).
        let iv = intervals(&b, &ray([-5.0, 0.0, 1.0], [1.0, 0.0, 0.0]));
        let h = 2f64.sqrt();
        assert!(close(iv[0], (5.0 - h, 5.0 + h)), "{iv:?}");
    }

    #[test]
    fn cylinder_side_and_cap() {
        let c = Shape::cylinder(DVec3::new(0.0, 0.0, 1.0), 0.5, 2.0).unwrap();
        let side = intervals(&c, &ray([-3.0, 0.0, 0.5], [1.0, 0.0, 0.0]));
        assert!(close(side[0], (2.5, 3.5)));
        let down = intervals(&c, &ray([0.1, 0.0, 5.0], [0.0, 0.0, -1.0]));
        assert!(close(down[0], (3.0, 5.0)));
        assert!(intervals(&c, &ray([-3.0, 0.0, 2.5], [1.0, 0.0, 0.0])).is_empty());
    }

    #[test]
    fn wall_corner_is_one_interval() {
        // An L-shaped wall: a ray along the first leg through the corner stays inside throughout.
        let w = Shape::wall(
            vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(4.0, 0.0),
                DVec2::new(4.0, 4.0),
            ],
            0.2,
            2.0,
        )
        .unwrap();
        let iv = intervals(&w, &ray([-1.0, 0.0, 1.0], [1.0, 0.0, 0.0]));
        assert_eq!(iv.len(), 1, "{iv:?}");
        assert!(close(iv[0], (0.9, 5.1)), "{iv:?}");
    }

    #[test]
    fn concave_prism_gives_two_intervals() {
        // A U shape open to +y: a ray along x at y = 1.5 crosses both arms.
        let u = Shape::prism(
            vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(3.0, 0.0),
                DVec2::new(3.0, 2.0),
                DVec2::new(2.0, 2.0),
                DVec2::new(2.0, 1.0),
                DVec2::new(1.0, 1.0),
                DVec2::new(1.0, 2.0),
                DVec2::new(0.0, 2.0),
            ],
            0.0,
            1.0,
        )
        .unwrap();
        let iv = intervals(&u, &ray([-1.0, 1.5, 0.5], [1.0, 0.0, 0.0]));
        assert_eq!(iv.len(), 2);
        assert!(
            close(iv[0], (1.0, 2.0)) && close(iv[1], (3.0, 4.0)),
            "{iv:?}"
        );
        // Along the notch floor (y = 1 passes through two inner vertices) the half-open rule
        // counts the vertices once: the boundary line is inside from x = 0 to x = 3.
        let iv = intervals(&u, &ray([-1.0, 1.0, 0.5], [1.0, 0.0, 0.0]));
        assert_eq!(iv.len(), 1, "{iv:?}");
        assert!(close(iv[0], (1.0, 4.0)), "{iv:?}");
    }

    #[test]
    fn constructors_reject_bad_values() {
        assert!(matches!(
            Shape::sphere(DVec3::ZERO, -1.0),
            Err(ShapeError::NotPositive { what: "radius", .. })
        ));
        assert!(Shape::wall(vec![DVec2::ZERO], 0.1, 1.0).is_err());
        assert!(Shape::prism(vec![DVec2::ZERO, DVec2::X, DVec2::Y], 1.0, 1.0).is_err());
        assert!(Shape::cuboid(DVec3::ZERO, DVec3::new(1.0, f64::NAN, 1.0), 0.0).is_err());
        assert!(
            Shape::wall(vec![DVec2::ZERO, DVec2::ZERO], 0.1, 1.0)
                .is_err_and(|e| matches!(e, ShapeError::Degenerate { index: 1, .. }))
        );
    }
}
