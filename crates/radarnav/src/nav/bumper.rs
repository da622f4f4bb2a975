//! Virtual bumpers (DESIGN §6): a scan grouped into K sectors, each *clear*, *pressed* or
//! *too close*.
//!
//! Sector `k` of `K` is centred on `k · 360°/K` counter-clockwise from the robot's front:
//! with 4 sectors front, left, back, right; with 8 also the diagonals in between. Ranges are
//! measured from the robot's centre (a sensor mounted off-centre is accounted for), so the
//! same safety distance means the same thing for every sensor.
//!
//! A sector is *too close* when any of its rays returns nearer than the safety distance (a
//! thin pole must not be outvoted), *pressed* when its rays satisfy the activation rule in
//! the band `[safety, safety + band]`, and *clear* otherwise. A sector with no rays (the
//! blind back of a 270° laser) is clear.
//!
//! # Safety distance and radar penetration
//! A thesis-model radar reports foliage where its budget runs out, up to
//! `budget / attenuation` metres *inside* it (`radar_thesis`: 3 dB, so 1 m into
//! `foliage_dense` at 3 dB/m); a volume thinner than that gives no return at all. A bumper
//! that keeps the robot's centre `safety` from such a return keeps its front
//! `safety − depth − length/2` from the foliage's surface. The default, 2.5 vehicle lengths
//! (1.27 m for the P3AT), leaves 1.27 − 1 − 0.25 ≈ 0 m at the worst depth: the thesis'
//! reason for 2–3 lengths. Take `safety ≥ length/2 + budget/attenuation + margin` for
//! denser budgets, and note that foliage the radar crosses whole is invisible to it.

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::fmt;

use glam::DVec2;

use super::{nav_pose, scan_pose};
use crate::map::PoseSource;
use crate::pose::{Pose, wrap_angle};
use crate::sensor::{RangeNoise, ReturnMode, Scan, SensorConfig, SensorKind};
use crate::sim::ControlInput;
use crate::vehicle::VehicleSpec;

/// How many of a sector's rays must lie in the band for it to be pressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BumperRule {
    /// Every ray (the thesis' rule).
    All,
    /// At least one ray.
    Any,
    /// At least this share of the rays, in (0, 1].
    Fraction(f64),
}

impl BumperRule {
    /// Parses `all`, `any` or `fraction:p` with `0 < p ≤ 1`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "all" => Ok(Self::All),
            "any" => Ok(Self::Any),
            _ => {
                let p = s.strip_prefix("fraction:").ok_or_else(|| {
                    format!("unknown bumper rule `{s}`; known: all, any, fraction:p")
                })?;
                match p.parse::<f64>() {
                    Ok(p) if p > 0.0 && p <= 1.0 => Ok(Self::Fraction(p)),
                    _ => Err(format!(
                        "`fraction:{p}`: expected a share in (0, 1], e.g. fraction:0.8"
                    )),
                }
            }
        }
    }

    fn pressed(self, in_band: usize, rays: usize) -> bool {
        match self {
            Self::All => in_band == rays,
            Self::Any => in_band > 0,
            Self::Fraction(p) => in_band as f64 >= p * rays as f64,
        }
    }
}

impl fmt::Display for BumperRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::All => f.write_str("all"),
            Self::Any => f.write_str("any"),
            Self::Fraction(p) => write!(f, "fraction:{p}"),
        }
    }
}

/// The state of one bumper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BumperState {
    /// Nothing in or inside the band.
    Clear,
    /// The rule holds in the band: an obstacle at the wanted distance.
    Pressed,
    /// Something nearer than the safety distance.
    TooClose,
}

/// Bumper parameters (`[mission.bumpers]`).
#[derive(Clone, Debug, PartialEq)]
pub struct BumperConfig {
    /// Sectors: 4 or 8.
    pub sectors: usize,
    /// Safety distance from the robot's centre, m; `None`: [`DEFAULT_SAFETY_LENGTHS`] vehicle
    /// lengths.
    pub safety: Option<f64>,
    /// Width of the pressed band beyond the safety distance, m.
    pub band: f64,
    /// Activation rule.
    pub rule: BumperRule,
    /// The sensor whose scans feed the bumpers (`None`: the robot's first sensor).
    pub sensor: Option<String>,
}

/// Makes a radar feeding bumpers report first echoes: in the thesis' return mode its range is
/// where the penetration budget ran out, deep inside foliage or past a hedge it crosses whole,
/// so a robot steering by it drives into what it sees through. In `all` mode the range is the
/// first echo (the foliage's surface) and the later echoes stay in the scan for the maps.
/// Other sensors and modes are left alone. Returns whether it changed `config`.
pub fn read_first_echoes(config: &mut SensorConfig) -> bool {
    let switch =
        config.kind == SensorKind::Radar && config.signal.return_mode == ReturnMode::Thesis;
    if switch {
        config.signal.return_mode = ReturnMode::All;
    }
    switch
}

/// Default safety distance in vehicle lengths (DESIGN §6: 2–3).
pub const DEFAULT_SAFETY_LENGTHS: f64 = 2.5;

/// Half-width of the arc over which a noisy sensor's neighbouring returns are pooled for the
/// body's clearance ([`denoised_returns`]), m.
const DENOISE_ARC: f64 = 0.01;
/// Returns farther than this from the sensor are left out of the denoised ones: the checks
/// they serve (the strip just ahead of a passing body, the way's narrowest pair beside and
/// ahead of it) lie within a metre of it, m.
const STEADY_RANGE: f64 = 1.5;
/// Earlier scans whose returns are pooled with the latest one's ([`denoised_returns`]): at the
/// control rate (20 Hz) a third of a second, over which the believed pose moves them into
/// place to a millimetre or two.
const STEADY_SCANS: usize = 6;
/// The range noise of a denoised return, as a fraction of the sensor's, as the narrowing
/// check ([`super::passage::narrows_ahead`]) allows for it. The median of n samples has
/// 1.25 σ / √n: half a metre from a UTM-30LX the pool holds 9 rays of each of 7 scans, 0.16 σ.
/// But the check takes the closest of many pairs across the way, and how far short of the
/// way's width that lies depends on its sides more than on σ: measured over 7 pooled scans of
/// 3 cm noise, 1.8 cm short across a straight way between two faces, between 0.4 cm short and
/// 0.8 cm long from a crate's corner to a face (the median rounds a corner's tip off). 0.11
/// puts the check's allowance (2 × 2.5 σ) at 1.7 cm, between the two: a 0.72 m way stays
/// open, a 0.70 m one closes (unit test), and a corner 0.698 m from a face closes from some
/// of the scans the robot takes driving up to it.
const STEADY_NOISE: f64 = 0.11;

/// One scan's returns kept for pooling into later ones ([`denoised_returns`]): the believed
/// robot pose it was taken at and its finite returns within [`STEADY_RANGE`] (and a margin),
/// robot frame, each with its plane.
#[derive(Clone, Debug, Default)]
struct PastScan {
    pose: Pose,
    points: Vec<(usize, DVec2)>,
}

impl PastScan {
    /// The returns of `scan` from a sensor at `mount` taken at the believed robot `pose`.
    fn of(scan: &Scan, mount: &Pose, pose: Pose) -> Self {
        let n = scan.azimuths.max(1);
        let origin = DVec2::new(mount.x, mount.y);
        let points = scan
            .ranges
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_finite() && f64::from(**r) <= STEADY_RANGE + 0.1)
            .map(|(i, &r)| {
                let dir = DVec2::from_angle(mount.yaw + scan.angles(i).0);
                (i / n, origin + dir * f64::from(r))
            })
            .collect();
        Self { pose, points }
    }

    /// These returns in the robot frame of the believed pose `now`, each with its plane.
    fn seen_from(&self, now: &Pose) -> impl Iterator<Item = (usize, DVec2)> + '_ {
        let rel = now.inverse().compose(&self.pose);
        let (turn, shift) = (DVec2::from_angle(rel.yaw), rel.xy());
        self.points
            .iter()
            .map(move |&(k, q)| (k, shift + turn.rotate(q)))
    }
}

/// The below-minimum returns of `scan` and its finite ones within [`STEADY_RANGE`], in the
/// robot frame (a sensor at `mount`), in ray order, each finite range replaced by the median
/// of the ranges of its own and its plane's neighbouring rays within [`DENOISE_ARC`] of arc
/// of it, together with the returns of earlier scans `past` (robot-frame points of this
/// scan's frame, each with its plane) that lie within that arc as seen from the sensor now.
///
/// Why: the body's clearance checks count returns inside a strip or circle round the body
/// and block at [`super::passage::HITS_TO_BLOCK`] of them, so that one stray range does not
/// stop the robot, and the narrowing check takes the closest pair of returns across the way
/// ahead. Close to a surface a fine-grained laser puts dozens of rays on each centimetre of
/// it (a UTM-30LX: 7 per centimetre at 0.3 m), and with 3 cm of range noise a few of them
/// fall 6 cm short: a crate's corner 8 cm from the body's flank blocked a 0.72 m way its
/// 0.50 m body passes, and the closest of hundreds of pairs across a 0.72 m way lies 4 cm
/// short or more, as near as a 0.70 m way's (closed to the robot's disc). The median of the
/// returns on a surface is as near as the surface is; pooled over one scan it keeps a third
/// of the noise near the body, over the last few scans (the same surface seen from where the
/// robot was, a few centimetres back) a sixth or less. It keeps a face's linear trend and an
/// edge where the depth jumps (the ray at a face's end has the face's returns as the
/// majority of its window). No gate on the range difference: one centred on the ray's own
/// noisy range keeps the neighbours as far out as an outlier and pulls it farther. Anything
/// narrower than the arc would be lost, so the arc is kept to a centimetre; rays farther
/// apart than that keep their own range and the earlier scans' along it.
fn denoised_returns(scan: &Scan, mount: &Pose, past: &[(usize, DVec2)]) -> Vec<DVec2> {
    let n = scan.azimuths.max(1);
    let wrap = scan.full_circle();
    let origin = DVec2::new(mount.x, mount.y);
    // The earlier returns by the ray of this scan they lie nearest to (plane, azimuth), as
    // ranges from the sensor now: `earlier[start[i]..start[i + 1]]` are ray i's.
    let inc = scan.angle_increment;
    let rays = scan.ranges.len();
    let keyed: Vec<(usize, f32)> = if inc > 0.0 {
        past.iter()
            .filter_map(|&(plane, q)| {
                let d = q - origin;
                let a = (d.to_angle() - mount.yaw - scan.angle_min).rem_euclid(TAU);
                let k = (a / inc).round();
                let k = if wrap { k.rem_euclid(n as f64) } else { k };
                let i = plane * n + k as usize;
                ((0.0..n as f64).contains(&k) && i < rays).then(|| (i, d.length() as f32))
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut start = vec![0usize; rays + 1];
    for &(i, _) in &keyed {
        start[i + 1] += 1;
    }
    for i in 0..rays {
        start[i + 1] += start[i];
    }
    let mut earlier = vec![0.0f32; keyed.len()];
    let mut fill = start.clone();
    for (i, r) in keyed {
        earlier[fill[i]] = r;
        fill[i] += 1;
    }
    let mut pool: Vec<f32> = Vec::new();
    let mut out = Vec::with_capacity(scan.ranges.len());
    for (i, &r) in scan.ranges.iter().enumerate() {
        if !r.is_finite() {
            if r < 0.0 {
                out.push(DVec2::ZERO);
            }
            continue;
        }
        let rf = f64::from(r);
        if rf > STEADY_RANGE {
            continue;
        }
        let dir = DVec2::from_angle(mount.yaw + scan.angles(i).0);
        let reach = if inc > 0.0 && rf > 0.0 {
            (DENOISE_ARC / (rf * inc)).floor() as usize
        } else {
            0
        };
        let reach = reach.min((n - 1) / 2);
        let (plane, k) = (i / n, i % n);
        pool.clear();
        pool.push(r);
        pool.extend_from_slice(&earlier[start[i]..start[i + 1]]);
        for m in 1..=reach {
            for side in [k.checked_sub(m), Some(k + m)] {
                let j = match side {
                    Some(j) if j < n => Some(j),
                    Some(j) if wrap => Some(j - n),
                    None if wrap => Some(k + n - m),
                    _ => None,
                };
                if let Some(j) = j {
                    let q = scan.ranges[plane * n + j];
                    if q.is_finite() {
                        pool.push(q);
                    }
                    let ray = plane * n + j;
                    pool.extend_from_slice(&earlier[start[ray]..start[ray + 1]]);
                }
            }
        }
        let mid = pool.len() / 2;
        let range = f64::from(*pool.select_nth_unstable_by(mid, f32::total_cmp).1);
        out.push(origin + dir * range);
    }
    out
}

impl Default for BumperConfig {
    fn default() -> Self {
        Self {
            sectors: 8,
            safety: None,
            band: 0.5,
            rule: BumperRule::All,
            sensor: None,
        }
    }
}

impl BumperConfig {
    /// The safety distance for `vehicle`, m.
    pub fn safety_for(&self, vehicle: &VehicleSpec) -> f64 {
        self.safety
            .unwrap_or(DEFAULT_SAFETY_LENGTHS * vehicle.length)
    }

    /// Checks the values.
    pub fn validate(&self) -> Result<(), String> {
        if self.sectors != 4 && self.sectors != 8 {
            return Err(format!(
                "`sectors`: expected 4 or 8, found {}",
                self.sectors
            ));
        }
        if let Some(s) = self.safety
            && !(s > 0.0 && s.is_finite())
        {
            return Err(format!("`safety`: expected a number > 0, found {s}"));
        }
        if !(self.band > 0.0 && self.band.is_finite()) {
            return Err(format!(
                "`band`: expected a number > 0, found {}",
                self.band
            ));
        }
        Ok(())
    }

    /// Index of the configured sensor among `names` (the first when none is named).
    pub fn sensor_index<'a>(&self, mut names: impl Iterator<Item = &'a str>) -> Option<usize> {
        match &self.sensor {
            None => names.next().map(|_| 0),
            Some(n) => names.position(|x| x == n),
        }
    }
}

/// The bumpers' states from one scan.
#[derive(Clone, Debug, PartialEq)]
pub struct Bumpers {
    stamp: f64,
    states: Vec<BumperState>,
    nearest: Vec<f64>,
    /// Every return in the robot frame (below-minimum ranges at the centre), for the
    /// corridor checks.
    points: Vec<DVec2>,
    /// `points` followed by returns remembered from earlier scans where the sensor is blind
    /// now ([`BumperSensor`]): what the body's clearance is checked against.
    clearance: Vec<DVec2>,
    /// `clearance` with a noisy sensor's returns of this scan denoised ([`denoised_returns`];
    /// those beyond [`STEADY_RANGE`] left out); empty for a sensor without range noise, and
    /// unless the bumpers are [`BumperSensor::denoising`].
    steady: Vec<DVec2>,
    /// The sensor's position in the robot frame, m.
    origin: DVec2,
    /// The sensor's range noise (none unless [`BumperSensor`] knows the sensor).
    noise: RangeNoise,
    /// Whether the scan covers the whole circle: nothing round the robot is hidden from it
    /// (a radar), unlike the back of a 270° laser.
    all_round: bool,
}

impl Bumpers {
    /// Bumpers from `scan` of a sensor mounted at `mount` on the robot, with `safety` and
    /// `band` in metres from the robot's centre.
    pub fn sense(
        scan: &Scan,
        mount: &Pose,
        sectors: usize,
        safety: f64,
        band: f64,
        rule: BumperRule,
    ) -> Self {
        Self::sense_with(scan, mount, sectors, safety, band, rule, &mut Vec::new())
    }

    /// [`Bumpers::sense`] taking each ray's sine and cosine from `dirs` (ray direction,
    /// (sine, cosine)) where its direction is the one there, bit for bit, and filing them
    /// there otherwise: a sensor's rays keep their directions on the robot from scan to
    /// scan.
    fn sense_with(
        scan: &Scan,
        mount: &Pose,
        sectors: usize,
        safety: f64,
        band: f64,
        rule: BumperRule,
        dirs: &mut Vec<(f64, (f64, f64))>,
    ) -> Self {
        let width = TAU / sectors as f64;
        let mut rays = vec![0usize; sectors];
        let mut close = vec![0usize; sectors];
        let mut in_band = vec![0usize; sectors];
        let mut nearest = vec![f64::INFINITY; sectors];
        let mut points = Vec::new();
        for (i, &r) in scan.ranges.iter().enumerate() {
            let dir = mount.yaw + scan.angles(i).0;
            let (angle, dist) = if r.is_finite() {
                let (s, c) = match dirs.get(i) {
                    Some(&(d, sc)) if d.to_bits() == dir.to_bits() => sc,
                    _ => {
                        let sc = dir.sin_cos();
                        dirs.resize(dirs.len().max(i + 1), (f64::NAN, (f64::NAN, f64::NAN)));
                        dirs[i] = (dir, sc);
                        sc
                    }
                };
                let (x, y) = (mount.x + f64::from(r) * c, mount.y + f64::from(r) * s);
                (y.atan2(x), x.hypot(y))
            } else if r < 0.0 {
                // Below the sensor's minimum range: as close as can be.
                (dir, 0.0)
            } else {
                (dir, f64::INFINITY)
            };
            if dist.is_finite() {
                points.push(DVec2::from_angle(angle) * dist);
            }
            let k = sector_index(angle, width, sectors);
            rays[k] += 1;
            nearest[k] = nearest[k].min(dist);
            if dist < safety {
                close[k] += 1;
            } else if dist <= safety + band {
                in_band[k] += 1;
            }
        }
        let states = (0..sectors)
            .map(|k| {
                if close[k] > 0 {
                    BumperState::TooClose
                } else if rays[k] > 0 && rule.pressed(in_band[k], rays[k]) {
                    BumperState::Pressed
                } else {
                    BumperState::Clear
                }
            })
            .collect();
        Self {
            stamp: scan.stamp,
            states,
            nearest,
            clearance: points.clone(),
            steady: Vec::new(),
            points,
            origin: DVec2::new(mount.x, mount.y),
            noise: RangeNoise::default(),
            all_round: scan.full_circle(),
        }
    }

    /// Whether the scan covers the whole circle round its sensor: what lies behind the robot
    /// is seen now, not remembered.
    pub fn sees_all_round(&self) -> bool {
        self.all_round
    }

    /// Whether no return lies in the corridor of half-width `half_width` from the robot's
    /// centre along the robot-frame direction `angle`, up to `length` metres: the way is open
    /// for the robot's body, whatever the sectors say.
    pub fn corridor_free(&self, angle: f64, length: f64, half_width: f64) -> bool {
        self.corridor_free_from(angle, 0.0, length, half_width)
    }

    /// [`Bumpers::corridor_free`] for the part of the corridor from `start` metres on.
    pub fn corridor_free_from(&self, angle: f64, start: f64, length: f64, half_width: f64) -> bool {
        let u = DVec2::from_angle(angle);
        !self.clearance.iter().any(|p| {
            let along = p.dot(u);
            (start..=length).contains(&along) && u.perp_dot(*p).abs() <= half_width
        })
    }

    /// Every return in the robot frame, in scan order.
    pub fn points(&self) -> &[DVec2] {
        &self.points
    }

    /// The returns the body's clearance is checked against, robot frame: [`Bumpers::points`]
    /// and, where the sensor is blind now, returns remembered from earlier scans.
    pub fn clearance(&self) -> &[DVec2] {
        &self.clearance
    }

    /// [`Bumpers::clearance`] with a noisy sensor's returns of this scan within 1.5 m denoised
    /// (each the median of its neighbours' and the last scans' returns within a centimetre of
    /// arc): what a passage checks the strip ahead of the body against, where counting raw
    /// returns inside it blocks on range noise, and what the way's narrowest pair ahead is
    /// taken among (the passages' and Bug's narrowing check, with [`Bumpers::steady_sigma`]). The
    /// guard and every other check keep the raw returns: a median sits up to a centimetre out
    /// from a corner's tip, and a turn that looks free on medians the guard refuses on the raw
    /// returns (the guard takes these only for a robot it has stalled, [`super::WithRecoil`]).
    pub fn steady_clearance(&self) -> &[DVec2] {
        if self.steady.is_empty() {
            &self.clearance
        } else {
            &self.steady
        }
    }

    /// Whether [`Bumpers::steady_clearance`] holds denoised returns (a noisy sensor's, for
    /// bumpers that denoise), not the raw ones.
    pub fn is_denoised(&self) -> bool {
        !self.steady.is_empty()
    }

    /// These bumpers with `steady` as their denoised returns (robot frame).
    #[cfg(test)]
    pub(crate) fn with_steady(mut self, steady: Vec<DVec2>) -> Self {
        self.steady = steady;
        self
    }

    /// The range noise (m, one σ) of [`Bumpers::steady_clearance`]'s returns at `range` m:
    /// 0.11 of the sensor's when they are denoised (the allowance the closest of many pairs
    /// across a way needs; see `STEADY_NOISE`), none without noise.
    pub fn steady_sigma(&self, range: f64) -> f64 {
        let sigma = self.noise.sigma(range);
        if self.steady.is_empty() {
            sigma
        } else {
            STEADY_NOISE * sigma
        }
    }

    /// Where the rays start in the robot frame (the sensor's mount), m.
    pub fn origin(&self) -> DVec2 {
        self.origin
    }

    /// The range noise of the sensor the returns come from.
    pub fn noise(&self) -> RangeNoise {
        self.noise
    }

    /// Time of the scan these bumpers come from, s.
    pub fn stamp(&self) -> f64 {
        self.stamp
    }

    /// Number of sectors.
    pub fn sectors(&self) -> usize {
        self.states.len()
    }

    /// State of sector `k` (taken modulo the count, so `k = -1` style offsets wrap).
    pub fn state(&self, k: isize) -> BumperState {
        self.states[k.rem_euclid(self.states.len() as isize) as usize]
    }

    /// State of the sector holding the robot-frame direction `angle` (rad, CCW from front).
    pub fn toward(&self, angle: f64) -> BumperState {
        let n = self.states.len();
        self.states[sector_index(angle, TAU / n as f64, n)]
    }

    /// Nearest range in sector `k` from the robot's centre, m (`inf`: no return).
    pub fn nearest(&self, k: isize) -> f64 {
        self.nearest[k.rem_euclid(self.nearest.len() as isize) as usize]
    }

    /// Nearest range in the sector holding the robot-frame direction `angle`, m.
    pub fn nearest_toward(&self, angle: f64) -> f64 {
        let n = self.nearest.len();
        self.nearest[sector_index(angle, TAU / n as f64, n)]
    }

    /// All states, sector 0 (front) first, counter-clockwise.
    pub fn states(&self) -> &[BumperState] {
        &self.states
    }
}

/// Returns within this distance of the robot's centre are remembered, m: as far as a body
/// backing off or turning on the spot can reach before the sensor sees there again.
const MEMORY_RADIUS: f64 = 1.5;
/// Remembered returns are forgotten after this long, s (a gyro's bias turns the believed
/// frame even standing still, some 10°/h for a MEMS gyro: under 2° in this time)... A robot
/// wedged between two crates stands and shuffles for minutes with a crate's corner behind
/// it: forgotten after two minutes, the corner was turned into.
const MEMORY_TIME: f64 = 600.0;
/// ... or once the robot has moved this far since, m (turns count [`TURN_AS_PATH`]): drift
/// grows with motion, and a robot shuffling in a narrow way for a minute still needs what
/// it saw on its way in.
const MEMORY_PATH: f64 = 6.0;
/// Path equivalent of a turn for [`MEMORY_PATH`], m per radian: about how far a corner of
/// the body moves.
const TURN_AS_PATH: f64 = 0.35;
/// How far outside the body a touch is remembered, m: within the guard's margin, so that
/// moving along it stays free and moving into it does not.
const CONTACT_OFFSET: f64 = 0.005;
/// Remembered returns are kept one per cell of this size, m.
const MEMORY_CELL: f64 = 0.05;

/// Bumpers kept up to date from a robot's scans: recomputed when its sensor has a new scan.
///
/// A sensor that does not see all round (a 270° laser) is blind behind: a robot backing off
/// or turning on the spot would sweep into a corner it passed a moment ago. So the returns
/// near the robot are remembered in the believed frame ([`BumperSensor::believing`]), and
/// those now in the sensor's blind sector are added to the [`Bumpers::clearance`] checks;
/// where it sees, the new scan replaces them.
#[derive(Clone, Debug)]
pub struct BumperSensor {
    config: BumperConfig,
    stamp: f64,
    bumpers: Option<Bumpers>,
    pose: PoseSource,
    /// Remembered returns, believed frame, one per [`MEMORY_CELL`] cell: (point, time seen,
    /// `moved` when seen).
    memory: BTreeMap<(i64, i64), (DVec2, f64, f64)>,
    /// How far the robot has moved at the scans so far (turns count [`TURN_AS_PATH`]), m.
    moved: f64,
    /// The believed robot pose when the latest scan was taken.
    scan_pose: Pose,
    /// The latest scan's clearance returns in the robot frame of that scan.
    scan_clearance: Vec<DVec2>,
    /// The same denoised ([`Bumpers::steady_clearance`]; empty for a noiseless sensor).
    scan_steady: Vec<DVec2>,
    /// The latest scans' near returns, oldest first, pooled into the next one's denoised
    /// returns (a noisy sensor only; at most [`STEADY_SCANS`]).
    recent: std::collections::VecDeque<PastScan>,
    /// Whether to keep denoised returns at all ([`BumperSensor::denoising`]).
    denoise: bool,
    /// Each ray's direction on the robot with its sine and cosine ([`Bumpers::sense`]).
    dirs: Vec<(f64, (f64, f64))>,
}

impl BumperSensor {
    /// Bumpers of `config`.
    pub fn new(config: BumperConfig) -> Self {
        Self {
            config,
            stamp: f64::NEG_INFINITY,
            bumpers: None,
            pose: PoseSource::Odometry,
            memory: BTreeMap::new(),
            moved: 0.0,
            scan_pose: Pose::default(),
            scan_clearance: Vec::new(),
            scan_steady: Vec::new(),
            recent: std::collections::VecDeque::new(),
            denoise: false,
            dirs: Vec::new(),
        }
    }

    /// Keeps a noisy sensor's returns denoised ([`Bumpers::steady_clearance`]) for the checks
    /// that take them: a Bug's passages and narrowing checks. Off by default (exploration):
    /// pooling the last scans costs about a quarter of a laser run.
    pub fn denoising(mut self) -> Self {
        self.denoise = true;
        self
    }

    /// Remembers returns in the frame of this pose source (default: odometry, as a robot
    /// without ground truth would).
    pub fn believing(mut self, pose: PoseSource) -> Self {
        self.pose = pose;
        self
    }

    /// Changes the safety distance (a standoff retry), keeping the returns remembered where
    /// the sensor is blind: the robot is still where it saw them. The sectors are sensed
    /// anew at the next [`BumperSensor::update`].
    pub fn set_safety(&mut self, safety: f64) {
        self.config.safety = Some(safety);
        self.bumpers = None;
    }

    /// The configuration.
    pub fn config(&self) -> &BumperConfig {
        &self.config
    }

    /// The bumpers as of the last [`BumperSensor::update`] (`None` before the first scan).
    pub fn latest(&self) -> Option<&Bumpers> {
        self.bumpers.as_ref()
    }

    /// The safety distance plus the band for `vehicle`: nearer than this, a sector is not free.
    pub fn reach(&self, vehicle: &VehicleSpec) -> f64 {
        self.config.safety_for(vehicle) + self.config.band
    }

    /// The wanted distance from a followed wall: the middle of the pressed band, m.
    pub fn follow_radius(&self, vehicle: &VehicleSpec) -> f64 {
        self.config.safety_for(vehicle) + self.config.band / 2.0
    }

    /// The bumpers from the latest scan of the configured sensor (`None` before its first
    /// scan, or if the robot has no such sensor). The sectors are the scan's; the
    /// [`Bumpers::clearance`] returns are moved into the robot's frame now: a radar scanning
    /// at 4 Hz is up to a quarter second old, 10 cm at cruise speed.
    pub fn update(&mut self, input: &ControlInput<'_>) -> Option<&Bumpers> {
        let i = self
            .config
            .sensor_index(input.sensors.iter().map(|s| s.name.as_str()))?;
        let scan = input.scans.get(i)?.as_ref()?;
        let now = nav_pose(self.pose, input);
        if scan.stamp != self.stamp || self.bumpers.is_none() {
            self.stamp = scan.stamp;
            let c = &self.config;
            let mount = &input.sensors[i].mount;
            let mut b = Bumpers::sense_with(
                scan,
                mount,
                c.sectors,
                c.safety_for(input.vehicle),
                c.band,
                c.rule,
                &mut self.dirs,
            );
            b.noise = input.sensors[i].config.range_noise();
            let last = self.scan_pose;
            self.scan_pose = scan_pose(self.pose, input, i).unwrap_or(now);
            let pose = self.scan_pose;
            if !self.memory.is_empty() {
                self.moved += (pose.xy() - last.xy()).length()
                    + TURN_AS_PATH * wrap_angle(pose.yaw - last.yaw).abs();
            }
            self.remember(&mut b, scan, mount, &pose, input.time);
            if self.denoise && b.noise.sigma(0.0) > 0.0 {
                // The earlier scans' returns moved into this scan's robot frame.
                let past: Vec<(usize, DVec2)> = self
                    .recent
                    .iter()
                    .flat_map(|p| p.seen_from(&pose))
                    .collect();
                b.steady = denoised_returns(scan, mount, &past);
                if self.recent.len() >= STEADY_SCANS {
                    self.recent.pop_front();
                }
                self.recent.push_back(PastScan::of(scan, mount, pose));
                b.steady.extend_from_slice(&b.clearance[b.points.len()..]);
            }
            self.scan_clearance = std::mem::take(&mut b.clearance);
            self.scan_steady = std::mem::take(&mut b.steady);
            self.bumpers = Some(b);
        }
        let moved = now.inverse().compose(&self.scan_pose);
        let (turn, shift) = (DVec2::from_angle(moved.yaw), moved.xy());
        let b = self.bumpers.as_mut()?;
        b.clearance.clear();
        b.clearance
            .extend(self.scan_clearance.iter().map(|&q| shift + turn.rotate(q)));
        b.steady.clear();
        b.steady
            .extend(self.scan_steady.iter().map(|&q| shift + turn.rotate(q)));
        Some(b)
    }

    /// Remembers where the body touched something while driving `(v, omega)`: points just
    /// outside the face that led (the rear backing, the front driving on) or, turning on the
    /// spot, the two corners that led, as a bumper strip would report. They stay where the
    /// sensor is blind (a 270° laser's back), so the guard does not back into the same
    /// unseen wall again; where it sees, the next scan replaces them.
    pub fn touched(&mut self, input: &ControlInput<'_>, moving: (f64, f64)) {
        let pose = nav_pose(self.pose, input);
        self.touched_at(&pose, input.vehicle, moving, input.time);
    }

    /// [`BumperSensor::touched`] with the believed pose and the time given.
    fn touched_at(&mut self, pose: &Pose, vehicle: &VehicleSpec, (v, omega): (f64, f64), now: f64) {
        let (hl, hw) = (vehicle.length / 2.0, vehicle.width / 2.0);
        let out = CONTACT_OFFSET;
        let mut contact = Vec::new();
        if v != 0.0 {
            let x = v.signum() * (hl + out);
            let n = (2.0 * hw / MEMORY_CELL).ceil() as usize;
            contact.extend((0..=n).map(|k| DVec2::new(x, -hw + 2.0 * hw * k as f64 / n as f64)));
        } else if omega != 0.0 {
            // Turning left the front-left and rear-right corners lead, right the others;
            // each a little out along the way it moved.
            let s = omega.signum();
            for c in [DVec2::new(hl, s * hw), DVec2::new(-hl, -s * hw)] {
                let way = DVec2::new(-c.y, c.x) * s;
                contact.push(c + way.normalize_or_zero() * out);
            }
        }
        let to_world = DVec2::from_angle(pose.yaw);
        for q in contact {
            let w = pose.xy() + to_world.rotate(q);
            let cell = (
                (w.x / MEMORY_CELL).floor() as i64,
                (w.y / MEMORY_CELL).floor() as i64,
            );
            self.memory.insert(cell, (w, now, self.moved));
        }
    }

    /// Adds the remembered returns the sensor is blind to now to `b`'s clearance, then
    /// remembers `b`'s own near returns in their place.
    fn remember(&mut self, b: &mut Bumpers, scan: &Scan, mount: &Pose, pose: &Pose, now: f64) {
        if scan.full_circle() {
            // Seeing all round: nothing is hidden from the sensor for long.
            return;
        }
        let span = scan.angle_increment * scan.azimuths as f64;
        let centre = mount.yaw + scan.angle_min + 0.5 * (span - scan.angle_increment);
        let blind = |q: DVec2| {
            let d = q - b.origin;
            wrap_angle(d.y.atan2(d.x) - centre).abs() > 0.5 * span + scan.angle_increment
        };
        let to_robot = DVec2::from_angle(-pose.yaw);
        let to_world = DVec2::from_angle(pose.yaw);
        let at = pose.xy();
        let moved = self.moved;
        self.memory.retain(|_, (w, seen, seen_moved)| {
            let q = to_robot.rotate(*w - at);
            let fresh = now - *seen <= MEMORY_TIME && moved - *seen_moved <= MEMORY_PATH;
            let keep = fresh && q.length() <= MEMORY_RADIUS && blind(q);
            if keep {
                b.clearance.push(q);
            }
            keep
        });
        for &q in &b.points {
            if q.length() <= MEMORY_RADIUS {
                let w = at + to_world.rotate(q);
                let cell = (
                    (w.x / MEMORY_CELL).floor() as i64,
                    (w.y / MEMORY_CELL).floor() as i64,
                );
                self.memory.insert(cell, (w, now, moved));
            }
        }
    }
}

fn sector_index(angle: f64, width: f64, sectors: usize) -> usize {
    ((wrap_angle(angle) / width).round() as isize).rem_euclid(sectors as isize) as usize
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sensor::{Beam, HitKind, SensorKind};

    /// A full-circle scan of `n` rays whose range is `f(azimuth)`.
    pub(crate) fn ring_scan(n: usize, f: impl Fn(f64) -> f32) -> Scan {
        let inc = TAU / n as f64;
        let ranges: Vec<f32> = (0..n)
            .map(|i| f(-std::f64::consts::PI + i as f64 * inc))
            .collect();
        Scan {
            stamp: 0.0,
            kind: SensorKind::Radar,
            pose: Pose::default(),
            angle_min: -std::f64::consts::PI,
            angle_increment: inc,
            azimuths: n,
            elevations: vec![0.0],
            range_min: 0.1,
            range_max: 20.0,
            side_beam_offset: 0.0,
            hits: vec![HitKind::None; n],
            materials: vec![None; n],
            beams: vec![Beam::Center; n],
            ranges,
            echoes: Vec::new(),
            echo_start: Vec::new(),
        }
    }

    /// Range to a straight wall parallel to the robot's x axis at `y = d` (left side).
    fn left_wall(d: f64) -> impl Fn(f64) -> f32 {
        move |a: f64| {
            if a.sin() > 1e-9 {
                (d / a.sin()) as f32
            } else {
                f32::INFINITY
            }
        }
    }

    /// Ranges of a straight wall `d` m ahead of the sensor, across its path (none beyond
    /// about 78° off the wall's normal).
    fn wall_at(d: f64) -> impl Fn(f64) -> f32 + Copy {
        move |a| {
            if a.cos() > 0.2 {
                (d / a.cos()) as f32
            } else {
                f32::INFINITY
            }
        }
    }

    /// A 270° scan (the back quarter blind) of `n` rays whose range is `f(azimuth)`.
    fn laser_scan(n: usize, f: impl Fn(f64) -> f32) -> Scan {
        let span = 1.5 * std::f64::consts::PI;
        let inc = span / n as f64;
        let mut s = ring_scan(n, |_| f32::INFINITY);
        s.angle_min = -0.5 * span;
        s.angle_increment = inc;
        s.ranges = (0..n).map(|i| f(-0.5 * span + i as f64 * inc)).collect();
        s
    }

    /// A UTM-30LX's range noise: σ 3 cm, 0.05 m at 30 m.
    const UTM_NOISE: RangeNoise = RangeNoise {
        std: 0.03,
        rel: 0.05 / 30.0,
    };

    /// A 270° laser scan every 0.25° of ranges `f(azimuth)`, each with Gaussian noise of
    /// `noise` (seeded).
    fn noisy_laser(f: impl Fn(f64) -> f32, noise: RangeNoise, seed: u64) -> Scan {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut s = laser_scan(1080, f);
        for r in &mut s.ranges {
            if r.is_finite() {
                let n = rand_distr::Normal::new(0.0, noise.sigma(f64::from(*r))).expect("sigma");
                *r += n.sample(&mut rng) as f32;
            }
        }
        s
    }

    #[test]
    fn denoised_returns_of_a_noisy_laser_keep_a_wall_where_it_is() {
        // A wall 0.3 m to the left, seen with 3 cm of range noise: of the returns abreast of
        // a P3AT's body, a few always fall 4 cm short or more (enough to block a clearance
        // check), the denoised ones never do.
        let d = 0.3;
        let mount = Pose::default();
        let short = |pts: &[DVec2]| {
            pts.iter()
                .filter(|q| q.x.abs() <= 0.5 && q.y < d - 0.04)
                .count()
        };
        let mut raw_blocked = 0;
        for seed in 0..20 {
            let scan = noisy_laser(left_wall(d), UTM_NOISE, seed);
            let raw = Bumpers::sense(&scan, &mount, 8, 1.27, 0.5, BumperRule::All);
            if short(raw.points()) >= super::super::passage::HITS_TO_BLOCK {
                raw_blocked += 1;
            }
            let denoised = denoised_returns(&scan, &mount, &[]);
            let left = short(&denoised);
            assert!(
                left < super::super::passage::HITS_TO_BLOCK,
                "seed {seed}: {left}"
            );
        }
        assert!(
            raw_blocked >= 15,
            "raw returns blocked in {raw_blocked} of 20"
        );
    }

    /// A UTM-30LX scan of ranges `f(azimuth)` from a sensor at `mount` (seeded), and its
    /// returns denoised with `scans - 1` earlier scans of the same (seeds after it) pooled in,
    /// all from one pose.
    fn pooled_laser(
        f: impl Fn(f64) -> f32 + Copy,
        mount: &Pose,
        seed: u64,
        scans: u64,
    ) -> (Scan, Vec<DVec2>) {
        let past: Vec<(usize, DVec2)> = (1..scans)
            .flat_map(|k| {
                let scan = noisy_laser(f, UTM_NOISE, 100 * seed + k);
                PastScan::of(&scan, mount, Pose::default()).points
            })
            .collect();
        let scan = noisy_laser(f, UTM_NOISE, 100 * seed);
        let steady = denoised_returns(&scan, mount, &past);
        (scan, steady)
    }

    #[test]
    fn the_guard_on_pooled_returns_lets_a_turn_clear_of_a_wall_by_centimetres_through() {
        use super::super::guard::{Guarded, guard, guard_steady};
        use crate::vehicle::{P3AT, Twist};
        // A wall ahead-right of a P3AT standing still, seen by a UTM-30LX (σ 3 cm) at the
        // body's centre over the last scans; turning left on the spot, the front-right
        // corner sweeps across the wall's normal on a circle of the body's half-diagonal
        // within the guard's horizon. 4.5 cm clear of that circle, the raw returns nearest the
        // corners' path lie some 2.5 σ short of the wall and stop the turn in most trials
        // (the robot stood turning against it until the watchdog gave up, r22700-crates);
        // on the pooled returns the turn is free in every trial. 1 cm clear, they stop it in
        // every trial.
        let mount = Pose::default();
        let turn = Twist { v: 0.0, omega: 0.8 };
        let circle = 0.5 * P3AT.length.hypot(P3AT.width);
        let pooled = STEADY_SCANS as u64 + 1;
        // The wall's normal: where the corner is at the end of the guard's 0.3 s horizon
        // (it starts a centimetre farther from the wall than that).
        let normal = -P3AT.width.atan2(P3AT.length) + 0.3 * turn.omega;
        let guarded = |clear: f64, seed: u64| {
            let ahead = wall_at(circle + clear);
            let wall = move |a: f64| ahead(a - normal);
            let (scan, steady) = pooled_laser(wall, &mount, seed, pooled);
            let raw = Bumpers::sense(&scan, &mount, 8, 1.27, 0.5, BumperRule::All);
            (
                guard(raw.clearance(), &P3AT, turn),
                guard_steady(&steady, &P3AT, turn),
            )
        };
        let mut raw_stopped = 0;
        for seed in 0..12 {
            let (raw, steady) = guarded(0.045, seed);
            raw_stopped += usize::from(raw == Guarded::Stop);
            assert_eq!(steady, Guarded::Free, "4.5 cm, seed {seed}");
            let (_, steady) = guarded(0.01, seed);
            assert_eq!(steady, Guarded::Stop, "1 cm, seed {seed}");
        }
        assert!(raw_stopped >= 10, "raw stopped {raw_stopped} of 12");
        // A crate's corner pointing at the robot there instead, 1 cm clear: the medians round
        // its tip off (they lie up to a centimetre beyond it), the margin covers that.
        let tip = |clear: f64| {
            let u = DVec2::from_angle(normal);
            let at = u * (circle + clear);
            let faces = [
                u.rotate(DVec2::from_angle(0.8)),
                u.rotate(DVec2::from_angle(-0.8)),
            ];
            move |a: f64| {
                let ray = DVec2::from_angle(a);
                faces
                    .iter()
                    .filter_map(|f| {
                        // at + s f = t ray, 0 <= s <= 0.5, t > 0.
                        let det = ray.perp_dot(*f);
                        (det.abs() > 1e-12).then(|| (at.perp_dot(*f) / det, at.perp_dot(ray) / det))
                    })
                    .filter(|&(t, s)| t > 0.0 && (0.0..=0.5).contains(&s))
                    .map(|(t, _)| t as f32)
                    .fold(f32::INFINITY, f32::min)
            }
        };
        for seed in 0..12 {
            let (_, steady) = pooled_laser(tip(0.01), &mount, seed, pooled);
            assert_eq!(
                guard_steady(&steady, &P3AT, turn),
                Guarded::Stop,
                "corner, seed {seed}"
            );
        }
    }

    #[test]
    fn steady_returns_pooled_over_scans_tell_a_way_closed_to_the_disc_from_one_just_open() {
        // A straight way between two walls, a P3AT (0.508 × 0.497 m: turning circle 0.71 m)
        // on its middle line, its UTM-30LX 0.1 m ahead of the centre. Pooled over the last
        // scans, the narrowing check closes a 0.70 m way and leaves a 0.72 m one open in
        // every trial; on one scan's returns alone the closest pair across 0.72 m lies as
        // near as across 0.70 m, and the 0.72 m way is closed in most trials.
        let (length, width) = (0.508, 0.497);
        let way = |w: f64| {
            move |a: f64| {
                if a.sin().abs() > 1e-9 {
                    (0.5 * w / a.sin().abs()) as f32
                } else {
                    f32::INFINITY
                }
            }
        };
        let mount = Pose::new(0.1, 0.0, 0.0, 0.0);
        // As a passage is given it: the noise at the follow radius.
        let sigma = STEADY_NOISE * UTM_NOISE.sigma(0.76);
        let narrow = |w: f64, seed: u64, scans: u64| {
            let (_, steady) = pooled_laser(way(w), &mount, seed, scans);
            super::super::passage::narrows_ahead(&steady, length, width, sigma, length / 2.0 + 0.15)
        };
        let pooled = STEADY_SCANS as u64 + 1;
        for seed in 0..12 {
            assert!(!narrow(0.72, seed, pooled), "0.72 m closed, seed {seed}");
            assert!(narrow(0.70, seed, pooled), "0.70 m open, seed {seed}");
        }
        let alone = (0..12).filter(|&seed| narrow(0.72, seed, 1)).count();
        assert!(alone >= 6, "one scan closed 0.72 m in {alone} of 12");
    }

    #[test]
    fn earlier_scans_pooled_from_where_the_robot_is_now_stay_on_their_wall() {
        // A wall 0.35 m to the left, scanned (3 cm of noise) from poses 2 cm apart along it,
        // turning half a degree between scans, and from the last one 5 cm ahead of the first
        // and turned 10° toward the wall: the denoised returns pooled with the earlier
        // scans, seen from there, lie on the wall within 1.5 cm. Pooled as if the robot had
        // not moved, they would lie up to 5 cm off it.
        let mount = Pose::new(0.1, 0.0, 0.0, 0.0);
        let wall_y = 0.35;
        // A wall along x at `wall_y` in the world, seen from the robot at `pose`.
        let seen = |pose: Pose| {
            move |a: f64| {
                let o = pose.xy() + DVec2::from_angle(pose.yaw).rotate(mount.xy());
                let s = (pose.yaw + a).sin();
                if s > 1e-9 {
                    ((wall_y - o.y) / s) as f32
                } else {
                    f32::INFINITY
                }
            }
        };
        let poses: Vec<Pose> = (0..STEADY_SCANS)
            .map(|k| Pose::new(0.02 * k as f64, 0.0, 0.0, 0.01 * k as f64))
            .collect();
        let now = Pose::new(0.05, 0.0, 0.0, 10f64.to_radians());
        let off_wall = |past: &[(usize, DVec2)]| {
            let scan = noisy_laser(seen(now), UTM_NOISE, 99);
            let to_world = DVec2::from_angle(now.yaw);
            denoised_returns(&scan, &mount, past)
                .iter()
                .map(|&q| now.xy() + to_world.rotate(q))
                .filter(|w| (-0.3..=0.4).contains(&w.x))
                .map(|w| (w.y - wall_y).abs())
                .fold(0.0, f64::max)
        };
        let recent: Vec<PastScan> = poses
            .iter()
            .enumerate()
            .map(|(k, &p)| PastScan::of(&noisy_laser(seen(p), UTM_NOISE, k as u64), &mount, p))
            .collect();
        let moved: Vec<(usize, DVec2)> = recent.iter().flat_map(|p| p.seen_from(&now)).collect();
        let still: Vec<(usize, DVec2)> = recent.iter().flat_map(|p| p.points.clone()).collect();
        let (moved, still) = (off_wall(&moved), off_wall(&still));
        assert!(moved < 0.015, "{moved}");
        assert!(still > 0.03, "{still}");
    }

    /// The index of the first ray of `scan` that returns: with every ray from there on
    /// returning, ray `i`'s return is [`Bumpers::points`]`[i - near_start]`.
    fn near_start(scan: &Scan) -> usize {
        scan.ranges.iter().position(|r| r.is_finite()).unwrap_or(0)
    }

    #[test]
    fn denoised_returns_keep_an_edge_and_a_clean_scan() {
        // A face 0.4 m ahead ending 0.1 m left of the sensor's axis, and 0.3 m behind it a
        // wall going on: without noise every return stays on its surface to the millimetre
        // (the edge's rays too); with noise, no ray on the face comes out nearer the wall
        // than the face, none beyond the face's end nearer the face.
        let (near, far, end) = (0.4, 0.7, 0.1);
        let mid = 0.5 * (near + far);
        let step = move |a: f64| {
            if a.cos() <= 0.2 {
                f32::INFINITY
            } else if near * a.tan() <= end {
                (near / a.cos()) as f32
            } else {
                (far / a.cos()) as f32
            }
        };
        let mount = Pose::new(0.1, 0.0, 0.0, 0.0);
        // Every ray returns (none below the minimum): the rays denoised, in order.
        let steady_rays = |scan: &Scan| -> Vec<usize> {
            (0..scan.ranges.len())
                .filter(|&i| f64::from(scan.ranges[i]) <= STEADY_RANGE)
                .collect()
        };
        let clean = laser_scan(1080, step);
        let exact = denoised_returns(&clean, &mount, &[]);
        let raw = Bumpers::sense(&clean, &mount, 8, 1.27, 0.5, BumperRule::All);
        let rays = steady_rays(&clean);
        assert_eq!(exact.len(), rays.len());
        assert!(rays.len() > 300, "{}", rays.len());
        for (q, &i) in exact.iter().zip(&rays) {
            let p = raw.points()[i - near_start(&clean)];
            assert!(q.distance(p) < 1e-3, "{q} against {p}");
        }
        for seed in 0..10 {
            let scan = noisy_laser(step, UTM_NOISE, seed);
            for (&i, q) in steady_rays(&scan)
                .iter()
                .zip(denoised_returns(&scan, &mount, &[]))
            {
                let a = scan.angles(i).0;
                let depth = q.x - mount.x;
                if near * a.tan() <= end {
                    assert!(depth < mid, "seed {seed}: ray {i} at {depth}");
                } else {
                    assert!(depth > mid, "seed {seed}: ray {i} at {depth}");
                }
            }
        }
    }

    #[test]
    fn remembered_ray_directions_give_the_same_bumpers() {
        // Returns everywhere but a gap: some rays finite, some not, some below range.
        let near = |a: f64| match a {
            a if a.abs() < 0.3 => f32::INFINITY,
            a if a > 2.5 => -1.0,
            a => (1.0 + 0.3 * a.sin()) as f32,
        };
        let (small, large) = (ring_scan(90, near), ring_scan(360, near));
        let mut dirs = Vec::new();
        let mounts = [
            Pose::new(0.2, 0.0, 0.3, 0.0),
            Pose::new(0.2, 0.0, 0.3, 0.0),
            Pose::new(-0.1, 0.05, 0.3, 0.4),
        ];
        for scan in [&small, &large, &small] {
            for mount in &mounts {
                let fresh = Bumpers::sense(scan, mount, 8, 1.27, 0.5, BumperRule::All);
                let kept =
                    Bumpers::sense_with(scan, mount, 8, 1.27, 0.5, BumperRule::All, &mut dirs);
                assert_eq!(kept, fresh);
            }
        }
        assert_eq!(dirs.len(), 360);
    }

    #[test]
    fn clearance_returns_follow_the_robot_between_scans() {
        use crate::setup::MountedSensor;
        use crate::sim::ControlInput;
        // A radar 1 m from a wall ahead scans; then the robot drives 0.3 m on and turns 90°
        // left before the next scan. The sectors stay the scan's; the returns the body is
        // checked against are where the wall is now: 0.7 m away, to the right.
        let wall_ahead = wall_at(1.0);
        let mut scan = ring_scan(360, wall_ahead);
        let sensors = [MountedSensor {
            name: "radar".into(),
            config: crate::sensor::preset("radar_thesis").expect("preset"),
            mount: Pose::default(),
        }];
        let vehicle = crate::vehicle::vehicle("p3at").expect("p3at");
        let mut sensor = BumperSensor::new(BumperConfig::default());
        let at_scan = Pose::default();
        let moved = Pose::new(0.3, 0.0, 0.0, std::f64::consts::FRAC_PI_2);
        for (now, pose) in [(at_scan, 0.0), (moved, 0.2)].map(|(p, t)| (t, p)) {
            scan.pose = at_scan;
            let scans = [Some(scan.clone())];
            let input = ControlInput {
                time: now,
                odometry: &pose,
                truth: &pose,
                bumped: false,
                scans: &scans,
                scan_odometry: &[Some(at_scan)],
                slam: None,
                scan_slam: &[],
                sensors: &sensors,
                vehicle,
            };
            let b = sensor.update(&input).expect("bumpers");
            let nearest = b
                .clearance()
                .iter()
                .min_by(|p, q| p.length().total_cmp(&q.length()))
                .expect("returns");
            if now == 0.0 {
                assert!(
                    (*nearest - DVec2::new(1.0, 0.0)).length() < 0.01,
                    "{nearest}"
                );
            } else {
                assert!(
                    (*nearest - DVec2::new(0.0, -0.7)).length() < 0.01,
                    "{nearest}"
                );
                assert!(b.corridor_free(0.0, 2.0, 0.3));
                assert!(!b.corridor_free(-std::f64::consts::FRAC_PI_2, 1.0, 0.3));
                // The sectors are still the scan's: the wall ahead presses the front one.
                assert_ne!(b.toward(0.0), BumperState::Clear);
            }
            scan.stamp = 0.0;
        }
    }

    #[test]
    fn a_touch_while_backing_blind_is_kept_behind_the_rear_and_stops_backing_there() {
        // A laser that saw nothing behind; the robot backs into something and touches it.
        let v = crate::vehicle::vehicle("p3at").expect("p3at");
        let mount = Pose::default();
        let pose = Pose::new(2.0, 1.0, 0.0, 0.5);
        let empty = laser_scan(1080, |_| f32::INFINITY);
        let mut sensor = BumperSensor::new(BumperConfig::default());
        sensor.touched_at(&pose, v, (-0.1, 0.0), 10.0);
        let mut b = Bumpers::sense(&empty, &mount, 8, 1.27, 0.5, BumperRule::All);
        sensor.remember(&mut b, &empty, &mount, &pose, 10.1);
        let c = b.clearance();
        assert!(!c.is_empty());
        assert!(
            c.iter()
                .all(|q| q.x < -v.length / 2.0 && q.y.abs() <= v.width / 2.0 + 1e-9)
        );
        // The guard now refuses backing on, and lets the robot drive away.
        use super::super::guard::{Guarded, guard};
        use crate::vehicle::Twist;
        let back = Twist {
            v: -0.1,
            omega: 0.0,
        };
        let ahead = Twist { v: 0.1, omega: 0.0 };
        assert_eq!(guard(c, v, back), Guarded::Stop);
        assert_eq!(guard(c, v, ahead), Guarded::Free);
    }

    #[test]
    fn a_robot_standing_wedged_for_minutes_keeps_what_is_behind_it() {
        use super::super::guard::{Guarded, guard};
        use crate::vehicle::{P3AT, Twist};
        use std::f64::consts::PI;
        // A wall 0.3 m ahead, then turned about on the spot: the wall is 0.3 m behind, in
        // the blind sector. Five minutes later, standing there, backing into it is still
        // stopped: the robot has not moved, so nothing it remembers has drifted.
        let mount = Pose::default();
        let sense = |scan: &Scan| Bumpers::sense(scan, &mount, 8, 1.27, 0.5, BumperRule::All);
        let seen = laser_scan(1080, wall_at(0.3));
        let empty = laser_scan(1080, |_| f32::INFINITY);
        let about = Pose::new(0.0, 0.0, 0.0, PI);
        let back = Twist {
            v: -0.3,
            omega: 0.0,
        };
        let mut sensor = BumperSensor::new(BumperConfig::default());
        sensor.remember(&mut sense(&seen), &seen, &mount, &Pose::default(), 0.0);
        for now in [1.0, 300.0] {
            let mut b = sense(&empty);
            sensor.remember(&mut b, &empty, &mount, &about, now);
            assert_eq!(
                guard(b.clearance(), &P3AT, back),
                Guarded::Stop,
                "at {now} s"
            );
        }
    }

    #[test]
    fn returns_behind_a_laser_are_forgotten_once_the_robot_has_moved_far_enough() {
        use std::f64::consts::PI;
        let mount = Pose::default();
        let sense = |scan: &Scan| Bumpers::sense(scan, &mount, 8, 1.27, 0.5, BumperRule::All);
        let seen = laser_scan(1080, wall_at(1.0));
        let empty = laser_scan(1080, |_| f32::INFINITY);
        let behind = Pose::new(0.0, 0.0, 0.0, PI);
        for (moved, kept) in [(MEMORY_PATH - 0.5, true), (MEMORY_PATH + 0.5, false)] {
            let mut sensor = BumperSensor::new(BumperConfig::default());
            sensor.remember(&mut sense(&seen), &seen, &mount, &Pose::default(), 0.0);
            // Long after (a robot shuffling in a narrow way), but having moved `moved`.
            sensor.moved = moved;
            let mut b = sense(&empty);
            sensor.remember(&mut b, &empty, &mount, &behind, 0.9 * MEMORY_TIME);
            assert_eq!(!b.clearance().is_empty(), kept, "moved {moved} m");
        }
    }

    #[test]
    fn returns_behind_a_laser_are_remembered_until_it_sees_there_again() {
        use std::f64::consts::PI;
        let mount = Pose::default();
        let sense = |scan: &Scan| Bumpers::sense(scan, &mount, 8, 1.27, 0.5, BumperRule::All);
        let wall_ahead = wall_at(1.0);
        let mut sensor = BumperSensor::new(BumperConfig::default());
        let mut remember = |scan: &Scan, pose: Pose, now: f64| {
            let mut b = sense(scan);
            sensor.remember(&mut b, scan, &mount, &pose, now);
            b
        };
        // A wall 1 m ahead, then turned about on the spot: the wall is behind, blind.
        let seen = laser_scan(1080, wall_ahead);
        let b = remember(&seen, Pose::default(), 0.0);
        assert_eq!(b.clearance().len(), b.points().len());
        let empty = laser_scan(1080, |_| f32::INFINITY);
        let b = remember(&empty, Pose::new(0.0, 0.0, 0.0, PI), 1.0);
        assert!(b.points().is_empty());
        assert!(!b.clearance().is_empty());
        // In the robot frame it lies 1 m behind: backing off is blocked, ahead is free.
        assert!(!b.corridor_free(PI, 1.2, 0.3));
        assert!(b.corridor_free(0.0, 1.2, 0.3));
        assert!(b.clearance().iter().all(|q| (q.x + 1.0).abs() < 1e-6));
        // Turned back to face where it was: the new scan (nothing there now) replaces it.
        let b = remember(&empty, Pose::default(), 2.0);
        assert!(b.clearance().is_empty());
        let b = remember(&empty, Pose::new(0.0, 0.0, 0.0, PI), 3.0);
        assert!(b.clearance().is_empty());
        // Forgotten after a while, or once farther than the memory's radius.
        remember(&seen, Pose::default(), 10.0);
        let later = remember(
            &empty,
            Pose::new(0.0, 0.0, 0.0, PI),
            10.0 + MEMORY_TIME + 1.0,
        );
        assert!(later.clearance().is_empty());
        remember(&seen, Pose::default(), 50.0);
        // 1.6 m behind it: farther than the memory reaches.
        let far = remember(&empty, Pose::new(2.6, 0.0, 0.0, 0.0), 51.0);
        assert!(far.clearance().is_empty());
        // A sensor that sees all round remembers nothing.
        let mut all_round = BumperSensor::new(BumperConfig::default());
        let ring = ring_scan(360, wall_ahead);
        let mut b = sense(&ring);
        all_round.remember(&mut b, &ring, &mount, &Pose::default(), 0.0);
        assert!(all_round.memory.is_empty());
    }

    #[test]
    fn a_new_safety_distance_keeps_what_the_bumpers_remember() {
        // A standoff retry where a wall the laser saw is now behind it, blind: backing off
        // must still see it, and the sectors take the new distance at the next update.
        let mut sensor = BumperSensor::new(BumperConfig::default());
        let wall_ahead = wall_at(1.0);
        let seen = laser_scan(1080, wall_ahead);
        let mut b = Bumpers::sense(&seen, &Pose::default(), 8, 1.27, 0.5, BumperRule::All);
        sensor.remember(&mut b, &seen, &Pose::default(), &Pose::default(), 0.0);
        let remembered = sensor.memory.len();
        assert!(remembered > 0);
        sensor.bumpers = Some(b);
        sensor.set_safety(0.6);
        assert_eq!(sensor.memory.len(), remembered);
        assert_eq!(sensor.config().safety, Some(0.6));
        assert!(
            sensor.latest().is_none(),
            "sectors sensed anew at the next update"
        );
    }

    #[test]
    fn rule_parsing() {
        assert_eq!(BumperRule::parse("all"), Ok(BumperRule::All));
        assert_eq!(
            BumperRule::parse("fraction:0.75"),
            Ok(BumperRule::Fraction(0.75))
        );
        assert!(
            BumperRule::parse("fraction:0")
                .unwrap_err()
                .contains("(0, 1]")
        );
        assert!(
            BumperRule::parse("most")
                .unwrap_err()
                .contains("known: all, any")
        );
        assert_eq!(BumperRule::Fraction(0.5).to_string(), "fraction:0.5");
    }

    #[test]
    fn wall_on_the_left_presses_only_the_left_sector() {
        let s = ring_scan(360, left_wall(1.4));
        let b = Bumpers::sense(&s, &Pose::default(), 8, 1.27, 0.5, BumperRule::All);
        // Sector 2 (left) spans 67.5°..112.5°: ranges 1.4 .. 1.4 / sin 67.5° = 1.515, in band.
        assert_eq!(b.state(2), BumperState::Pressed);
        // The diagonals reach past the band (1.4 / sin 22.5° = 3.7 m): not every ray in it.
        for k in [0, 1, 3, 4, 5, 6, 7] {
            assert_eq!(b.state(k), BumperState::Clear, "sector {k}");
        }
        assert!((b.nearest(2) - 1.4).abs() < 1e-3);
        // Any: the diagonals have rays in the band too.
        let any = Bumpers::sense(&s, &Pose::default(), 8, 1.27, 0.5, BumperRule::Any);
        assert_eq!(any.state(1), BumperState::Pressed);
        assert_eq!(any.state(3), BumperState::Pressed);
        assert_eq!(any.state(0), BumperState::Clear);
        // Nearer than the safety distance: too close, whatever the rule.
        let near = Bumpers::sense(
            &ring_scan(360, left_wall(1.0)),
            &Pose::default(),
            8,
            1.27,
            0.5,
            BumperRule::All,
        );
        assert_eq!(near.state(2), BumperState::TooClose);
        assert_eq!(
            near.toward(std::f64::consts::FRAC_PI_2),
            BumperState::TooClose
        );
        // Four sectors of 90°: the left one's edge rays reach 1.4 / sin 45° = 1.98 m > band.
        let four = Bumpers::sense(&s, &Pose::default(), 4, 1.27, 0.5, BumperRule::All);
        assert_eq!(four.state(1), BumperState::Clear);
        let frac = Bumpers::sense(
            &s,
            &Pose::default(),
            4,
            1.27,
            0.5,
            BumperRule::Fraction(0.6),
        );
        // In band from 1.4 up to 1.77 m: |angle − 90°| ≤ acos(1.4/1.77) = 37.7°, 84 % of 90°.
        assert_eq!(frac.state(1), BumperState::Pressed);
        let strict = Bumpers::sense(
            &s,
            &Pose::default(),
            4,
            1.27,
            0.5,
            BumperRule::Fraction(0.9),
        );
        assert_eq!(strict.state(1), BumperState::Clear);
    }

    #[test]
    fn a_full_circle_scan_sees_all_round_and_a_270_degree_one_does_not() {
        let sense = |s: &Scan| Bumpers::sense(s, &Pose::default(), 8, 0.76, 0.5, BumperRule::All);
        assert!(sense(&ring_scan(360, |_| f32::INFINITY)).sees_all_round());
        assert!(!sense(&laser_scan(1081, |_| f32::INFINITY)).sees_all_round());
        // One ray short of the circle leaves a gap behind.
        let mut s = ring_scan(360, |_| f32::INFINITY);
        s.angle_increment *= 359.0 / 360.0;
        assert!(!sense(&s).sees_all_round());
    }

    #[test]
    fn one_close_ray_is_too_close_and_minus_inf_counts_as_close() {
        let mut s = ring_scan(360, |_| f32::INFINITY);
        s.ranges[180] = 0.8; // straight ahead
        let b = Bumpers::sense(&s, &Pose::default(), 4, 1.27, 0.5, BumperRule::All);
        assert_eq!(b.state(0), BumperState::TooClose);
        assert_eq!(b.state(1), BumperState::Clear);
        s.ranges[180] = f32::NEG_INFINITY;
        let b = Bumpers::sense(&s, &Pose::default(), 4, 1.27, 0.5, BumperRule::All);
        assert_eq!(b.state(0), BumperState::TooClose);
        assert_eq!(b.nearest(0), 0.0);
    }

    #[test]
    fn mount_offset_and_yaw_move_rays_to_the_robot_frame() {
        // A sensor 1 m ahead of the centre, looking backwards: its forward ray (azimuth 0)
        // at 1.5 m ends 0.5 m behind the robot's centre.
        let mut s = ring_scan(360, |_| f32::INFINITY);
        s.ranges[180] = 1.5;
        let mount = Pose::new(1.0, 0.0, 0.0, std::f64::consts::PI);
        let b = Bumpers::sense(&s, &mount, 4, 1.0, 0.5, BumperRule::Any);
        assert_eq!(b.state(2), BumperState::TooClose);
        assert!((b.nearest(2) - 0.5).abs() < 1e-6);
        assert_eq!(b.state(0), BumperState::Clear);
    }

    #[test]
    fn empty_sector_is_clear_and_config_checks() {
        // A 180° scan covers only the front half.
        let mut s = ring_scan(180, |_| 1.4);
        s.angle_min = -std::f64::consts::FRAC_PI_2;
        s.angle_increment = std::f64::consts::PI / 180.0;
        let b = Bumpers::sense(&s, &Pose::default(), 4, 1.0, 0.5, BumperRule::All);
        assert_eq!(b.state(2), BumperState::Clear);
        assert_eq!(b.state(0), BumperState::Pressed);
        let c = BumperConfig {
            sectors: 6,
            ..Default::default()
        };
        assert!(c.validate().unwrap_err().contains("4 or 8"));
        let p3at = crate::vehicle::vehicle("p3at").unwrap();
        assert!((BumperConfig::default().safety_for(p3at) - 1.27).abs() < 1e-9);
        let named = BumperConfig {
            sensor: Some("laser".into()),
            ..Default::default()
        };
        assert_eq!(named.sensor_index(["radar", "laser"].into_iter()), Some(1));
        assert_eq!(
            BumperConfig::default().sensor_index(["radar"].into_iter()),
            Some(0)
        );
        assert_eq!(named.sensor_index(["radar"].into_iter()), None);
    }
}
