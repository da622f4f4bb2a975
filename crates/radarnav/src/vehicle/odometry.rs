//! Wheel odometry with noise: what the robot believes about its own motion.
//!
//! Each step, the executed track speeds are measured with multiplicative noise (slip, tyre
//! wear), and the turn rate gets a constant drift plus white noise (skid-steer turns are the
//! worst part of a skid-steer's odometry). The measured twist is integrated as an exact arc
//! from the previous estimate. A refused move (a bump) stops the wheels, so it adds nothing.

use rand::Rng;
use rand_distr::StandardNormal;
use serde::Serialize;

use super::{Twist, VehicleSpec, integrate};
use crate::pose::Pose;

/// Noise of the odometry.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct OdometryNoise {
    /// Standard deviation of the relative error of each track speed, per step (0.02 = 2 %).
    pub speed_noise: f64,
    /// Constant error of the turn rate, rad/s (positive: the estimate turns left of the truth).
    pub yaw_drift: f64,
    /// Standard deviation of white noise on the turn rate, rad/s.
    pub yaw_noise: f64,
}

impl Default for OdometryNoise {
    /// 2 % track-speed noise and 0.5 °/s turn-rate noise per step, no constant drift: the
    /// estimate wanders by a few degrees over minutes. Set `yaw_drift` to model a biased
    /// robot (skid-steer slip in turns); 0.1–0.5 °/s makes maps visibly bend.
    fn default() -> Self {
        Self {
            speed_noise: 0.02,
            yaw_drift: 0.0,
            yaw_noise: 0.5f64.to_radians(),
        }
    }
}

impl OdometryNoise {
    /// No noise at all: odometry equals the truth.
    pub const NONE: Self = Self {
        speed_noise: 0.0,
        yaw_drift: 0.0,
        yaw_noise: 0.0,
    };
}

/// The odometry estimate of one robot.
#[derive(Clone, Debug)]
pub struct Odometry {
    /// Current estimate.
    pub pose: Pose,
    /// Its noise model.
    pub noise: OdometryNoise,
    /// Distance the estimate has travelled, m.
    pub distance: f64,
}

impl Odometry {
    /// Odometry starting at `pose` (the robot knows where it starts).
    pub fn new(pose: Pose, noise: OdometryNoise) -> Self {
        Self {
            pose,
            noise,
            distance: 0.0,
        }
    }

    /// Adds a step in which the vehicle drove `executed` for `dt` seconds. The noise draws
    /// (left, right, turn) come from `rng` in that order, and only when the noise is on.
    pub fn update<R: Rng + ?Sized>(
        &mut self,
        spec: &VehicleSpec,
        executed: Twist,
        dt: f64,
        rng: &mut R,
    ) {
        if executed == Twist::default() {
            return;
        }
        let (mut l, mut r) = spec.tracks(executed);
        let n = self.noise;
        if n.speed_noise > 0.0 {
            l *= 1.0 + n.speed_noise * rng.sample::<f64, _>(StandardNormal);
            r *= 1.0 + n.speed_noise * rng.sample::<f64, _>(StandardNormal);
        }
        let mut omega = (r - l) / spec.wheel_separation + n.yaw_drift;
        if n.yaw_noise > 0.0 {
            omega += n.yaw_noise * rng.sample::<f64, _>(StandardNormal);
        }
        let measured = Twist {
            v: (l + r) / 2.0,
            omega,
        };
        self.distance += measured.v.abs() * dt;
        self.pose = integrate(&self.pose, measured, dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::P3AT;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn noiseless_odometry_is_the_truth() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut odo = Odometry::new(Pose::default(), OdometryNoise::NONE);
        let mut truth = Pose::default();
        let t = Twist { v: 0.4, omega: 0.3 };
        for _ in 0..100 {
            odo.update(&P3AT, t, 0.05, &mut rng);
            truth = integrate(&truth, t, 0.05);
        }
        assert_eq!(odo.pose, truth);
        assert!((odo.distance - 2.0).abs() < 1e-12);
    }

    #[test]
    fn drift_bends_a_straight_line() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let noise = OdometryNoise {
            yaw_drift: 1f64.to_radians(),
            ..OdometryNoise::NONE
        };
        let mut odo = Odometry::new(Pose::default(), noise);
        for _ in 0..200 {
            odo.update(&P3AT, Twist { v: 0.5, omega: 0.0 }, 0.05, &mut rng);
        }
        // 10 s at 1°/s drift: the estimate heads 10° left of the truth.
        assert!((odo.pose.yaw - 10f64.to_radians()).abs() < 1e-9);
        assert!(odo.pose.y > 0.0);
    }

    #[test]
    fn standing_still_draws_nothing() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut odo = Odometry::new(Pose::default(), OdometryNoise::default());
        odo.update(&P3AT, Twist::default(), 0.05, &mut rng);
        assert_eq!(odo.pose, Pose::default());
        assert_eq!(rng, ChaCha8Rng::seed_from_u64(3));
    }
}
