//! The penetration walk: where along a ray a sensor's budget runs out (DESIGN §3.1).
//!
//! The thesis cast one ray per material crossing, recursively. Here the ray's intervals are
//! found once and walked in order: between two events (an entry or an exit) the summed
//! attenuation of the volumes the ray is inside is constant, so the budget falls linearly and
//! the depth where it reaches zero is exact. Radar, laser and ground truth share this walk and
//! differ only in the [`Band`] that says how each material attenuates.
//!
//! A laser in an aerosol (DESIGN §7.6) is given one exponential draw E per ray: the ray
//! returns from the particles where its optical depth ∫k dt reaches E, i.e. from depth d with
//! probability 1 − exp(−k·d). With aerosols modelled, a ray whose budget runs out first is
//! lost (its return is too weak for the link budget) instead of ending exhausted.

use serde::{Deserialize, Serialize};

use crate::world::{Band, Fan, IntervalSource, MaterialId, Ray, RayQuery, World};

/// How a ray ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HitKind {
    /// Stopped at the surface of a material that is solid to this sensor.
    Solid,
    /// Its penetration budget ran out inside penetrable material(s).
    Exhausted,
    /// No return within range.
    None,
}

impl HitKind {
    /// Lowercase name, as in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Solid => "solid",
            Self::Exhausted => "exhausted",
            Self::None => "none",
        }
    }
}

/// Where and why a traced ray ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Return {
    /// Distance from the ray origin; infinite when `kind` is [`HitKind::None`].
    pub range: f64,
    /// How it ended.
    pub kind: HitKind,
    /// The material that stopped it (for an exhausted ray, the most attenuating one it was in).
    pub material: Option<MaterialId>,
}

impl Return {
    /// No return within range.
    pub const NONE: Return = Return {
        range: f64::INFINITY,
        kind: HitKind::None,
        material: None,
    };
}

/// A volume a ray is inside: (exit distance, dB/m, material, aerosol extinction 1/m).
type Active = (f64, f64, MaterialId, f64);

/// A ray tracer with reusable buffers; one per thread.
#[derive(Clone, Debug, Default)]
pub struct Tracer {
    query: RayQuery,
    /// The candidate lists of the scan being traced ([`crate::sensor`] builds them).
    pub(crate) fan: Fan,
    /// Volumes the ray is currently inside: (exit distance, dB/m, material, aerosol
    /// extinction 1/m).
    active: Vec<Active>,
    /// The echo walk's buffers, for sensors with a signal model.
    pub(crate) echo: super::echo::EchoTracer,
    /// One azimuth's echoes of all its beam rays (multi-echo scans).
    pub(crate) beam_echoes: Vec<super::echo::Echo>,
    /// Per beam ray, where its echoes start in `beam_echoes` and its first incidence cosine.
    pub(crate) beam_spans: Vec<(usize, f64)>,
    /// The world bearings of the scan being traced, with its sensor's azimuth table.
    pub(crate) bearings: super::Bearings,
}

impl Tracer {
    /// Walks `ray` through `world` for a sensor of `band` with `budget_db` of penetration,
    /// up to `t_max` metres. Overlapping volumes add their attenuations.
    pub fn trace(
        &mut self,
        world: &World,
        ray: &Ray,
        band: Band,
        budget_db: f64,
        t_max: f64,
    ) -> Return {
        self.trace_from(world, None, ray, band, budget_db, t_max, None)
    }

    /// [`Tracer::trace`] for a ray from the origin of `fan` ([`World::fan`], built for at
    /// least `t_max`) whose direction has bearing `heading`: the same result, found from the
    /// fan's candidate lists instead of a walk through the grid.
    #[allow(clippy::too_many_arguments)]
    pub fn trace_in_fan(
        &mut self,
        world: &World,
        fan: &Fan,
        heading: f64,
        ray: &Ray,
        band: Band,
        budget_db: f64,
        t_max: f64,
    ) -> Return {
        self.trace_from(
            world,
            Some((fan, heading)),
            ray,
            band,
            budget_db,
            t_max,
            None,
        )
    }

    /// [`Tracer::trace`] (through `fan` if given, as [`Tracer::trace_in_fan`]) with aerosol
    /// returns: `optical_depth` is the ray's exponential draw E (see the module doc).
    #[allow(clippy::too_many_arguments)]
    pub fn trace_aerosol(
        &mut self,
        world: &World,
        fan: Option<(&Fan, f64)>,
        ray: &Ray,
        band: Band,
        budget_db: f64,
        t_max: f64,
        optical_depth: f64,
    ) -> Return {
        self.trace_from(world, fan, ray, band, budget_db, t_max, Some(optical_depth))
    }

    #[allow(clippy::too_many_arguments)]
    fn trace_from(
        &mut self,
        world: &World,
        fan: Option<(&Fan, f64)>,
        ray: &Ray,
        band: Band,
        budget_db: f64,
        t_max: f64,
        optical_depth: Option<f64>,
    ) -> Return {
        // The ground plane z = 0 is solid to every sensor; a ray tilted down ends on it.
        let t_ground = if ray.dir.z < 0.0 {
            (-ray.origin.z / ray.dir.z).max(0.0)
        } else {
            f64::INFINITY
        };
        let reach = t_max.min(t_ground);
        let ret = if optical_depth.is_none() && world.is_binary(band) {
            // Nothing to spend a budget in: the ray ends at its first solid entry, exactly
            // where the walk below would end it.
            match world.first_solid(fan, ray, reach, band, &mut self.query) {
                Some((t_in, material)) if t_in.max(0.0) < reach => Return {
                    range: t_in.max(0.0),
                    kind: HitKind::Solid,
                    material: Some(material),
                },
                _ => Return::NONE,
            }
        } else {
            let mut intervals = match fan {
                Some((fan, heading)) => {
                    world.fan_intervals(fan, ray, heading, reach, Some(band), &mut self.query)
                }
                None => world.ordered_intervals(ray, reach, Some(band), &mut self.query),
            };
            walk(
                &mut intervals,
                world,
                band,
                budget_db,
                reach,
                optical_depth,
                &mut self.active,
            )
        };
        if ret.kind == HitKind::None && t_ground <= t_max {
            return Return {
                range: t_ground,
                kind: HitKind::Solid,
                material: Some(world.ground_material()),
            };
        }
        ret
    }
}

/// The walk proper over the ray's intervals up to `t_max`. It asks `intervals` for the next
/// entry only as far as the walk can get without it (the next exit, `t_max`, or where the
/// budget runs out), so that a front-to-back source does no work behind the ray's end.
/// `optical_depth`: the ray's aerosol draw, if aerosols are modelled.
fn walk(
    intervals: &mut impl IntervalSource,
    world: &World,
    band: Band,
    budget_db: f64,
    t_max: f64,
    optical_depth: Option<f64>,
    active: &mut Vec<Active>,
) -> Return {
    let materials = world.materials();
    active.clear();
    let mut budget = budget_db;
    // Optical depth still to go before a particle return.
    let mut to_particle = optical_depth.unwrap_or(f64::INFINITY);
    let mut t = 0.0;
    loop {
        let (exit_slot, t_exit) = active
            .iter()
            .enumerate()
            .map(|(i, a)| (i, a.0))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((usize::MAX, f64::INFINITY));
        let alpha: f64 = active.iter().map(|a| a.1).sum();
        // Beyond this the budget is surely spent (the margin dwarfs rounding), so an entry
        // there cannot change the result and need not be looked for.
        let spent_by = if alpha > 0.0 {
            t + budget / alpha * (1.0 + 1e-9) + 1e-12
        } else {
            f64::INFINITY
        };
        let entry = intervals.peek(t_exit.min(t_max).min(spent_by));
        let t_entry = entry.map_or(f64::INFINITY, |iv| iv.t_in.max(0.0));
        let t_next = t_entry.min(t_exit).min(t_max);
        // Aerosols only where they are modelled: the thesis walk pays nothing for them.
        let kappa: f64 = if optical_depth.is_some() {
            active.iter().map(|a| a.3).sum()
        } else {
            0.0
        };
        if kappa > 0.0 {
            // The particles return the ray before the segment ends and before the budget is
            // spent: the laser sees the aerosol as a surface there.
            let t_particle = t + to_particle / kappa;
            let t_spent = if alpha > 0.0 {
                t + budget / alpha
            } else {
                f64::INFINITY
            };
            if t_particle < t_next && t_particle < t_spent {
                let densest = active.iter().max_by(|a, b| a.3.total_cmp(&b.3));
                return Return {
                    range: t_particle,
                    kind: HitKind::Solid,
                    material: densest.map(|a| a.2),
                };
            }
            to_particle -= kappa * (t_next - t);
        }
        if alpha > 0.0 {
            let cost = alpha * (t_next - t);
            if cost >= budget {
                if optical_depth.is_some() {
                    // Too weak for the link budget: lost.
                    return Return::NONE;
                }
                let densest = active.iter().max_by(|a, b| a.1.total_cmp(&b.1));
                return Return {
                    range: t + budget / alpha,
                    kind: HitKind::Exhausted,
                    material: densest.map(|a| a.2),
                };
            }
            budget -= cost;
        }
        t = t_next;
        if t >= t_max {
            return Return::NONE;
        }
        match entry {
            Some(iv) if t_entry <= t_exit => {
                intervals.pop();
                let m = materials.get(iv.material);
                let a = m.attenuation_db_per_m(band);
                if a.is_infinite() {
                    return Return {
                        range: t,
                        kind: HitKind::Solid,
                        material: Some(iv.material),
                    };
                }
                let k = if optical_depth.is_some() && band == Band::Laser && m.laser_aerosol() {
                    m.laser_extinction_per_m
                } else {
                    0.0
                };
                if a > 0.0 || k > 0.0 {
                    active.push((iv.t_out, a, iv.material, k));
                }
            }
            _ => {
                active.swap_remove(exit_slot);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{MaterialTable, Shape, SortedIntervals};
    use glam::DVec3;
    use proptest::prelude::{Just, prop_oneof};

    use crate::world::strategies::world_of as world;

    fn x_ray(y: f64) -> Ray {
        Ray::new(DVec3::new(0.0, y, 1.0), DVec3::X)
    }

    fn sphere(x: f64, y: f64, r: f64) -> Shape {
        Shape::sphere(DVec3::new(x, y, 1.0), r).unwrap()
    }

    /// A penetrable crown mesh spends the budget over its chord as the sphere it tessellates
    /// does: a 3 dB budget in a dense crown (3 dB/m) runs out 1 m in, whichever of the two;
    /// a laser stops at its surface; a body overlapping it is blocked.
    #[test]
    fn a_crown_mesh_spends_the_budget_like_its_sphere() {
        let mesh = crate::world::mesh::tests::uv_sphere(DVec3::new(5.0, 0.0, 1.0), 1.5, 48, 96);
        let mesh = Shape::Mesh(std::sync::Arc::new(mesh));
        let analytic = sphere(5.0, 0.0, 1.5);
        let mut t = Tracer::default();
        for y in [0.0, 0.4, -0.7, 1.1] {
            let a = t.trace(
                &world(&[(analytic.clone(), "foliage_dense")]),
                &x_ray(y),
                Band::Radar,
                3.0,
                30.0,
            );
            let m = t.trace(
                &world(&[(mesh.clone(), "foliage_dense")]),
                &x_ray(y),
                Band::Radar,
                3.0,
                30.0,
            );
            assert_eq!(
                (a.kind, m.kind),
                (HitKind::Exhausted, HitKind::Exhausted),
                "y {y}"
            );
            // The mesh lies inside the sphere by at most 1.5 (1 − cos(π/48)) ≈ 3.2 mm radially.
            assert!(
                (a.range - m.range).abs() < 0.01,
                "y {y}: {} vs {}",
                a.range,
                m.range
            );
            let entry = 5.0 - (1.5f64 * 1.5 - y * y).sqrt();
            assert!((a.range - (entry + 1.0)).abs() < 1e-9);
            let l = t.trace(
                &world(&[(mesh.clone(), "foliage_dense")]),
                &x_ray(y),
                Band::Laser,
                3.0,
                30.0,
            );
            assert_eq!(l.kind, HitKind::Solid);
            assert!((l.range - entry).abs() < 0.01, "laser {}", l.range);
        }
        let w = world(&[(mesh, "wood")]);
        let body = |x: f64| crate::world::overlap::body_box(x, 0.0, 0.3, 0.5, 0.5, 0.3);
        assert_eq!(w.blocking_object(&body(3.5)), Some(0));
        assert_eq!(
            w.blocking_object(&body(5.0)),
            Some(0),
            "inside the closed mesh"
        );
        assert_eq!(w.blocking_object(&body(2.9)), None);
    }

    #[test]
    fn budget_runs_out_at_the_exact_depth() {
        // foliage_dense is 3 dB/m: a 1.5 dB budget lasts 0.5 m past the entry at x = 4.
        let w = world(&[(sphere(5.0, 0.0, 1.0), "foliage_dense")]);
        let r = Tracer::default().trace(&w, &x_ray(0.0), Band::Radar, 1.5, 20.0);
        assert_eq!(r.kind, HitKind::Exhausted);
        assert!((r.range - 4.5).abs() < 1e-12, "{r:?}");
        assert_eq!(r.material, w.materials().id("foliage_dense"));
    }

    /// Laser rays into an aerosol return from its particles at depth d with probability
    /// 1 − exp(−k·d): over many seeded rays the share of returns before each depth lies in
    /// the 99.9 % binomial band around it; past the link budget no return comes back; a
    /// wall inside the cloud returns the rays that reach it.
    #[test]
    fn laser_returns_from_an_aerosol_follow_beer_lambert() {
        use rand::{Rng, SeedableRng};
        let w = world(&[
            (sphere(6.0, 0.0, 5.0), "dust"),
            (sphere(2.0, 0.0, 0.5), "concrete"),
        ]);
        let dust = w.materials().get(w.materials().id("dust").unwrap());
        let k = dust.laser_extinction_per_m;
        assert!(dust.laser_aerosol() && k > 1.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut tracer = Tracer::default();
        let n = 20_000;
        // A budget that outlasts the cloud: every ray returns from the dust or from the post
        // at x = 1.5 (0.5 m into the cloud).
        let depths: Vec<Return> = (0..n)
            .map(|_| {
                let e: f64 = rng.sample(rand_distr::Exp1);
                tracer.trace_aerosol(&w, None, &x_ray(0.0), Band::Laser, 1e4, 30.0, e)
            })
            .collect();
        for d in [0.05, 0.1, 0.2, 0.3, 0.4] {
            let p = 1.0 - (-k * d).exp();
            let share = depths.iter().filter(|r| r.range - 1.0 <= d).count() as f64 / n as f64;
            let band = 3.29 * (p * (1.0 - p) / n as f64).sqrt();
            assert!((share - p).abs() < band, "d {d}: {share} vs {p} ± {band}");
        }
        assert!(depths.iter().all(|r| r.kind == HitKind::Solid));
        let dust_id = w.materials().id("dust");
        assert!(depths.iter().all(|r| r.range <= 1.5 + 1e-9));
        let posts = depths.iter().filter(|r| r.material != dust_id).count();
        let p = (-k * 0.5f64).exp();
        let band = 3.29 * (p * (1.0 - p) / n as f64).sqrt();
        assert!((posts as f64 / n as f64 - p).abs() < band, "{posts}");
        // With a 6 dB budget (spent 6 / (4.343 k) = 0.3 m in, before the post), the rays
        // that get that far are lost: a share exp(−6 / 4.343).
        let budget = 6.0;
        let lost = (0..n)
            .filter(|_| {
                let e: f64 = rng.sample(rand_distr::Exp1);
                let r = tracer.trace_aerosol(&w, None, &x_ray(0.0), Band::Laser, budget, 30.0, e);
                assert!(r.kind != HitKind::Exhausted);
                r.kind == HitKind::None
            })
            .count();
        let p = (-budget / crate::world::DB_PER_UNIT_EXTINCTION).exp();
        let band = 3.29 * (p * (1.0 - p) / n as f64).sqrt();
        assert!((lost as f64 / n as f64 - p).abs() < band, "lost {lost}");
        // The radar and an opaque-laser world ignore the draw.
        let r = tracer.trace_aerosol(&w, None, &x_ray(0.0), Band::Radar, 3.0, 30.0, 1e-6);
        assert_eq!(r, tracer.trace(&w, &x_ray(0.0), Band::Radar, 3.0, 30.0));
    }

    #[test]
    fn thin_chord_is_seen_through() {
        // At offset 0.8 the chord is 2·sqrt(1 - 0.64) = 1.2 m: 3.6 dB < 4 dB, so the ray passes
        // and hits the wall behind.
        let w = world(&[
            (sphere(5.0, 0.0, 1.0), "foliage_dense"),
            (
                Shape::cuboid(DVec3::new(10.0, 0.0, 1.0), DVec3::new(0.2, 10.0, 2.0), 0.0).unwrap(),
                "concrete",
            ),
        ]);
        let mut tr = Tracer::default();
        let edge = tr.trace(&w, &x_ray(0.8), Band::Radar, 4.0, 20.0);
        assert_eq!(edge.kind, HitKind::Solid);
        assert!((edge.range - 9.9).abs() < 1e-12);
        let core = tr.trace(&w, &x_ray(0.0), Band::Radar, 4.0, 20.0);
        assert_eq!(core.kind, HitKind::Exhausted);
        assert!((core.range - (4.0 + 4.0 / 3.0)).abs() < 1e-12);
        // The laser stops at the foliage surface: x = 5 - 0.6.
        let laser = tr.trace(&w, &x_ray(0.8), Band::Laser, 4.0, 20.0);
        assert_eq!(laser.kind, HitKind::Solid);
        assert!((laser.range - 4.4).abs() < 1e-12);
    }

    #[test]
    fn overlapping_volumes_add_attenuation() {
        // Two concentric foliage spheres: inside both the loss is 3 + 1.55 dB/m.
        let w = world(&[
            (sphere(5.0, 0.0, 2.0), "foliage_light"),
            (sphere(5.0, 0.0, 1.0), "foliage_dense"),
        ]);
        // Budget: 1 m of light (1.55 dB), then 0.5 m of both (2.275 dB).
        let budget = 1.55 + 0.5 * 4.55;
        let r = Tracer::default().trace(&w, &x_ray(0.0), Band::Radar, budget, 20.0);
        assert_eq!(r.kind, HitKind::Exhausted);
        assert!((r.range - 4.5).abs() < 1e-9, "{r:?}");
        assert_eq!(r.material, w.materials().id("foliage_dense"));
    }

    #[test]
    fn solid_inside_foliage_is_returned_when_budget_suffices() {
        // A metal pole at the centre of a bush: 1 m of foliage (3 dB) before the pole.
        let w = world(&[
            (sphere(5.0, 0.0, 1.5), "foliage_dense"),
            (
                Shape::cylinder(DVec3::new(5.0, 0.0, 1.0), 0.5, 2.0).unwrap(),
                "metal",
            ),
        ]);
        let mut tr = Tracer::default();
        let r = tr.trace(&w, &x_ray(0.0), Band::Radar, 3.5, 20.0);
        assert_eq!(
            (r.kind, r.material),
            (HitKind::Solid, w.materials().id("metal"))
        );
        assert!((r.range - 4.5).abs() < 1e-12);
        let short = tr.trace(&w, &x_ray(0.0), Band::Radar, 2.5, 20.0);
        assert_eq!(short.kind, HitKind::Exhausted);
        assert!((short.range - (3.5 + 2.5 / 3.0)).abs() < 1e-12);
    }

    #[test]
    fn smoke_is_clear_to_radar_and_opaque_to_laser() {
        let w = world(&[(sphere(5.0, 0.0, 1.0), "smoke")]);
        let mut tr = Tracer::default();
        let radar = tr.trace(&w, &x_ray(0.0), Band::Radar, 1.0, 20.0);
        assert_eq!((radar.kind, radar.range), (HitKind::None, f64::INFINITY));
        let laser = tr.trace(&w, &x_ray(0.0), Band::Laser, 1.0, 20.0);
        assert_eq!(laser.kind, HitKind::Solid);
        assert!((laser.range - 4.0).abs() < 1e-12);
    }

    proptest::proptest! {
        /// Pruning behind the nearest solid never changes where a ray ends.
        #[test]
        fn pruned_trace_equals_walk_over_all_intervals(
            spheres in proptest::collection::vec(
                ((-20.0..20.0f64, -20.0..20.0f64, 0.0..2.0f64), 0.2..3.0f64, 0usize..9), 1..60),
            // Level or rising rays: the ground plane is a separate case with its own test.
            rays in proptest::collection::vec(((-1.0..1.0f64, -1.0..1.0f64), 0.0..0.2f64), 1..10),
            budget in 0.1..12.0f64,
        ) {
            let names: Vec<String> = MaterialTable::default().names().iter().map(|n| n.to_string()).collect();
            let objects: Vec<(Shape, &str)> = spheres
                .iter()
                .map(|((x, y, z), r, m)| (Shape::sphere(DVec3::new(*x, *y, *z), *r).unwrap(), names[*m].as_str()))
                .collect();
            let w = world(&objects);
            let (mut tr, mut q, mut active) = (Tracer::default(), RayQuery::default(), Vec::new());
            for ((dx, dy), dz) in rays {
                let d = DVec3::new(dx, dy, dz);
                if d.length() < 1e-3 {
                    continue;
                }
                let ray = Ray::new(DVec3::new(0.0, 0.0, 0.5), d);
                for band in [Band::Radar, Band::Laser, Band::Surface] {
                    let pruned = tr.trace(&w, &ray, band, budget, 30.0);
                    let all = w.ray_intervals_exhaustive(&ray, 30.0, &mut q);
                    let whole = walk(&mut SortedIntervals::new(all), &w, band, budget, 30.0, None, &mut active);
                    proptest::prop_assert_eq!(pruned, whole);
                }
            }
        }
    }

    proptest::proptest! {
        /// The front-to-back walk over the grid ends every ray exactly where the walk over
        /// the exhaustive interval list does: any shapes of any material, rays starting inside
        /// objects, on cell boundaries and along the axes, every band, any budget.
        #[test]
        fn ordered_trace_equals_walk_over_exhaustive_intervals(
            w in crate::world::strategies::arb_world(),
            rays in proptest::collection::vec(crate::world::strategies::arb_hard_ray(), 1..16),
            budget in prop_oneof![Just(0.0), 0.0..12.0f64, Just(f64::INFINITY)],
            t_max in 0.5..40.0f64,
        ) {
            let (mut tr, mut q, mut active) = (Tracer::default(), RayQuery::default(), Vec::new());
            for ray in rays {
                // Level and rising rays: a falling one may end on the ground, which `trace`
                // adds after the walk.
                let ray = Ray { dir: DVec3::new(ray.dir.x, ray.dir.y, ray.dir.z.abs()), ..ray };
                for band in [Band::Radar, Band::Laser, Band::Surface] {
                    let ordered = tr.trace(&w, &ray, band, budget, t_max);
                    let all = w.ray_intervals_exhaustive(&ray, t_max, &mut q);
                    let whole =
                        walk(&mut SortedIntervals::new(all), &w, band, budget, t_max, None, &mut active);
                    proptest::prop_assert_eq!(ordered, whole, "{:?} {:?}", ray, band);
                }
            }
        }
    }

    proptest::proptest! {
        /// Rays of one origin traced through a fan's candidate lists end exactly where the
        /// walk over the exhaustive interval list ends them: any world, origins inside objects,
        /// any number of sectors, rays level or rising, headings of any turn.
        #[test]
        fn fan_trace_equals_walk_over_exhaustive_intervals(
            w in crate::world::strategies::arb_world(),
            origin in crate::world::strategies::arb_ray(),
            sectors in prop_oneof![Just(1usize), 1usize..20, 20usize..5000],
            rays in proptest::collection::vec((-20.0..20.0f64, 0.0..0.4f64), 1..24),
            budget in prop_oneof![Just(0.0), 0.0..12.0f64, Just(f64::INFINITY)],
            t_max in 0.5..40.0f64,
        ) {
            let (mut tr, mut q, mut active) = (Tracer::default(), RayQuery::default(), Vec::new());
            let mut fan = crate::world::Fan::default();
            proptest::prop_assert!(w.fan(origin.origin, t_max, sectors, usize::MAX, &mut fan));
            for (heading, el) in rays {
                let (s, c) = heading.sin_cos();
                let ray = Ray { origin: origin.origin, dir: DVec3::new(el.cos() * c, el.cos() * s, el.sin()) };
                for band in [Band::Radar, Band::Laser, Band::Surface] {
                    let fanned = tr.trace_in_fan(&w, &fan, heading, &ray, band, budget, t_max);
                    let all = w.ray_intervals_exhaustive(&ray, t_max, &mut q);
                    let whole =
                        walk(&mut SortedIntervals::new(all), &w, band, budget, t_max, None, &mut active);
                    proptest::prop_assert_eq!(fanned, whole, "{:?} heading {} {:?}", ray, heading, band);
                }
            }
        }
    }

    /// Every band's trace of `ray` along the grid and through `fan` (made at the ray's origin;
    /// `heading`: the ray's bearing) ends where the walk over the exhaustive intervals does;
    /// `state` is kept from ray to ray, as a scan keeps it.
    fn traces_equal_walk(
        (tr, q, active): &mut (Tracer, RayQuery, Vec<Active>),
        w: &World,
        fan: &Fan,
        heading: f64,
        ray: &Ray,
        budget: f64,
        t_max: f64,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        for band in [Band::Radar, Band::Laser, Band::Surface] {
            let all = w.ray_intervals_exhaustive(ray, t_max, q);
            let whole = walk(
                &mut SortedIntervals::new(all),
                w,
                band,
                budget,
                t_max,
                None,
                active,
            );
            let gridded = tr.trace(w, ray, band, budget, t_max);
            proptest::prop_assert_eq!(gridded, whole, "{:?} {:?}", ray, band);
            let fanned = tr.trace_in_fan(w, fan, heading, ray, band, budget, t_max);
            proptest::prop_assert_eq!(fanned, whole, "{:?} {:?} fan", ray, band);
        }
        Ok(())
    }

    proptest::proptest! {
        /// In a world whose materials are all solid or transparent, every band takes the
        /// first-solid query (along the grid, and through a fan) instead of the walk, and
        /// ends every ray exactly where the walk over the exhaustive list does: origins
        /// inside objects, rays along the axes and on cell boundaries, any budget.
        #[test]
        fn first_solid_trace_equals_walk_over_exhaustive_intervals(
            w in crate::world::strategies::arb_binary_world(),
            rays in proptest::collection::vec(crate::world::strategies::arb_hard_ray(), 1..16),
            sectors in prop_oneof![Just(1usize), 1usize..5000],
            budget in prop_oneof![Just(0.0), 0.0..12.0f64, Just(f64::INFINITY)],
            t_max in 0.5..40.0f64,
        ) {
            let mut state = (Tracer::default(), RayQuery::default(), Vec::new());
            let mut fan = crate::world::Fan::default();
            for band in [Band::Radar, Band::Laser, Band::Surface] {
                proptest::prop_assert!(w.is_binary(band));
            }
            for ray in rays {
                let ray = Ray { dir: DVec3::new(ray.dir.x, ray.dir.y, ray.dir.z.abs()), ..ray };
                let heading = ray.dir.y.atan2(ray.dir.x);
                proptest::prop_assert!(w.fan(ray.origin, t_max, sectors, usize::MAX, &mut fan));
                traces_equal_walk(&mut state, &w, &fan, heading, &ray, budget, t_max)?;
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
        /// Generated trees and bushes (closed meshes of wood and foliage, each a union of
        /// overlapping leaf clusters): the mesh searches that stop once the answer is settled
        /// end every ray where the walk over every mesh's whole-line intervals does. Every
        /// band (the laser through the first-solid query, foliage being solid to it), along
        /// the grid and through a fan, from inside crowns and under them, level or rising.
        #[test]
        fn plant_forest_trace_equals_walk_over_exhaustive_intervals(
            count in 1usize..8,
            seed in 0u64..1000,
            rays in proptest::collection::vec(
                ((-5.0..5.0f64, -5.0..5.0f64, 0.0..4.0f64), -3.2..3.2f64, 0.0..0.5f64), 1..12),
            budget in prop_oneof![Just(0.0), 0.0..12.0f64, Just(f64::INFINITY)],
            t_max in 0.5..20.0f64,
        ) {
            let spec = crate::world::forest::ForestSpec {
                count, side: 10.0, radius: (0.3, 1.0), clearing: 0.0, seed,
            };
            let w = crate::world::forest::plant_forest_of(&spec);
            proptest::prop_assert!(w.is_binary(Band::Laser));
            let mut state = (Tracer::default(), RayQuery::default(), Vec::new());
            let mut fan = crate::world::Fan::default();
            for ((x, y, z), heading, el) in rays {
                let (s, c) = heading.sin_cos();
                let ray = Ray::new(DVec3::new(x, y, z), DVec3::new(el.cos() * c, el.cos() * s, el.sin()));
                proptest::prop_assert!(w.fan(ray.origin, t_max, 360, usize::MAX, &mut fan));
                traces_equal_walk(&mut state, &w, &fan, heading, &ray, budget, t_max)?;
            }
        }
    }

    /// A dense thicket of foliage spheres and posts, many to a grid cell, walked by rays that
    /// often end inside foliage: the walk must look for the next entry exactly as far as the
    /// budget reaches.
    #[test]
    fn ordered_trace_equals_exhaustive_walk_in_a_dense_thicket() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut objects = Vec::new();
        for k in 0..1500 {
            let (x, y) = (rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0));
            let shape = if k % 5 == 0 {
                Shape::cylinder(DVec3::new(x, y, 1.0), rng.random_range(0.03..0.1), 2.0)
            } else {
                Shape::sphere(DVec3::new(x, y, 0.5), rng.random_range(0.1..0.6))
            };
            let m = [
                "concrete",
                "foliage_dense",
                "foliage_light",
                "dust",
                "glass",
            ][k % 5];
            objects.push((shape.unwrap(), m));
        }
        let w = world(&objects);
        let (mut tr, mut q, mut active) = (Tracer::default(), RayQuery::default(), Vec::new());
        let mut exhausted = 0;
        for i in 0..4000 {
            let a = f64::from(i) * 0.618_034 * std::f64::consts::TAU;
            let o = DVec3::new(
                f64::from(i % 50) * 0.6 - 15.0,
                f64::from(i / 50) * 0.37 - 15.0,
                0.5,
            );
            let ray = Ray::new(o, DVec3::new(a.cos(), a.sin(), 0.0));
            for (band, budget) in [(Band::Radar, 0.5 + f64::from(i % 9)), (Band::Laser, 2.0)] {
                let ordered = tr.trace(&w, &ray, band, budget, 30.0);
                let all = w.ray_intervals_exhaustive(&ray, 30.0, &mut q);
                let whole = walk(
                    &mut SortedIntervals::new(all),
                    &w,
                    band,
                    budget,
                    30.0,
                    None,
                    &mut active,
                );
                assert_eq!(ordered, whole, "ray {i} {band:?}");
                exhausted += usize::from(ordered.kind == HitKind::Exhausted);
            }
        }
        assert!(exhausted > 1000, "{exhausted}");
    }

    #[test]
    fn a_ray_tilted_down_ends_on_the_ground_unless_something_is_nearer() {
        let w = world(&[(sphere(5.0, 0.0, 1.0), "smoke")]);
        let mut tr = Tracer::default();
        let el = 10f64.to_radians();
        let down = Ray::new(
            DVec3::new(0.0, 3.0, 0.4),
            DVec3::new(el.cos(), 0.0, -el.sin()),
        );
        let r = tr.trace(&w, &down, Band::Radar, 3.0, 20.0);
        assert_eq!(
            (r.kind, r.material),
            (HitKind::Solid, Some(w.ground_material()))
        );
        assert!((r.range - 0.4 / el.sin()).abs() < 1e-12);
        // Out of range: no return.
        assert_eq!(
            tr.trace(&w, &down, Band::Radar, 3.0, 2.0).kind,
            HitKind::None
        );
        // The laser meets the smoke before the ground.
        let into_smoke = Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.0, -0.1));
        let l = tr.trace(&w, &into_smoke, Band::Laser, 3.0, 20.0);
        assert_eq!(l.material, w.materials().id("smoke"));
        assert!(l.range < 5.0);
    }

    #[test]
    fn nothing_within_range_gives_infinity_and_ray_starting_inside_pays_from_zero() {
        let w = world(&[(sphere(5.0, 0.0, 1.0), "concrete")]);
        let mut tr = Tracer::default();
        assert_eq!(
            tr.trace(&w, &x_ray(0.0), Band::Radar, 3.0, 3.9).kind,
            HitKind::None
        );
        let w = world(&[(sphere(0.0, 0.0, 2.0), "foliage_dense")]);
        let r = tr.trace(&w, &x_ray(0.0), Band::Radar, 3.0, 20.0);
        assert!((r.range - 1.0).abs() < 1e-12 && r.kind == HitKind::Exhausted);
    }
}
