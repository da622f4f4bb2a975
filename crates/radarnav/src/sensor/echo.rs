//! The radar's echoes along one ray (DESIGN §7.2).
//!
//! The same front-to-back interval walk as the thesis model ([`super::trace`]), but instead of
//! one range it yields every echo the ray produces: a surface echo at each entry into a
//! reflecting material, a volume echo over each stretch inside a scattering one (foliage glows
//! over its depth), and the echoes of mirrored rays off specular materials, placed at half
//! their round-trip path along the original azimuth (ghosts). The walk stops at the first
//! solid, at `t_max`, or as soon as the two-way loss has used the dynamic range: nothing behind
//! that point could rise above the noise floor, and no work is done for it.
//!
//! Power is relative to a reflector of ρ = 1 at normal incidence and 1 m under the same range
//! law, so 1 (0 dB) is the strongest echo a range of 1 m or more can give. The walk keeps it
//! linear, as products of reflectivity, incidence, range law and the two-way transmission so
//! far, and files, reads and draws it in dB ([`Echo::power_db`]): a logarithm per echo was a
//! tenth of a multi-echo scan. An echo weaker than `−dynamic_range_db` is dropped.

use std::f64::consts::LN_10;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::world::{Band, Fan, IntervalSource, MaterialId, Ray, RayQuery, World};

/// How an echo's power falls with range R.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RangeLaw {
    /// ∝ R⁻²: extended, beam-filling surfaces.
    R2,
    /// ∝ R⁻⁴: point targets (the radar equation).
    R4,
    /// Range-independent: a sensor's own range compensation (Navtech's high-pass filter).
    Flat,
}

impl RangeLaw {
    /// The law's gain in dB at range `r` (0 dB at 1 m). Ranges under 1 cm count as 1 cm.
    pub fn gain_db(self, r: f64) -> f64 {
        to_db(self.gain(r))
    }

    /// The law's linear power gain at range `r` (1 at 1 m; ranges under 1 cm count as 1 cm).
    pub fn gain(self, r: f64) -> f64 {
        let r = r.max(0.01);
        match self {
            Self::R2 => 1.0 / (r * r),
            Self::R4 => 1.0 / (r * r * r * r),
            Self::Flat => 1.0,
        }
    }

    /// Lowercase name, as in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::R2 => "r2",
            Self::R4 => "r4",
            Self::Flat => "flat",
        }
    }
}

/// What made an echo.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EchoKind {
    /// Reflection at the entry into a material.
    Surface,
    /// Backscatter from inside a penetrable material, spread over `depth`.
    Volume,
}

impl EchoKind {
    /// Lowercase name, as in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Surface => "surface",
            Self::Volume => "volume",
        }
    }
}

/// One echo of a ray.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Echo {
    /// Apparent range, m: half the round-trip path (for a volume echo, where it begins).
    pub range: f64,
    /// Extent along range of a volume echo, m; 0 for a surface echo.
    pub depth: f64,
    /// Two-way decay of a volume echo's power density along its depth, dB/m.
    pub decay_db_per_m: f64,
    /// Power, linear, relative to a ρ = 1 reflector at normal incidence and 1 m (files carry
    /// it in dB, as `power_db`).
    #[serde(rename = "power_db", serialize_with = "serialize_db")]
    pub power: f64,
    /// The material that made it.
    pub material: MaterialId,
    /// Surface or volume.
    pub kind: EchoKind,
    /// Specular bounces before it (0 = a direct echo; more = a ghost).
    pub bounces: u8,
}

impl Echo {
    /// The echo's power in dB relative to a ρ = 1 reflector at normal incidence and 1 m.
    pub fn power_db(&self) -> f64 {
        to_db(self.power)
    }
}

/// Writes a linear power as its dB.
fn serialize_db<S: serde::Serializer>(power: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(to_db(*power))
}

/// What the echo walk needs of a sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EchoModel {
    /// Range law of the echo power.
    pub range_law: RangeLaw,
    /// Echoes weaker than `−dynamic_range_db` are dropped, and the walk stops once its
    /// two-way loss exceeds it.
    pub dynamic_range_db: f64,
    /// Specular bounces followed per ray.
    pub max_bounces: u8,
    /// Echoes weaker than this, dB, are dropped too (a detection threshold, where nothing
    /// under it is wanted); `f64::NEG_INFINITY` keeps all above the dynamic range.
    pub min_power_db: f64,
    /// `(n, threshold_db)` when the caller keeps only the first `n` echoes (by range) at or
    /// above `threshold_db`: the walk then stops once it has them, since every echo found
    /// later lies at or beyond their range and sorts after them (`None`: every echo).
    pub wanted: Option<(usize, f64)>,
}

/// Whether `found` (one ray's echoes so far) holds the first `n` echoes of power at least
/// `threshold` (linear) within range `upto`: then nothing the ray meets further on can be
/// among them.
fn have_wanted(found: &[Echo], upto: f64, (n, threshold): (usize, f64)) -> bool {
    found.len() >= n
        && found
            .iter()
            .filter(|e| e.power >= threshold && e.range <= upto)
            .count()
            >= n
}

/// The bits of an [`EchoModel`]'s thresholds: `min_power_db`, `dynamic_range_db`, `wanted`.
type FloorsKey = (u64, u64, Option<(usize, u64)>);

/// An [`EchoModel`]'s power thresholds as linear powers: the floor below which echoes are
/// dropped, and `wanted`'s. Made once per model, not per ray (each is an `exp`).
#[derive(Clone, Copy, Debug)]
struct Floors {
    key: FloorsKey,
    floor: f64,
    wanted: Option<(usize, f64)>,
}

impl Floors {
    fn key(model: &EchoModel) -> FloorsKey {
        (
            model.min_power_db.to_bits(),
            model.dynamic_range_db.to_bits(),
            model.wanted.map(|(n, t)| (n, t.to_bits())),
        )
    }

    fn of(model: &EchoModel) -> Self {
        Self {
            key: Self::key(model),
            floor: from_db(model.min_power_db.max(-model.dynamic_range_db)),
            wanted: model.wanted.map(|(n, t)| (n, from_db(t))),
        }
    }
}

/// A volume echo is cut into pieces of at most this depth, m, so that the range law, taken at
/// each piece's middle, stays close to its value across the piece.
pub const VOLUME_PIECE_M: f64 = 2.0;

/// A mirrored ray still to walk.
#[derive(Clone, Copy, Debug)]
struct Leg {
    ray: Ray,
    /// Path already travelled to the ray's origin, m (one way).
    path: f64,
    /// One-way loss already suffered, dB: what the walk's stops look at.
    loss_db: f64,
    /// The same loss as a two-way power factor: what echoes are multiplied by.
    two_way: f64,
    bounces: u8,
    /// Path left within range, m.
    t_max: f64,
}

/// Reusable buffers of the echo walk; one per thread.
#[derive(Clone, Debug, Default)]
pub struct EchoTracer {
    query: RayQuery,
    /// Volumes the ray is inside: (exit, dB/m, η, material).
    active: Vec<(f64, f64, f64, MaterialId)>,
    legs: Vec<Leg>,
    /// The last model's thresholds.
    floors: Option<Floors>,
}

/// The smaller of two distances along a ray, which are never NaN: a bare compare and select,
/// where `f64::min` adds a NaN fix-up to every step of the walk's critical path.
#[inline(always)]
fn nearer(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// The larger of two never-NaN values (see [`nearer`]).
#[inline(always)]
fn farther(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// Ten to the power `db / 10`: the linear power of `db`.
pub(crate) fn from_db(db: f64) -> f64 {
    (db * (LN_10 / 10.0)).exp()
}

/// Ten times the log of `x` (through `ln`: libm's `log10` costs about twice as much).
fn to_db(x: f64) -> f64 {
    (10.0 / LN_10) * x.ln()
}

impl EchoTracer {
    /// Appends to `out` every echo of `ray` (beam weight `weight`) through `world` within
    /// `t_max` metres of path, in the order the walk meets them (by range within each leg;
    /// ghosts after the direct echoes). Returns the incidence cosine at the first surface met
    /// (1 when none), for incidence-weighted beam selection.
    pub fn echoes(
        &mut self,
        world: &World,
        ray: &Ray,
        weight: f64,
        t_max: f64,
        model: &EchoModel,
        out: &mut Vec<Echo>,
    ) -> f64 {
        self.echoes_from(world, None, ray, weight, t_max, model, out)
    }

    /// [`EchoTracer::echoes`] for a ray from the origin of `fan` ([`World::fan`], built for
    /// at least `t_max`) with bearing `heading`: its direct leg takes its intervals from the
    /// fan's candidate lists (the same intervals, found faster), mirrored legs from the grid.
    #[allow(clippy::too_many_arguments)]
    pub fn echoes_in_fan(
        &mut self,
        world: &World,
        fan: &Fan,
        heading: f64,
        ray: &Ray,
        weight: f64,
        t_max: f64,
        model: &EchoModel,
        out: &mut Vec<Echo>,
    ) -> f64 {
        self.echoes_from(world, Some((fan, heading)), ray, weight, t_max, model, out)
    }

    #[allow(clippy::too_many_arguments)]
    fn echoes_from(
        &mut self,
        world: &World,
        fan: Option<(&Fan, f64)>,
        ray: &Ray,
        weight: f64,
        t_max: f64,
        model: &EchoModel,
        out: &mut Vec<Echo>,
    ) -> f64 {
        self.legs.clear();
        let floors = match self.floors {
            Some(f) if f.key == Floors::key(model) => f,
            _ => *self.floors.insert(Floors::of(model)),
        };
        let start = out.len();
        let direct = Leg {
            ray: *ray,
            path: 0.0,
            // A beam of one ray weighs 1: −0 dB (as `-to_db(1.0)` gives) without the log.
            loss_db: if weight == 1.0 { -0.0 } else { -to_db(weight) },
            two_way: weight * weight,
            bounces: 0,
            t_max,
        };
        // The direct leg first, then its mirrored legs, last found first.
        let first_cos = self.walk_leg(world, fan, &direct, (model, &floors), start, out);
        while let Some(leg) = self.legs.pop() {
            self.walk_leg(world, None, &leg, (model, &floors), start, out);
        }
        first_cos.unwrap_or(1.0)
    }

    /// Walks one leg under `model`, whose thresholds `floors` holds (the ray's echoes begin at
    /// `out[start]`); returns the incidence cosine at its first surface.
    fn walk_leg(
        &mut self,
        world: &World,
        fan: Option<(&Fan, f64)>,
        leg: &Leg,
        (model, floors): (&EchoModel, &Floors),
        start: usize,
        out: &mut Vec<Echo>,
    ) -> Option<f64> {
        let ray = &leg.ray;
        let &Floors { floor, wanted, .. } = floors;
        // The ground plane z = 0 is a solid under every world.
        let t_ground = if ray.dir.z < 0.0 {
            (-ray.origin.z / ray.dir.z).max(0.0)
        } else {
            f64::INFINITY
        };
        let reach = leg.t_max.min(t_ground);
        let materials = world.materials();
        let mut intervals = match fan {
            Some((fan, heading)) => {
                world.fan_intervals(fan, ray, heading, reach, Some(Band::Radar), &mut self.query)
            }
            None => world.ordered_intervals(ray, reach, Some(Band::Radar), &mut self.query),
        };
        let active = &mut self.active;
        active.clear();
        let (mut loss, mut two_way) = (leg.loss_db, leg.two_way);
        let mut t = 0.0;
        let mut first_cos = None;
        let emit = |out: &mut Vec<Echo>, e: Echo| {
            if e.power >= floor {
                out.push(e);
            }
        };
        loop {
            // Echoes are found in range order along a leg, and a mirrored leg's lie beyond
            // its bounce: past the wanted ones, the walk is over.
            if let Some(wanted) = wanted
                && have_wanted(&out[start..], leg.path + t, wanted)
            {
                return first_cos;
            }
            let (exit_slot, t_exit) = active
                .iter()
                .enumerate()
                .map(|(i, a)| (i, a.0))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((usize::MAX, f64::INFINITY));
            let alpha: f64 = active.iter().map(|a| a.1).sum();
            let eta: f64 = active.iter().map(|a| a.2).sum();
            // Where the two-way loss reaches the dynamic range: nothing beyond matters.
            let horizon = if alpha > 0.0 {
                t + farther((model.dynamic_range_db / 2.0 - loss) / alpha, 0.0)
            } else {
                f64::INFINITY
            };
            let entry = intervals.peek(nearer(nearer(t_exit, reach), horizon));
            let t_entry = entry.map_or(f64::INFINITY, |iv| farther(iv.t_in, 0.0));
            let t_next = nearer(nearer(t_entry, t_exit), reach);
            let t_end = nearer(t_next, horizon);
            if eta > 0.0 && t_end > t {
                let scatterer = active
                    .iter()
                    .max_by(|a, b| a.2.total_cmp(&b.2))
                    .map(|a| a.3);
                if let Some(material) = scatterer {
                    let strength = (two_way, alpha, eta);
                    two_way =
                        volume_echoes((t, t_end), strength, leg, material, model, |e| emit(out, e));
                }
            } else if alpha > 0.0 && t_end > t {
                two_way *= (-two_way_decay(alpha) * (t_end - t)).exp();
            }
            if alpha > 0.0 {
                loss += alpha * (t_end - t);
            }
            if t_end < t_next || 2.0 * loss >= model.dynamic_range_db {
                return first_cos;
            }
            t = t_next;
            if t >= reach {
                if t_ground <= leg.t_max && t >= t_ground {
                    let (cos, _) = surface_echo(
                        leg,
                        DVec3::Z,
                        t,
                        (loss, two_way),
                        materials.get(world.ground_material()),
                        world.ground_material(),
                        model,
                        &mut |e| emit(out, e),
                    );
                    return first_cos.or(Some(cos));
                }
                return first_cos;
            }
            match entry {
                Some(iv) if t_entry <= t_exit => {
                    intervals.pop();
                    let m = materials.get(iv.material);
                    let a = m.attenuation_db_per_m(Band::Radar);
                    if iv.t_in > 0.0 {
                        let p = ray.at(t);
                        let normal = world.normal_at(&iv, p);
                        let at = (loss, two_way);
                        let (cos, bounce) =
                            surface_echo(leg, normal, t, at, m, iv.material, model, &mut |e| {
                                emit(out, e)
                            });
                        first_cos.get_or_insert(cos);
                        if let Some(b) = bounce {
                            self.legs.push(b);
                        }
                        let (db, factor) = world.radar_transmission(iv.material);
                        loss += db;
                        two_way *= factor;
                        if m.radar_reflectivity >= 1.0 {
                            return first_cos; // all reflected: nothing goes in
                        }
                    }
                    if a.is_infinite() {
                        return first_cos;
                    }
                    if a > 0.0 || m.radar_backscatter_per_m > 0.0 {
                        active.push((iv.t_out, a, m.radar_backscatter_per_m, iv.material));
                    }
                }
                _ => {
                    active.swap_remove(exit_slot);
                }
            }
        }
    }
}

/// The surface echo where `leg` enters material `m` at distance `t` (outward normal
/// `normal`; one-way loss so far `loss`, dB, that is the two-way power factor `two_way`), and
/// the mirrored leg of a specular surface. Returns the incidence cosine and that leg.
#[allow(clippy::too_many_arguments)]
fn surface_echo(
    leg: &Leg,
    normal: DVec3,
    t: f64,
    (loss, two_way): (f64, f64),
    m: &crate::world::Material,
    material: MaterialId,
    model: &EchoModel,
    emit: &mut impl FnMut(Echo),
) -> (f64, Option<Leg>) {
    let d = leg.ray.dir;
    let cos = nearer(1.0, d.dot(normal).abs());
    let rho = m.radar_reflectivity;
    if rho <= 0.0 {
        return (cos, None);
    }
    let gain = if m.specular {
        specular_gain(cos, m)
    } else {
        cos
    };
    let range = leg.path + t;
    if gain > 0.0 {
        emit(Echo {
            range,
            depth: 0.0,
            decay_db_per_m: 0.0,
            power: rho * gain * model.range_law.gain(range) * two_way,
            material,
            kind: EchoKind::Surface,
            bounces: leg.bounces,
        });
    }
    let bounce = (m.specular && leg.bounces < model.max_bounces && leg.t_max > t)
        .then(|| mirrored_leg(leg, normal, t, (loss, two_way), m));
    (
        cos,
        bounce.filter(|b| 2.0 * b.loss_db < model.dynamic_range_db),
    )
}

/// A specular surface's echo gain at incidence cosine `cos`: its lobe around the normal, plus
/// the diffuse share's echo at any angle (with no diffuse share exactly the lobe: 1·x + 0 = x).
/// Out of line, as the bounce below: few surfaces are specular, and the walk's loop keeps more
/// in registers without them.
#[inline(never)]
fn specular_gain(cos: f64, m: &crate::world::Material) -> f64 {
    let diffuse = m.radar_diffuse;
    let theta = cos.acos();
    let x = theta / m.specular_lobe;
    let lobe = (-4.0 * std::f64::consts::LN_2 * x * x).exp();
    (1.0 - diffuse) * lobe + diffuse * cos
}

/// The leg mirrored off specular material `m` where `leg` meets it at distance `t` (outward
/// normal `normal`; one-way loss so far `loss`, dB, that is the two-way factor `two_way`).
#[inline(never)]
fn mirrored_leg(
    leg: &Leg,
    normal: DVec3,
    t: f64,
    (loss, two_way): (f64, f64),
    m: &crate::world::Material,
) -> Leg {
    let d = leg.ray.dir;
    // What the diffuse share scatters is not mirrored.
    let mirrored = m.radar_reflectivity * (1.0 - m.radar_diffuse);
    // Mirrored about the surface, facing away from it.
    let n = if d.dot(normal) < 0.0 { normal } else { -normal };
    let dir = d - 2.0 * d.dot(n) * n;
    Leg {
        ray: Ray {
            origin: leg.ray.at(t) + n * 1e-6,
            dir,
        },
        path: leg.path + t,
        loss_db: loss - to_db(mirrored),
        two_way: two_way * mirrored * mirrored,
        bounces: leg.bounces + 1,
        t_max: leg.t_max - t,
    }
}

/// The two-way decay constant, 1/m, of power through a medium of `alpha` dB/m one way.
fn two_way_decay(alpha: f64) -> f64 {
    2.0 * alpha * LN_10 / 10.0
}

/// The volume echoes of the stretch `[t0, t1]` of `leg` inside scatterers of total η
/// (`eta`, 1/m) and attenuation `alpha` (dB/m), entered with the two-way power factor
/// `two_way`: the power η ∫ two_way · e^(−k s) ds (k the two-way decay), in pieces of at most
/// [`VOLUME_PIECE_M`], each under the range law at its middle. Returns the two-way factor at
/// `t1`.
fn volume_echoes(
    (t0, t1): (f64, f64),
    (two_way, alpha, eta): (f64, f64, f64),
    leg: &Leg,
    material: MaterialId,
    model: &EchoModel,
    mut emit: impl FnMut(Echo),
) -> f64 {
    // ⌈x⌉ as −⌊−x⌋, without a call to libm's `ceil`.
    let pieces = (-crate::world::floor_i64(-(t1 - t0) / VOLUME_PIECE_M)).max(1);
    let step = (t1 - t0) / pieces as f64;
    let k = two_way_decay(alpha);
    // The pieces are equally long, so each one's decay integral and its decay across are the
    // same: one `exp` (or `exp_m1`) for the whole stretch.
    let x = k * step;
    let (integral, across) = if x > 0.125 {
        // 1 − e⁻ˣ loses under 10⁻¹⁵ of its value to cancellation here, and libm's `exp`
        // costs about half its `exp_m1`.
        let e = (-x).exp();
        ((1.0 - e) / k, e)
    } else if k > 0.0 {
        let m1 = (-x).exp_m1();
        (-m1 / k, 1.0 + m1)
    } else {
        (step, 1.0)
    };
    let mut entry = two_way;
    for i in 0..pieces {
        let a = t0 + step * i as f64;
        let mid = leg.path + a + step / 2.0;
        emit(Echo {
            range: leg.path + a,
            depth: step,
            decay_db_per_m: 2.0 * alpha,
            power: eta * integral * model.range_law.gain(mid) * entry,
            material,
            kind: EchoKind::Volume,
            bounces: leg.bounces,
        });
        entry *= across;
    }
    entry
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{METAL_DIFFUSE, Material, Shape};

    use crate::world::strategies::world_of as world;

    /// The direct leg walked through a fan's candidate lists gives exactly the echoes of the
    /// grid walk: in a foliage forest with posts, over level and tilted rays of one origin.
    #[test]
    fn fan_and_grid_walks_give_the_same_echoes() {
        let w = crate::world::forest::forest(400, 40.0, 3);
        let origin = DVec3::new(0.3, -0.2, 0.6);
        let mut fan = Fan::default();
        assert!(w.fan(origin, 30.0, 360, usize::MAX, &mut fan));
        let model = EchoModel {
            range_law: RangeLaw::R2,
            dynamic_range_db: 80.0,
            max_bounces: 2,
            min_power_db: f64::NEG_INFINITY,
            wanted: None,
        };
        let mut t = EchoTracer::default();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let mut total = 0;
        for k in 0..720 {
            let heading = k as f64 * std::f64::consts::TAU / 720.0;
            for el in [-0.02f64, 0.0, 0.03] {
                let (s, c) = heading.sin_cos();
                let dir = DVec3::new(el.cos() * c, el.cos() * s, el.sin());
                let ray = Ray::new(origin, dir);
                a.clear();
                b.clear();
                let ca = t.echoes(&w, &ray, 0.5, 30.0, &model, &mut a);
                let cb = t.echoes_in_fan(&w, &fan, heading, &ray, 0.5, 30.0, &model, &mut b);
                assert_eq!(a, b, "heading {heading} el {el}");
                assert_eq!(ca, cb);
                total += a.len();
            }
        }
        assert!(total > 2000, "{total} echoes");
    }

    fn wall_at(x: f64) -> Shape {
        Shape::cuboid(
            DVec3::new(x + 0.1, 0.0, 1.0),
            DVec3::new(0.2, 40.0, 2.0),
            0.0,
        )
        .unwrap()
    }

    fn model(law: RangeLaw) -> EchoModel {
        EchoModel {
            range_law: law,
            dynamic_range_db: 200.0,
            max_bounces: 2,
            min_power_db: f64::NEG_INFINITY,
            wanted: None,
        }
    }

    fn echoes_of(w: &World, ray: &Ray, m: &EchoModel) -> Vec<Echo> {
        let mut out = Vec::new();
        EchoTracer::default().echoes(w, ray, 1.0, 100.0, m, &mut out);
        out
    }

    fn x_ray() -> Ray {
        Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::X)
    }

    #[test]
    fn range_laws_give_exact_steps_for_double_range() {
        for (law, step) in [
            (RangeLaw::R2, 20.0 * 2f64.log10()),
            (RangeLaw::R4, 40.0 * 2f64.log10()),
            (RangeLaw::Flat, 0.0),
        ] {
            let near = echoes_of(&world(&[(wall_at(5.0), "concrete")]), &x_ray(), &model(law));
            let far = echoes_of(
                &world(&[(wall_at(10.0), "concrete")]),
                &x_ray(),
                &model(law),
            );
            assert_eq!((near.len(), far.len()), (1, 1));
            assert!((near[0].range - 5.0).abs() < 1e-12 && (far[0].range - 10.0).abs() < 1e-12);
            let diff = near[0].power_db() - far[0].power_db();
            assert!((diff - step).abs() < 1e-9, "{law:?}: {diff}");
            // Normal incidence on concrete: ρ = 0.35 at 5 m.
            let expect = 10.0 * 0.35f64.log10() + law.gain_db(5.0);
            assert!((near[0].power_db() - expect).abs() < 1e-9);
        }
        assert!((RangeLaw::R2.gain_db(2.0) + 6.0206).abs() < 1e-4);
        assert!((RangeLaw::R4.gain_db(2.0) + 12.0412).abs() < 1e-4);
    }

    #[test]
    fn foliage_slab_lowers_the_wall_echo_by_two_way_loss_and_entry() {
        let slab =
            Shape::cuboid(DVec3::new(4.0, 0.0, 1.0), DVec3::new(1.5, 40.0, 2.0), 0.0).unwrap();
        let m = model(RangeLaw::Flat);
        let bare = echoes_of(&world(&[(wall_at(10.0), "concrete")]), &x_ray(), &m);
        let w = world(&[(slab, "foliage_dense"), (wall_at(10.0), "concrete")]);
        let hidden = echoes_of(&w, &x_ray(), &m);
        let wall = hidden
            .iter()
            .find(|e| e.kind == EchoKind::Surface && e.range > 9.0);
        let wall = wall.expect("wall echo behind the slab");
        // 1.5 m at 3 dB/m, two ways, plus the slab's entry: 10 log10(1 / (1 - 0.1)), two ways.
        let expect = 2.0 * 3.0 * 1.5 + 2.0 * 10.0 * (1.0 / 0.9f64).log10();
        assert!((bare[0].power_db() - wall.power_db() - expect).abs() < 1e-9);
        // The slab: a surface echo at 3.25 m and a volume echo over its depth.
        assert!((hidden[0].range - 3.25).abs() < 1e-12 && hidden[0].kind == EchoKind::Surface);
        let vol = hidden[1];
        assert_eq!(vol.kind, EchoKind::Volume);
        assert!((vol.range - 3.25).abs() < 1e-12 && (vol.depth - 1.5).abs() < 1e-12);
        // η ∫₀^1.5 10^(−2(L0 + 3 s)/10) ds, L0 the entry loss.
        let l0 = 10.0 * (1.0 / 0.9f64).log10();
        let k = 2.0 * 3.0 * LN_10 / 10.0;
        let expect = 0.2 * (1.0 - (-k * 1.5).exp()) / k * 10f64.powf(-2.0 * l0 / 10.0);
        assert!((vol.power - expect).abs() < 1e-12);
        // A slab deeper than the dynamic range hides the wall: 60 dB of range is used up by
        // 10 m of dense foliage (60 dB two ways).
        let deep =
            Shape::cuboid(DVec3::new(6.0, 0.0, 1.0), DVec3::new(11.0, 40.0, 2.0), 0.0).unwrap();
        let w = world(&[(deep, "foliage_dense"), (wall_at(13.0), "concrete")]);
        let m60 = EchoModel {
            dynamic_range_db: 60.0,
            ..m
        };
        let e = echoes_of(&w, &x_ray(), &m60);
        assert!(e.iter().all(|e| e.range < 13.0), "{e:?}");
    }

    /// A slab deeper than a volume piece glows in equal pieces, each with the analytic power
    /// of its depth (the two-way factor carried from piece to piece as the walk carries it),
    /// and the wall behind it has lost exactly 2αd dB plus the slab's entry.
    #[test]
    fn a_deep_slab_glows_piece_by_piece_as_the_integral_says() {
        let depth = 5.0;
        let slab = Shape::cuboid(
            DVec3::new(2.0 + depth / 2.0, 0.0, 1.0),
            DVec3::new(depth, 40.0, 2.0),
            0.0,
        )
        .unwrap();
        let m = model(RangeLaw::R2);
        let w = world(&[(slab, "foliage_light"), (wall_at(10.0), "concrete")]);
        let e = echoes_of(&w, &x_ray(), &m);
        let pieces: Vec<&Echo> = e.iter().filter(|e| e.kind == EchoKind::Volume).collect();
        assert_eq!(pieces.len(), 3, "{e:?}");
        let light = w
            .materials()
            .get(w.materials().id("foliage_light").unwrap());
        let (alpha, eta) = (
            light.attenuation_db_per_m(Band::Radar),
            light.radar_backscatter_per_m,
        );
        let entry_db = 10.0 * (1.0 / (1.0 - light.radar_reflectivity)).log10();
        let step = depth / 3.0;
        let k = 2.0 * alpha * LN_10 / 10.0;
        for (i, p) in pieces.iter().enumerate() {
            let a = step * i as f64;
            assert!((p.range - (2.0 + a)).abs() < 1e-12 && (p.depth - step).abs() < 1e-12);
            // η ∫ over the piece of 10^(−2(L0 + α s)/10) ds, under r⁻² at its middle.
            let loss = entry_db + alpha * a;
            let expect = eta * (1.0 - (-k * step).exp()) / k * 10f64.powf(-2.0 * loss / 10.0)
                / (2.0 + a + step / 2.0).powi(2);
            assert!(
                ((p.power - expect) / expect).abs() < 1e-12,
                "piece {i}: {p:?}"
            );
        }
        let wall = e.iter().find(|e| e.range > 9.0).expect("the wall behind");
        let bare = echoes_of(&world(&[(wall_at(10.0), "concrete")]), &x_ray(), &m);
        let lost = bare[0].power_db() - wall.power_db();
        assert!(
            (lost - 2.0 * (alpha * depth + entry_db)).abs() < 1e-9,
            "{lost}"
        );
    }

    /// Files carry an echo's power in dB under `power_db`.
    #[test]
    fn an_echo_serialises_its_power_in_db() {
        let e = Echo {
            range: 2.0,
            depth: 0.0,
            decay_db_per_m: 0.0,
            power: 0.01,
            material: MaterialId(0),
            kind: EchoKind::Surface,
            bounces: 0,
        };
        let v = serde_json::to_value(e).unwrap();
        assert!(
            (v["power_db"].as_f64().unwrap() + 20.0).abs() < 1e-12,
            "{v}"
        );
        assert!(v.get("power").is_none());
        assert!((e.power_db() + 20.0).abs() < 1e-12);
    }

    #[test]
    fn sphere_before_wall_gives_surface_volume_and_wall_echoes() {
        let w = world(&[
            (
                Shape::sphere(DVec3::new(5.0, 0.0, 1.0), 1.0).unwrap(),
                "foliage_light",
            ),
            (wall_at(10.0), "concrete"),
        ]);
        let e = echoes_of(&w, &x_ray(), &model(RangeLaw::R2));
        let kinds: Vec<_> = e.iter().map(|e| (e.kind, e.range, e.depth)).collect();
        assert_eq!(kinds.len(), 3, "{kinds:?}");
        assert_eq!(kinds[0], (EchoKind::Surface, 4.0, 0.0));
        assert_eq!(kinds[1].0, EchoKind::Volume);
        assert!((kinds[1].1 - 4.0).abs() < 1e-12 && (kinds[1].2 - 2.0).abs() < 1e-12);
        assert_eq!(kinds[2], (EchoKind::Surface, 10.0, 0.0));
    }

    #[test]
    fn absorber_gives_no_echo_and_hides_what_is_behind() {
        let w = world(&[
            (
                Shape::cuboid(DVec3::new(4.0, 0.0, 1.0), DVec3::new(0.5, 40.0, 2.0), 0.0).unwrap(),
                "absorber",
            ),
            (wall_at(10.0), "concrete"),
        ]);
        assert!(echoes_of(&w, &x_ray(), &model(RangeLaw::R2)).is_empty());
    }

    #[test]
    fn mirror_at_45_degrees_gives_a_ghost_at_the_unfolded_path() {
        // A metal plate at x = 5 turned 45°: the ray goes on along +y to a wall at y = 6.
        let mirror = Shape::cuboid(
            DVec3::new(5.0, 0.0, 1.0),
            DVec3::new(0.1, 3.0, 2.0),
            -45f64.to_radians(),
        )
        .unwrap();
        let wall =
            Shape::cuboid(DVec3::new(5.0, 6.1, 1.0), DVec3::new(40.0, 0.2, 2.0), 0.0).unwrap();
        // A perfect mirror: built-in metal without its diffuse share.
        let mut w = world(&[(mirror.clone(), "metal"), (wall.clone(), "concrete")]);
        let mut table = w.materials().clone();
        let metal = table.id("metal").unwrap();
        let smooth = Material {
            radar_diffuse: 0.0,
            ..table.get(metal).clone()
        };
        table.insert(smooth);
        w = World::new(table, w.objects().to_vec());
        let e = echoes_of(&w, &x_ray(), &model(RangeLaw::R2));
        let ghost = e.iter().find(|e| e.bounces == 1).expect("a ghost echo");
        // The mirror's face is 0.05·√2 before its centre line along x.
        let hit = 5.0 - 0.05 * 2f64.sqrt();
        let unfolded = hit + (6.0 - 0.0);
        assert!((ghost.range - unfolded).abs() < 1e-6, "{e:?}");
        assert_eq!(ghost.material, w.materials().id("concrete").unwrap());
        // At 45° a 10° lobe returns nothing above the floor directly.
        assert!(e.iter().all(|e| e.bounces == 1), "{e:?}");

        // Built-in metal scatters its diffuse share at any angle: a direct echo of
        // d·cos 45° (its lobe adds nothing at 45°) at the face, and a ghost weaker by (1 − d)², mirrored twice.
        let rough = world(&[(mirror, "metal"), (wall, "concrete")]);
        let f = echoes_of(&rough, &x_ray(), &model(RangeLaw::R2));
        let direct = f.iter().find(|e| e.bounces == 0).expect("a direct echo");
        assert!((direct.range - hit).abs() < 1e-9, "{f:?}");
        let expect = to_db(METAL_DIFFUSE * 0.5f64.sqrt() / (hit * hit));
        assert!((direct.power_db() - expect).abs() < 1e-9, "{f:?}");
        let rough_ghost = f.iter().find(|e| e.bounces == 1).expect("a ghost echo");
        assert_eq!(rough_ghost.range, ghost.range);
        let weaker = ghost.power_db() - rough_ghost.power_db();
        // Mirrored on the way out and on the way back.
        assert!(
            (weaker + 2.0 * to_db(1.0 - METAL_DIFFUSE)).abs() < 1e-9,
            "{weaker}"
        );
    }

    /// The first `n` echoes above a threshold, by range (ties in the order found): what a
    /// caller that sets [`EchoModel::wanted`] keeps.
    fn kept(echoes: &[Echo], n: usize, threshold: f64) -> Vec<Echo> {
        let mut k: Vec<Echo> = echoes
            .iter()
            .copied()
            .filter(|e| e.power_db() >= threshold)
            .collect();
        k.sort_by(|a, b| a.range.total_cmp(&b.range));
        k.truncate(n);
        k
    }

    proptest::proptest! {
        /// A walk that stops once it has the wanted echoes keeps exactly the echoes (and the
        /// first incidence, when it met a surface) that the whole walk gives: on random worlds
        /// of every material, mirrors and foliage included, from inside objects too.
        #[test]
        fn a_walk_stopped_at_the_wanted_echoes_keeps_the_whole_walks(
            w in crate::world::strategies::arb_world(),
            ray in crate::world::strategies::arb_hard_ray(),
            n in 1usize..6,
            threshold in -90.0f64..-10.0,
        ) {
            let m = EchoModel {
                range_law: RangeLaw::R2,
                dynamic_range_db: 80.0,
                max_bounces: 2,
                min_power_db: f64::NEG_INFINITY,
                wanted: None,
            };
            let capped = EchoModel { wanted: Some((n, threshold)), ..m };
            let mut t = EchoTracer::default();
            let (mut all, mut some) = (Vec::new(), Vec::new());
            let cos_all = t.echoes(&w, &ray, 0.7, 40.0, &m, &mut all);
            let cos_some = t.echoes(&w, &ray, 0.7, 40.0, &capped, &mut some);
            proptest::prop_assert!(some.len() <= all.len());
            proptest::prop_assert_eq!(kept(&some, n, threshold), kept(&all, n, threshold));
            if some.iter().any(|e| e.kind == EchoKind::Surface && e.bounces == 0) {
                proptest::prop_assert_eq!(cos_some, cos_all);
            }
        }
    }
}
