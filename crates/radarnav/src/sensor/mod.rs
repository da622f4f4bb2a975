//! Range sensors: the thesis radar, laser scanners and ground truth (DESIGN §3).
//!
//! A [`Scan`] follows ROS `LaserScan` semantics (`+inf` = no return within range, `-inf` = a
//! return closer than `range_min`, REP-117) and adds, per ray, how it ended, the material that
//! stopped it and which of the three side beams was reported.

pub mod cfar;
pub mod config;
pub mod echo;
pub mod image;
mod returns;
pub mod signal;
pub mod trace;

pub use config::{MAX_RAYS, PRESETS, Preset, RangeNoise, SensorConfig, SensorKind, preset};
pub use echo::{Echo, EchoKind, RangeLaw};
pub use signal::{ImageConfig, ReturnMode, Selection, SignalConfig};
pub use trace::{HitKind, Return, Tracer};

use glam::DVec3;
use rand::Rng;
use rand_distr::{Exp1, StandardNormal};
use rayon::prelude::*;
use serde::Serialize;

use crate::pose::Pose;
use crate::world::{MaterialId, Ray, World};

/// Scans with at least this many rays are traced on all cores (rayon; `RAYON_NUM_THREADS`
/// sets how many). Below it, waking the pool costs more than it saves: a 1081-ray laser scan
/// (about 0.2 ms of work) ran a 10-minute simulation slower on two threads than on one.
pub const PARALLEL_MIN_RAYS: usize = 4096;

/// Rays per task when a scan is shared among threads.
const PARALLEL_CHUNK: usize = 256;

thread_local! {
    /// The tracer of each thread that takes part in parallel work: its buffers (sized to the
    /// world) are kept from task to task.
    static POOL_TRACER: std::cell::Cell<Tracer> = std::cell::Cell::new(Tracer::default());
}

/// Runs `f` with this thread's pool tracer. The tracer is taken out while `f` runs, so a task
/// that rayon starts on this thread meanwhile (while `f` waits on nested work) gets a fresh
/// one instead of a second borrow.
pub(crate) fn with_pool_tracer<T>(f: impl FnOnce(&mut Tracer) -> T) -> T {
    let mut tracer = POOL_TRACER.take();
    let out = f(&mut tracer);
    POOL_TRACER.set(tracer);
    out
}

/// A scan's fan ([`World::fan`]) has about this many rays per azimuth sector.
const RAYS_PER_SECTOR: f64 = 4.0;
/// A scan builds a fan only while the parts in range are at most its rays divided by this:
/// filing a part costs about as much as walking a ray through the grid.
const PARTS_PER_RAY_FOR_FAN: usize = 4;

/// Which of the thesis' three parallel rays a reading came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Beam {
    /// The nominal ray.
    Center,
    /// The ray offset `side_beam_offset` to the left (counter-clockwise side).
    Left,
    /// The ray offset to the right.
    Right,
}

impl Beam {
    /// Lowercase name, as in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Center => "center",
            Self::Left => "left",
            Self::Right => "right",
        }
    }

    /// Signed multiple of the side-beam offset, towards the ray's left.
    pub fn side(self) -> f64 {
        match self {
            Self::Center => 0.0,
            Self::Left => 1.0,
            Self::Right => -1.0,
        }
    }
}

/// One scan. Rays are stored plane by plane: index = elevation index × azimuths + azimuth index.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Scan {
    /// Simulation time, seconds.
    pub stamp: f64,
    /// Sensor model.
    pub kind: SensorKind,
    /// Sensor pose in the world frame.
    pub pose: Pose,
    /// Azimuth of the first ray relative to the sensor's x axis, radians.
    pub angle_min: f64,
    /// Azimuth step, radians.
    pub angle_increment: f64,
    /// Rays per plane.
    pub azimuths: usize,
    /// Elevation of each plane, radians.
    pub elevations: Vec<f64>,
    /// Minimum valid range, metres.
    pub range_min: f64,
    /// Maximum range, metres.
    pub range_max: f64,
    /// Side-beam offset in use, metres.
    pub side_beam_offset: f64,
    /// Reported ranges, metres (ROS semantics; `null` in JSON where not finite).
    pub ranges: Vec<f32>,
    /// How each ray ended.
    pub hits: Vec<HitKind>,
    /// Material that ended each ray.
    pub materials: Vec<Option<MaterialId>>,
    /// Which side beam each reading came from.
    pub beams: Vec<Beam>,
    /// Echoes of every ray in `all` mode, ray after ray, each ray's by range (DESIGN §7.3);
    /// empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub echoes: Vec<Echo>,
    /// Where each ray's echoes start in `echoes`, one more entry than rays; empty when
    /// `echoes` is unused.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub echo_start: Vec<u32>,
}

impl Scan {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    /// Whether the scan has no rays.
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// (azimuth relative to the sensor, elevation) of ray `i`, radians.
    pub fn angles(&self, i: usize) -> (f64, f64) {
        let (plane, az) = (i / self.azimuths, i % self.azimuths);
        (self.azimuth(az), self.elevations[plane])
    }

    /// Whether each plane's rays cover the whole circle round the sensor (a scanning radar),
    /// so that nothing round it is hidden, unlike the back of a 270° laser.
    pub fn full_circle(&self) -> bool {
        self.angle_increment * self.azimuths as f64 >= std::f64::consts::TAU - 1e-9
    }

    /// Azimuth of the `k`-th ray of each plane in the sensor frame, rad.
    pub fn azimuth(&self, k: usize) -> f64 {
        self.angle_min + k as f64 * self.angle_increment
    }

    /// Each scan plane's elevation, rad, with the indices of its rays in `ranges`: the
    /// rays plane by plane without a division per ray, as [`Scan::angles`] numbers them.
    pub fn planes(&self) -> impl Iterator<Item = (f64, std::ops::Range<usize>)> + '_ {
        let (n, len) = (self.azimuths, self.len());
        (self.elevations.iter().enumerate())
            .map(move |(p, &el)| (el, (p * n).min(len)..((p + 1) * n).min(len)))
    }

    /// Ray `i` as cast: from its (possibly side-offset) origin, in the world frame.
    pub fn ray(&self, i: usize) -> Ray {
        let (az, el) = self.angles(i);
        beam_ray(
            &self.pose,
            az,
            el.sin_cos(),
            self.beams[i].side() * self.side_beam_offset,
        )
    }

    /// The echoes of ray `i` (empty unless the scan was taken in `all` mode).
    pub fn echoes_of(&self, i: usize) -> &[Echo] {
        match (self.echo_start.get(i), self.echo_start.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.echoes[a as usize..b as usize],
            _ => &[],
        }
    }

    /// The world point of a finite reading, `None` for `±inf`.
    pub fn endpoint(&self, i: usize) -> Option<DVec3> {
        let r = self.ranges[i];
        r.is_finite().then(|| self.ray(i).at(f64::from(r)))
    }
}

/// The ray at azimuth `az` and elevation `el` (given as its sine and cosine, the same for a
/// whole plane) from a sensor at `pose`, its origin shifted `lateral` metres to the ray's
/// left, perpendicular to it in the scan plane.
pub fn beam_ray(pose: &Pose, az: f64, el: (f64, f64), lateral: f64) -> Ray {
    beam_ray_toward(pose, (pose.yaw + az).sin_cos(), el, lateral)
}

/// [`beam_ray`] for a ray whose world bearing has sine and cosine `(s, c)`.
fn beam_ray_toward(pose: &Pose, (s, c): (f64, f64), (se, ce): (f64, f64), lateral: f64) -> Ray {
    let dir = DVec3::new(ce * c, ce * s, se);
    let left = DVec3::new(-s, c, 0.0);
    Ray {
        origin: pose.position() + left * lateral,
        dir,
    }
}

/// The sines and cosines of a scan's azimuths relative to the sensor, kept from scan to scan
/// (a sensor's azimuths do not change): a scan turns them by its yaw with four products per
/// ray instead of a sine and a cosine (DESIGN §11), an echo scan one table per offset in
/// azimuth of its beam's rays. The turned values differ from `sin_cos(yaw + az)`
/// ([`beam_ray`]) by a few units in the last place, far below a reading's rounding to `f32`
/// (though a hit exactly on a map cell's border may fall to its other side). A tracer serves
/// every sensor of a run in turn (a radar and a laser alternate), so it keeps one table per
/// azimuth layout.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bearings {
    /// Per layout, its sines and cosines.
    tables: Vec<(AzimuthLayout, Vec<(f64, f64)>)>,
    /// The last scan's world bearings.
    turned: Vec<(f64, f64)>,
}

/// A scan's azimuths: first, increment (as bits) and count.
type AzimuthLayout = (u64, u64, usize);

/// Azimuth layouts a tracer keeps tables for; more are dropped and remade (a robot has a few
/// sensors, and a radar's beam one layout per ray offset in azimuth).
const BEARING_TABLES: usize = signal::MAX_BEAM_RAYS + 8;

impl Bearings {
    /// Sine and cosine of the world bearing of each of `n` azimuths `first + k * step` from a
    /// sensor at heading `yaw`.
    fn turned(&mut self, yaw: f64, first: f64, step: f64, n: usize) -> &[(f64, f64)] {
        self.turned_from(yaw, &[first], step, n)
    }

    /// [`Bearings::turned`] for several first azimuths (a beam's rays off the boresight in
    /// azimuth), one after the other: entry `j * n + k` is azimuth `firsts[j] + k * step`.
    fn turned_from(&mut self, yaw: f64, firsts: &[f64], step: f64, n: usize) -> &[(f64, f64)] {
        let (sy, cy) = yaw.sin_cos();
        self.turned.clear();
        for &first in firsts {
            let key = (first.to_bits(), step.to_bits(), n);
            let k = match self.tables.iter().position(|t| t.0 == key) {
                Some(k) => k,
                None => {
                    if self.tables.len() >= BEARING_TABLES {
                        self.tables.clear();
                    }
                    let table = (0..n)
                        .map(|k| (first + k as f64 * step).sin_cos())
                        .collect();
                    self.tables.push((key, table));
                    self.tables.len() - 1
                }
            };
            self.turned.extend(
                (self.tables[k].1.iter()).map(|&(sa, ca)| (sy * ca + cy * sa, cy * ca - sy * sa)),
            );
        }
        &self.turned
    }
}

/// The random draws of one scan, in ray order: which side beam each ray reports and its
/// standard-normal range noise ([`SensorConfig::draw`]). Drawn before any ray is traced, so
/// that a scan does not depend on how its rays, or a run's scans, are shared among threads.
///
/// A sensor with a signal model and a random beam selection also draws, per ray, a uniform
/// number in [0, 1) that picks the answering beam ray; the thesis model draws exactly as before.
/// A laser in a world with aerosol objects (§7.6) then draws, per ray, the exponential optical
/// depth at which particles return it; in a world without, it draws nothing more.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanDraws(Vec<(Beam, f64)>, Vec<f64>, Vec<f64>);

impl SensorConfig {
    /// One scan from a sensor at `pose` (world frame) at time `stamp`. Random draws (side-beam
    /// choice, then range noise, ray by ray) come from `rng` in a fixed order, so the same
    /// RNG state gives the same scan.
    pub fn scan<R: Rng + ?Sized>(
        &self,
        world: &World,
        pose: &Pose,
        stamp: f64,
        rng: &mut R,
        tracer: &mut Tracer,
    ) -> Scan {
        let draws = self.draw(world, rng);
        self.trace_scan(world, pose, stamp, &draws, tracer, PARALLEL_MIN_RAYS)
    }

    /// The random draws of one scan, taken from `rng` exactly as [`SensorConfig::scan`]
    /// takes them.
    pub fn draw<R: Rng + ?Sized>(&self, world: &World, rng: &mut R) -> ScanDraws {
        let n = self.azimuth_count() * self.elevations.len();
        let noisy = self.range_noise_std > 0.0 || self.range_noise_rel > 0.0;
        let side_beams = self.has_side_beams();
        let sig = &self.signal;
        let echo_mode = sig.return_mode != ReturnMode::Thesis;
        // The thesis' side-beam draw is the uniform selection among three rays.
        let beam_draw = side_beams && (!echo_mode || sig.selection == Selection::Uniform);
        let select_draw = echo_mode
            && !beam_draw
            && sig.selection.random()
            && sig.beam(self.side_offset()).len() > 1;
        let mut select = Vec::new();
        let rays = (0..n)
            .map(|_| {
                let beam = if beam_draw {
                    [Beam::Center, Beam::Left, Beam::Right][rng.random_range(0..3)]
                } else {
                    Beam::Center
                };
                if select_draw {
                    select.push(rng.random::<f64>());
                }
                let noise: f64 = if noisy {
                    rng.sample(StandardNormal)
                } else {
                    0.0
                };
                (beam, noise)
            })
            .collect();
        let aerosols = self.kind == SensorKind::Laser && world.has_laser_aerosols();
        let optical = if aerosols {
            (0..n).map(|_| rng.sample(Exp1)).collect()
        } else {
            Vec::new()
        };
        ScanDraws(rays, select, optical)
    }

    /// A scan of this sensor at `pose` and `stamp` with room for its rays and none filled in.
    fn empty_scan(&self, pose: &Pose, stamp: f64) -> Scan {
        self.empty_scan_for(pose, stamp, self.azimuth_count() * self.elevations.len())
    }

    /// [`SensorConfig::empty_scan`] with room for `n` rays (a part of a scan traced in
    /// parallel holds a chunk of its rays).
    fn empty_scan_for(&self, pose: &Pose, stamp: f64, n: usize) -> Scan {
        Scan {
            stamp,
            kind: self.kind,
            pose: *pose,
            angle_min: self.angle_min(),
            angle_increment: self.resolution,
            azimuths: self.azimuth_count(),
            elevations: self.elevations.clone(),
            range_min: self.range_min,
            range_max: self.range_max,
            side_beam_offset: self.side_offset(),
            ranges: Vec::with_capacity(n),
            hits: Vec::with_capacity(n),
            materials: Vec::with_capacity(n),
            beams: Vec::with_capacity(n),
            echoes: Vec::new(),
            echo_start: Vec::new(),
        }
    }

    /// The side-beam offset in use (0 for ground truth).
    fn side_offset(&self) -> f64 {
        if self.has_side_beams() {
            self.side_beam_offset
        } else {
            0.0
        }
    }

    /// Whether this sensor reports one of three parallel rays (the thesis' side beams).
    fn has_side_beams(&self) -> bool {
        self.side_beam_offset > 0.0 && self.kind != SensorKind::GroundTruth
    }

    /// The scan of [`SensorConfig::scan`] from draws taken beforehand; its rays are shared
    /// among threads from `parallel_min` rays up.
    pub(crate) fn trace_scan(
        &self,
        world: &World,
        pose: &Pose,
        stamp: f64,
        draws: &ScanDraws,
        tracer: &mut Tracer,
        parallel_min: usize,
    ) -> Scan {
        let azimuths = self.azimuth_count();
        let n = azimuths * self.elevations.len();
        let band = self.kind.band();
        let side_beams = self.has_side_beams();
        if self.signal.return_mode != ReturnMode::Thesis {
            return self.trace_echo_scan(world, pose, stamp, draws, tracer, parallel_min);
        }
        let optical = &draws.2;
        let draws = &draws.0;
        assert_eq!(draws.len(), n, "draws of another sensor");
        let mut out = self.empty_scan(pose, stamp);
        let plane_sin_cos: Vec<(f64, f64)> = self.elevations.iter().map(|e| e.sin_cos()).collect();
        // Rays that all leave the sensor's origin share one set of candidate lists, unless
        // the world has so much in range that building them costs more than walking the grid.
        let mut fan = std::mem::take(&mut tracer.fan);
        let fan_ok = !side_beams && self.scan_fan(world, pose, n, &mut fan);
        let fan_ref = fan_ok.then_some(&fan);
        // Ray `i` is azimuth `k` of plane `plane` (the serial loop below counts them rather
        // than divide per ray).
        let mut bearings = std::mem::take(&mut tracer.bearings);
        let (angle_min, increment) = (out.angle_min, out.angle_increment);
        let side_offset = out.side_beam_offset;
        let toward = bearings.turned(pose.yaw, angle_min, increment, azimuths);
        let trace = |tracer: &mut Tracer, i: usize, plane: usize, k: usize| {
            let az = angle_min + k as f64 * increment;
            let el = plane_sin_cos[plane];
            let lateral = draws[i].0.side() * side_offset;
            let ray = beam_ray_toward(pose, toward[k], el, lateral);
            if let Some(&e) = optical.get(i) {
                let fan = fan_ref.map(|f| (f, pose.yaw + az));
                let (budget, max) = (self.penetration_db, self.range_max);
                return tracer.trace_aerosol(world, fan, &ray, band, budget, max, e);
            }
            match fan_ref {
                Some(fan) => tracer.trace_in_fan(
                    world,
                    fan,
                    pose.yaw + az,
                    &ray,
                    band,
                    self.penetration_db,
                    self.range_max,
                ),
                None => tracer.trace(world, &ray, band, self.penetration_db, self.range_max),
            }
        };
        // Each return is filed field by field as soon as it is traced: collected first and
        // filed later, it was copied out sixteen bytes at once from fields just written one by
        // one, which stalls the store buffer once per ray (a twentieth of a whole run).
        let file = |out: &mut Scan, ret: &Return, &(beam, noise): &(Beam, f64)| {
            out.ranges
                .push(self.reported_range(ret.range, noise) as f32);
            out.hits.push(ret.kind);
            out.materials.push(ret.material);
            out.beams.push(beam);
        };
        if n >= parallel_min {
            let returns: Vec<Return> = (0..n)
                .into_par_iter()
                .with_min_len(PARALLEL_CHUNK)
                .map(|i| with_pool_tracer(|t| trace(t, i, i / azimuths, i % azimuths)))
                .collect();
            for (ret, draw) in returns.iter().zip(draws) {
                file(&mut out, ret, draw);
            }
        } else {
            for plane in 0..self.elevations.len() {
                for k in 0..azimuths {
                    let i = plane * azimuths + k;
                    let ret = trace(tracer, i, plane, k);
                    file(&mut out, &ret, &draws[i]);
                }
            }
        }
        tracer.fan = fan;
        tracer.bearings = bearings;
        out
    }

    /// Builds in `fan` the candidate lists of a scan of `rays` rays from `pose`; `false` when
    /// the world has too much in range for them to pay (see [`World::fan`]).
    pub(crate) fn scan_fan(
        &self,
        world: &World,
        pose: &Pose,
        rays: usize,
        fan: &mut crate::world::Fan,
    ) -> bool {
        let sectors = (std::f64::consts::TAU / self.resolution / RAYS_PER_SECTOR).round();
        world.fan(
            pose.position(),
            self.range_max,
            sectors.clamp(8.0, 4096.0) as usize,
            rays / PARTS_PER_RAY_FOR_FAN,
            fan,
        )
    }

    /// A true range turned into the reading: noise, bin quantisation, `±inf` rules.
    fn reported_range(&self, true_range: f64, noise: f64) -> f64 {
        if !true_range.is_finite() {
            return f64::INFINITY;
        }
        let mut r = (true_range + noise * self.noise_sigma(true_range)).max(0.0);
        if let Some(bin) = self.range_bin {
            r = ((r / bin).floor() + 0.5) * bin;
        }
        if r < self.range_min {
            f64::NEG_INFINITY
        } else if r > self.range_max {
            f64::INFINITY
        } else {
            r
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{MaterialTable, Object, Shape};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The turned azimuth table agrees with the sine and cosine of each bearing to a few
    /// units in the last place, for any heading, and each sensor's layout keeps its table.
    #[test]
    fn turned_bearings_are_the_bearings_sines_and_cosines() {
        let mut b = Bearings::default();
        // A laser's and a radar's scans in turn, as one tracer serves them in a run.
        for yaw in [0.0, 0.3, -2.9, 7.5, 1e3] {
            for (first, step, n) in [(-2.356, 0.25f64.to_radians(), 1081), (0.0, 0.0175, 360)] {
                let turned = b.turned(yaw, first, step, n).to_vec();
                assert_eq!(turned.len(), n);
                for (k, (s, c)) in turned.into_iter().enumerate() {
                    let (s0, c0) = (yaw + first + k as f64 * step).sin_cos();
                    // The sum yaw + az itself rounds by up to half an ulp of its size.
                    let tol = 4.0 * f64::EPSILON * (1.0 + yaw.abs());
                    assert!((s - s0).abs() <= tol && (c - c0).abs() <= tol, "{yaw} {k}");
                }
            }
        }
        // Each layout's table was made once and kept.
        assert_eq!(b.tables.len(), 2);
        // A beam's offsets in azimuth: each offset's bearings in turn, as `turned` gives them.
        let (yaw, step, n) = (0.7, 0.0175, 360);
        let firsts = [-0.0157, 0.0, 0.0157];
        let all = b.turned_from(yaw, &firsts, step, n).to_vec();
        assert_eq!(all.len(), 3 * n);
        for (j, &first) in firsts.iter().enumerate() {
            assert_eq!(
                &all[j * n..(j + 1) * n],
                b.turned(yaw, first, step, n),
                "offset {j}"
            );
        }
    }

    /// A closed 10 × 10 m concrete room centred on the origin; inner faces at ±4.9 m.
    fn square_room() -> World {
        let materials = MaterialTable::default();
        let concrete = materials.id("concrete").unwrap();
        let wall = Shape::wall(
            vec![
                glam::DVec2::new(-5.0, -5.0),
                glam::DVec2::new(5.0, -5.0),
                glam::DVec2::new(5.0, 5.0),
                glam::DVec2::new(-5.0, 5.0),
                glam::DVec2::new(-5.0, -5.0),
            ],
            0.2,
            2.0,
        )
        .unwrap();
        World::new(
            materials,
            vec![Object {
                name: None,
                shape: wall,
                material: concrete,
            }],
        )
    }

    #[test]
    fn scan_of_square_room_hits_inner_faces() {
        let world = square_room();
        let cfg = preset("ground_truth").unwrap();
        let pose = Pose::new(0.0, 0.0, 0.4, 0.0);
        let scan = cfg.scan(
            &world,
            &pose,
            0.0,
            &mut ChaCha8Rng::seed_from_u64(1),
            &mut Tracer::default(),
        );
        assert_eq!(scan.len(), 360);
        for i in 0..scan.len() {
            let (az, _) = scan.angles(i);
            let expected = 4.9 / az.cos().abs().max(az.sin().abs());
            assert!(
                (f64::from(scan.ranges[i]) - expected).abs() < 1e-5,
                "ray {i}"
            );
            assert_eq!(scan.hits[i], HitKind::Solid);
        }
    }

    #[test]
    fn side_beams_are_chosen_uniformly_and_offset_the_origin() {
        let world = square_room();
        let cfg = preset("radar_thesis_n100").unwrap();
        let pose = Pose::new(0.0, 0.0, 0.4, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut tracer = Tracer::default();
        let mut counts = [0usize; 3];
        for k in 0..30 {
            let scan = cfg.scan(&world, &pose, k as f64, &mut rng, &mut tracer);
            for (i, b) in scan.beams.iter().enumerate() {
                counts[*b as usize] += 1;
                // The reading is the offset ray's own range: its endpoint lies on a wall face.
                let p = scan.endpoint(i).unwrap();
                assert!((p.x.abs().max(p.y.abs()) - 4.9).abs() < 1e-4, "{p:?}");
                let o = scan.ray(i).origin;
                assert!((o.truncate().length() - b.side().abs() * 0.4).abs() < 1e-12);
            }
        }
        // 10 800 draws: each share within 1/3 ± 0.02 (more than 7 standard deviations).
        for c in counts {
            assert!((c as f64 / 10_800.0 - 1.0 / 3.0).abs() < 0.02, "{counts:?}");
        }
    }

    #[test]
    fn same_seed_same_scan_and_noise_follows_sigma() {
        let world = square_room();
        let cfg = preset("sick_lms291").unwrap();
        let pose = Pose::new(0.0, 0.0, 0.4, 0.3);
        let mut tr = Tracer::default();
        let a = cfg.scan(
            &world,
            &pose,
            0.0,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut tr,
        );
        let b = cfg.scan(
            &world,
            &pose,
            0.0,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut tr,
        );
        assert_eq!(a, b);
        let truth = SensorConfig {
            range_noise_std: 0.0,
            ..cfg.clone()
        }
        .scan(
            &world,
            &pose,
            0.0,
            &mut ChaCha8Rng::seed_from_u64(3),
            &mut tr,
        );
        let errs: Vec<f64> = a
            .ranges
            .iter()
            .zip(&truth.ranges)
            .map(|(x, y)| f64::from(x - y))
            .collect();
        let sd = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        assert!(sd > 0.004 && sd < 0.01, "σ = {sd}");
    }

    #[test]
    fn parallel_scan_equals_serial_scan() {
        let world = crate::world::forest::forest(300, 50.0, 4);
        let pose = Pose::new(0.0, 0.0, 0.4, 0.0);
        let mut tr = Tracer::default();
        // Side beams (grid walk per ray), one origin (fan), first hit, and the echo modes:
        // every echo of one ray (echoes gathered per chunk of azimuths when parallel), and a
        // 3 × 3 beam answered by its strongest ray.
        let mut all = preset("radar_thesis").unwrap();
        all.signal.return_mode = ReturnMode::All;
        let configs = ["radar_thesis_n100", "radar_thesis", "hokuyo_utm30lx"]
            .map(|name| preset(name).unwrap())
            .into_iter()
            .chain([all, preset("navtech_cts350x").unwrap()]);
        for cfg in configs {
            let draws = cfg.draw(&world, &mut ChaCha8Rng::seed_from_u64(9));
            let mut scan = |min| cfg.trace_scan(&world, &pose, 0.0, &draws, &mut tr, min);
            let (serial, parallel) = (scan(usize::MAX), scan(1));
            assert!(
                serial.hits.contains(&HitKind::Solid) || serial.hits.contains(&HitKind::Exhausted)
            );
            if cfg.signal.return_mode == ReturnMode::All {
                assert!(
                    serial.echoes.len() > serial.ranges.len(),
                    "{:?}",
                    cfg.preset
                );
            }
            assert_eq!(serial, parallel, "{:?}", cfg.preset);
        }
    }

    #[test]
    fn ros_infinities_and_bins() {
        let cfg = SensorConfig {
            range_min: 1.0,
            range_max: 10.0,
            range_bin: Some(0.5),
            ..preset("radar_thesis").unwrap()
        };
        assert_eq!(cfg.reported_range(f64::INFINITY, 0.0), f64::INFINITY);
        assert_eq!(cfg.reported_range(0.5, 0.0), f64::NEG_INFINITY);
        assert_eq!(cfg.reported_range(3.1, 0.0), 3.25);
        assert_eq!(cfg.reported_range(9.99, 0.0), 9.75);
        let noisy = SensorConfig {
            range_noise_std: 1.0,
            ..cfg
        };
        assert_eq!(noisy.reported_range(9.0, 2.0), f64::INFINITY);
    }
}
