//! Localisation without ground truth (DESIGN §10): each scan of one sensor is registered
//! against the map built from the scans before it, with the odometry as the motion prior.
//!
//! The method is Hector SLAM's (Kohlbrecher et al. 2011), as Cartographer's local SLAM refines
//! its matches: the scan's returns (a radar's first echoes, whether a solid stopped the ray or
//! its budget ran out in foliage; a laser's ranges) are moved by a candidate pose onto a
//! smoothed likelihood grid ([`likelihood`]), and Gauss–Newton finds the pose where they lie
//! on the most likely cells, coarse level first. The odometry's motion since the last scan
//! predicts the pose and stays in the cost as a weak prior, so a scan with nothing to hold on
//! to (a corridor's length, an empty field) leaves the odometry in charge of that direction.
//! A match that moves the prediction further than the odometry could have erred is refused.
//! The scan then goes into the map at the registered pose once the robot has moved far enough
//! from where the last one went in (a keyframe), so the map is not smeared by every scan.
//!
//! Between registrations the estimate follows the odometry: `estimate = anchor_slam ∘
//! anchor_odometry⁻¹ ∘ odometry`, so every consumer (a controller at 10 Hz, a mapper placing a
//! laser scan taken between two radar scans) gets a pose at any time.

pub mod graph;
pub mod likelihood;

use glam::{DMat3, DVec2, DVec3};
use serde::Serialize;

use crate::pose::{Pose, wrap_angle};
use crate::sensor::{HitKind, Scan};
use likelihood::Level;

/// How the localiser works.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SlamConfig {
    /// Index of the registered sensor in the robot's sensors.
    pub sensor: usize,
    /// Cell size of the finest likelihood level, m.
    pub resolution: f64,
    /// Likelihood levels, each twice as coarse as the one before.
    pub levels: usize,
    /// Returns farther than this are not used, m.
    pub max_range: f64,
    /// A scan goes into the map after the robot moved this far since the last one, m...
    pub keyframe_distance: f64,
    /// ...or turned this much, rad.
    pub keyframe_angle: f64,
}

impl SlamConfig {
    /// The defaults for sensor `sensor`: Hector's 5 cm over three levels, keyframes every
    /// 0.5 m or 15° (inserting every scan thickens the map with each one's small error: on
    /// the foliage-wall loop, keyframes every 0.1 m put the radar map's obstacle precision
    /// 6 points below the true-pose map's, every 0.5 m 1–2 points).
    pub fn for_sensor(sensor: usize) -> Self {
        Self {
            sensor,
            resolution: 0.05,
            levels: 3,
            max_range: 30.0,
            keyframe_distance: 0.5,
            keyframe_angle: 15f64.to_radians(),
        }
    }
}

/// Gauss–Newton iterations per level at most.
const ITERATIONS: usize = 8;
/// Scale of the Cauchy loss on a return's residual `1 - M`: returns whose likelihood is below
/// about 0.9 count less and less. The thesis radar's returns from inside foliage lie where its
/// budget ran out, which moves with the viewpoint; with plain least squares they drag the
/// pose by centimetres (7 cm RMS on the foliage-wall lap of the tests, 2.7 cm with this).
const ROBUST_SCALE: f64 = 0.1;
/// Times a step that raises the cost is halved before the level is left.
const HALVINGS: usize = 3;
/// Standard deviations of the odometry prior on one registration: position, m, and heading,
/// rad. Wide: the scan decides wherever it can.
const PRIOR_SIGMA: (f64, f64) = (0.25, 0.1);
/// Largest correction of the prediction a match may make, m and rad: beyond what the odometry
/// can err between two scans, a match is a wrong one.
const MAX_CORRECTION: (f64, f64) = (0.5, 0.25);
/// Fewest returns a scan needs to be registered.
const MIN_POINTS: usize = 12;
/// Returns closer together than this fraction of the finest cell are merged (a laser's
/// 1080 returns on a near wall are a few dozen distinct cells).
const POINT_SPACING: f64 = 1.0;
/// Neighbouring returns up to this many beam steps apart (at the farther one's range) are
/// taken as one surface.
const JOIN_STEPS: f64 = 2.5;
/// Scan planes steeper than this are not registered: the localiser is planar, m/m.
const MAX_ELEVATION_SIN: f64 = 0.09;

/// The localiser's counters, for `summary.json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SlamStats {
    /// Scans registered.
    pub registered: u64,
    /// Scans whose match was refused (too few returns, or a correction too large).
    pub refused: u64,
    /// Scans put into the map.
    pub keyframes: u64,
    /// Mean likelihood of the registered scans' returns at their final poses.
    pub mean_score: f64,
}

/// Registers one sensor's scans into a pose estimate (see the module doc).
#[derive(Clone, Debug)]
pub struct Localiser {
    config: SlamConfig,
    /// The registered sensor's mount on the robot.
    mount: Pose,
    levels: Vec<Level>,
    /// The last registered pose and the odometry at its time.
    anchor: (Pose, Pose),
    /// Where the last keyframe went in; `None` before the first.
    last_keyframe: Option<Pose>,
    /// The current scan's returns in the robot frame.
    points: Vec<DVec2>,
    /// Neighbouring returns of the current scan, joined (robot frame).
    segments: Vec<(DVec2, DVec2)>,
    stats: SlamStats,
    score_sum: f64,
}

impl Localiser {
    /// A localiser for a robot starting at `start` (where its odometry starts too), its sensor
    /// mounted at `mount`.
    pub fn new(config: SlamConfig, mount: Pose, start: Pose) -> Self {
        let half = config.max_range.min(50.0) + 2.0;
        let levels = (0..config.levels.max(1))
            .map(|l| Level::new(config.resolution * f64::from(1u32 << l), start.xy(), half))
            .collect();
        Self {
            config,
            mount,
            levels,
            anchor: (start, start),
            last_keyframe: None,
            points: Vec::new(),
            segments: Vec::new(),
            stats: SlamStats::default(),
            score_sum: 0.0,
        }
    }

    /// The settings.
    pub fn config(&self) -> &SlamConfig {
        &self.config
    }

    /// The estimated robot pose for an odometry reading taken since the last registration.
    pub fn estimate(&self, odometry: &Pose) -> Pose {
        let moved = self.anchor.1.inverse().compose(odometry);
        let p = self.anchor.0.compose(&moved);
        Pose { z: 0.0, ..p }
    }

    /// What the localiser did so far.
    pub fn stats(&self) -> SlamStats {
        SlamStats {
            mean_score: if self.stats.registered > 0 {
                self.score_sum / self.stats.registered as f64
            } else {
                0.0
            },
            ..self.stats
        }
    }

    /// Registers `scan` (of the configured sensor), taken where the odometry says `odometry`;
    /// returns the estimated robot pose at the scan's time.
    pub fn register(&mut self, scan: &Scan, odometry: &Pose) -> Pose {
        let predicted = self.estimate(odometry);
        self.collect_points(scan);
        let pose = if self.points.len() < MIN_POINTS {
            self.stats.refused += 1;
            predicted
        } else if self.last_keyframe.is_none() {
            // The first scan makes the map: the start pose is the frame.
            predicted
        } else {
            let (pose, score) = self.match_scan(&predicted);
            let d = pose.xy() - predicted.xy();
            if d.length() > MAX_CORRECTION.0
                || wrap_angle(pose.yaw - predicted.yaw).abs() > MAX_CORRECTION.1
            {
                self.stats.refused += 1;
                predicted
            } else {
                self.stats.registered += 1;
                self.score_sum += score;
                pose
            }
        };
        self.anchor = (pose, *odometry);
        let due = self.last_keyframe.is_none_or(|k| {
            (pose.xy() - k.xy()).length() >= self.config.keyframe_distance
                || wrap_angle(pose.yaw - k.yaw).abs() >= self.config.keyframe_angle
        });
        if due && self.points.len() >= MIN_POINTS {
            self.insert(&pose);
            self.last_keyframe = Some(pose);
            self.stats.keyframes += 1;
        }
        pose
    }

    /// The scan's usable returns in the robot frame, thinned to about one per finest cell.
    fn collect_points(&mut self, scan: &Scan) {
        self.points.clear();
        self.segments.clear();
        let spacing = self.config.resolution * POINT_SPACING;
        let mut last: Option<DVec2> = None;
        // The previous ray's return, if it had one: (point, range).
        let mut previous: Option<(DVec2, f64)> = None;
        let step = scan.angle_increment.abs();
        for i in 0..scan.len() {
            let r = f64::from(scan.ranges[i]);
            if scan.hits[i] == HitKind::None || !r.is_finite() || r > self.config.max_range {
                previous = None;
                continue;
            }
            let (az, el) = scan.angles(i);
            if el.sin().abs() > MAX_ELEVATION_SIN || i % scan.azimuths == 0 {
                previous = None;
            }
            if el.sin().abs() > MAX_ELEVATION_SIN {
                continue;
            }
            // The reading in the sensor frame (a side beam's origin is offset to its left).
            let (s, c) = az.sin_cos();
            let lateral = scan.beams[i].side() * scan.side_beam_offset;
            let reach = r * el.cos();
            let sensor = Pose::new(-s * lateral + c * reach, c * lateral + s * reach, 0.0, 0.0);
            let p = self.mount.compose(&sensor).xy();
            // Neighbouring returns on one surface are joined for the map: a wall 10 m away
            // is a return every 17 cm at 1°, and a line of dots would hold a scan by its gaps.
            // Returns farther apart than a few beam steps are across a depth jump.
            if let Some((q, rq)) = previous {
                let gap = (p - q).length();
                if gap <= JOIN_STEPS * step * r.max(rq) + self.config.resolution {
                    self.segments.push((q, p));
                }
            }
            previous = Some((p, r));
            if last.is_some_and(|q| (p - q).length() < spacing) {
                continue;
            }
            last = Some(p);
            self.points.push(p);
        }
    }

    /// Puts the current returns, and the surfaces joining neighbours, into every level at
    /// `pose`.
    fn insert(&mut self, pose: &Pose) {
        let (s, c) = pose.yaw.sin_cos();
        let world = |p: DVec2| DVec2::new(pose.x + c * p.x - s * p.y, pose.y + s * p.x + c * p.y);
        for level in &mut self.levels {
            for p in &self.points {
                level.insert(world(*p), world(*p));
            }
            for &(a, b) in &self.segments {
                level.insert(world(a), world(b));
            }
        }
    }

    /// Gauss–Newton from `predicted`, coarse level to fine; the pose and the mean likelihood
    /// of the returns there. A step is taken only where it lowers the cost (halved until it
    /// does, up to [`HALVINGS`] times): on the likelihood's peaks the residuals do not reach 0
    /// (the interpolated peak is below 1) while their gradients do, so plain Gauss–Newton
    /// would leap away from the optimum it sits on.
    fn match_scan(&self, predicted: &Pose) -> (Pose, f64) {
        let info = DVec3::new(
            PRIOR_SIGMA.0.powi(-2),
            PRIOR_SIGMA.0.powi(-2),
            PRIOR_SIGMA.1.powi(-2),
        );
        let mut xi = DVec3::new(predicted.x, predicted.y, predicted.yaw);
        for level in self.levels.iter().rev() {
            let mut here = self.normal_equations(level, xi, predicted, info);
            for _ in 0..ITERATIONS {
                let (_, h, g) = here;
                if h.determinant().abs() < 1e-12 {
                    break;
                }
                let step = -(h.inverse() * g);
                let mut scale = 1.0;
                let mut taken = None;
                for _ in 0..=HALVINGS {
                    let next = xi + step * scale;
                    let there = self.normal_equations(level, next, predicted, info);
                    if there.0 < here.0 {
                        taken = Some((next, there));
                        break;
                    }
                    scale *= 0.5;
                }
                let Some((next, there)) = taken else {
                    break;
                };
                (xi, here) = (next, there);
                if (step * scale).truncate().length() < 1e-4 && (step.z * scale).abs() < 1e-4 {
                    break;
                }
            }
        }
        let pose = Pose::new(xi.x, xi.y, 0.0, wrap_angle(xi.z));
        let (s, c) = pose.yaw.sin_cos();
        let finest = &self.levels[0];
        let score = self
            .points
            .iter()
            .map(|p| {
                finest
                    .sample(DVec2::new(
                        pose.x + c * p.x - s * p.y,
                        pose.y + s * p.x + c * p.y,
                    ))
                    .value
            })
            .sum::<f64>()
            / self.points.len() as f64;
        (pose, score)
    }

    /// The cost `Σ ρ(1 - M) + prior` (ρ the Cauchy loss) at pose `xi` (x, y, yaw) on `level`, and the Gauss–Newton
    /// normal equations there, reweighted: `H = Σ w J Jᵀ + P`, `g = Σ w J r + P (xi - predicted)`.
    fn normal_equations(
        &self,
        level: &Level,
        xi: DVec3,
        predicted: &Pose,
        info: DVec3,
    ) -> (f64, DMat3, DVec3) {
        let (s, c) = xi.z.sin_cos();
        let dev = DVec3::new(
            xi.x - predicted.x,
            xi.y - predicted.y,
            wrap_angle(xi.z - predicted.yaw),
        );
        let mut h = DMat3::from_diagonal(info);
        let mut g = info * dev;
        let mut cost = dev.dot(info * dev);
        for p in &self.points {
            let w = DVec2::new(xi.x + c * p.x - s * p.y, xi.y + s * p.x + c * p.y);
            let m = level.sample(w);
            let r = 1.0 - m.value;
            // d(residual)/d(x, y, yaw).
            let j = -DVec3::new(
                m.gradient.x,
                m.gradient.y,
                m.gradient.x * (-s * p.x - c * p.y) + m.gradient.y * (c * p.x - s * p.y),
            );
            // Cauchy weights: a return far off every surface (one that went deeper into
            // foliage than from the last viewpoint) barely pulls.
            let c2 = ROBUST_SCALE * ROBUST_SCALE;
            let w = 1.0 / (1.0 + r * r / c2);
            h += outer(j) * w;
            g += j * (w * r);
            cost += c2 * (r * r / c2).ln_1p();
        }
        (cost, h, g)
    }
}

/// `j jᵀ`.
fn outer(j: DVec3) -> DMat3 {
    DMat3::from_cols(j * j.x, j * j.y, j * j.z)
}

#[cfg(test)]
mod tests;
