//! Poses in the world frame (REP-103: x forward, y left, z up, yaw counter-clockwise from +x).

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A pose (x, y, z, yaw): the robot moves in the plane z = 0, sensors sit above it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Metres.
    pub x: f64,
    /// Metres.
    pub y: f64,
    /// Metres.
    pub z: f64,
    /// Radians, counter-clockwise from +x.
    pub yaw: f64,
}

impl Pose {
    /// A pose from its four components.
    pub const fn new(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        Self { x, y, z, yaw }
    }

    /// The position as a vector.
    pub fn position(&self) -> DVec3 {
        DVec3::new(self.x, self.y, self.z)
    }

    /// The position in the ground plane.
    pub fn xy(&self) -> glam::DVec2 {
        glam::DVec2::new(self.x, self.y)
    }

    /// `self ∘ child`: the pose of `child` (given relative to `self`) in `self`'s parent frame.
    pub fn compose(&self, child: &Pose) -> Pose {
        let (s, c) = self.yaw.sin_cos();
        Pose {
            x: self.x + c * child.x - s * child.y,
            y: self.y + s * child.x + c * child.y,
            z: self.z + child.z,
            yaw: wrap_angle(self.yaw + child.yaw),
        }
    }

    /// The inverse transform: `self.compose(&self.inverse())` is the identity.
    pub fn inverse(&self) -> Pose {
        let (s, c) = self.yaw.sin_cos();
        Pose {
            x: -(c * self.x + s * self.y),
            y: -(-s * self.x + c * self.y),
            z: -self.z,
            yaw: wrap_angle(-self.yaw),
        }
    }
}

/// Wraps an angle into (-π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let w = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if w <= -std::f64::consts::PI {
        w + std::f64::consts::TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn compose_rotates_child_offset() {
        let robot = Pose::new(1.0, 2.0, 0.0, FRAC_PI_2);
        let mount = Pose::new(0.5, 0.0, 0.4, 0.0);
        let p = robot.compose(&mount);
        assert!((p.x - 1.0).abs() < 1e-12 && (p.y - 2.5).abs() < 1e-12);
        assert!((p.z - 0.4).abs() < 1e-12 && (p.yaw - FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn a_pose_composed_with_its_inverse_is_the_identity() {
        let p = Pose::new(1.5, -2.0, 0.3, 2.9);
        for q in [p.compose(&p.inverse()), p.inverse().compose(&p)] {
            assert!(q.x.abs() < 1e-12 && q.y.abs() < 1e-12 && q.z.abs() < 1e-12);
            assert!(q.yaw.abs() < 1e-12);
        }
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-15);
    }
}
