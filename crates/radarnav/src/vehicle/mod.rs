//! Vehicles (DESIGN §4): the P3AT preset, drive commands and planar kinematics.
//!
//! A skid-steer vehicle is driven either by its left/right track speeds (as USARSim's
//! `DRIVE {Left}{Right}`) or by a body twist (v, ω); the two are related by
//! `v = (l + r) / 2`, `ω = (r − l) / b` with `b` the wheel separation. Motion within a step is
//! an exact arc, so straight lines, turns in place and circles match their closed forms.

pub mod odometry;

pub use odometry::{Odometry, OdometryNoise};

use serde::Serialize;

use crate::pose::{Pose, wrap_angle};
use crate::world::OrientedBox;
use crate::world::overlap::body_box;

/// Dimensions and limits of a vehicle.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VehicleSpec {
    /// Preset name.
    pub name: &'static str,
    /// Footprint along x, m.
    pub length: f64,
    /// Footprint along y, m.
    pub width: f64,
    /// Body height: the band above the ground in which objects block it, m.
    pub height: f64,
    /// Top speed of each track, m/s.
    pub max_speed: f64,
    /// Top turn rate, rad/s.
    pub max_turn_rate: f64,
    /// Wheel radius, m (turns USARSim wheel spin speeds into track speeds).
    pub wheel_radius: f64,
    /// Distance between the left and right wheels, m.
    pub wheel_separation: f64,
    /// Distance between front and rear axles, m.
    pub wheel_base: f64,
}

/// Pioneer 3-AT: footprint, height, speed and turn rate from the Adept MobileRobots datasheet;
/// wheel radius, separation and base from USARSim's P3AT model.
pub const P3AT: VehicleSpec = VehicleSpec {
    name: "p3at",
    length: 0.508,
    width: 0.497,
    height: 0.277,
    max_speed: 0.7,
    max_turn_rate: 140.0 * std::f64::consts::PI / 180.0,
    wheel_radius: 0.098,
    wheel_separation: 0.36,
    wheel_base: 0.248,
};

/// Every vehicle preset.
pub const VEHICLES: &[VehicleSpec] = &[P3AT];

/// The vehicle preset called `name`.
pub fn vehicle(name: &str) -> Option<&'static VehicleSpec> {
    VEHICLES.iter().find(|v| v.name == name)
}

/// A body twist: forward speed and turn rate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Twist {
    /// m/s along the body's x axis.
    pub v: f64,
    /// rad/s, counter-clockwise.
    pub omega: f64,
}

/// What a controller asks the vehicle to do until its next call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DriveCommand {
    /// Body twist (v m/s, ω rad/s).
    Twist(Twist),
    /// Left and right track surface speeds, m/s.
    Tracks {
        /// Left track, m/s.
        left: f64,
        /// Right track, m/s.
        right: f64,
    },
}

impl DriveCommand {
    /// Standing still.
    pub const STOP: Self = Self::Twist(Twist { v: 0.0, omega: 0.0 });

    /// A twist command.
    pub fn twist(v: f64, omega: f64) -> Self {
        Self::Twist(Twist { v, omega })
    }

    /// Whether it turns on the spot: a turn rate without forward speed.
    pub fn is_turn_on_the_spot(&self) -> bool {
        match *self {
            Self::Twist(Twist { v, omega }) => v.abs() < 1e-9 && omega != 0.0,
            Self::Tracks { left, right } => (left + right).abs() < 1e-9 && left != 0.0,
        }
    }

    /// USARSim's `DRIVE {Left l} {Right r}` for a skid-steered robot: wheel spin speeds in rad/s.
    pub fn usarsim_drive(left: f64, right: f64, spec: &VehicleSpec) -> Self {
        Self::Tracks {
            left: left * spec.wheel_radius,
            right: right * spec.wheel_radius,
        }
    }
}

impl VehicleSpec {
    /// Track speeds (left, right) of a twist.
    pub fn tracks(&self, t: Twist) -> (f64, f64) {
        let half = t.omega * self.wheel_separation / 2.0;
        (t.v - half, t.v + half)
    }

    /// The twist a command asks for, scaled down as a whole (so the path keeps its curvature)
    /// until both tracks are within `max_speed` and the turn rate within `max_turn_rate`.
    /// Non-finite requests become a stop.
    pub fn limit(&self, cmd: DriveCommand) -> Twist {
        let t = match cmd {
            DriveCommand::Twist(t) => t,
            DriveCommand::Tracks { left, right } => Twist {
                v: (left + right) / 2.0,
                omega: (right - left) / self.wheel_separation,
            },
        };
        if !(t.v.is_finite() && t.omega.is_finite()) {
            return Twist::default();
        }
        let (l, r) = self.tracks(t);
        let over = [
            l.abs() / self.max_speed,
            r.abs() / self.max_speed,
            t.omega.abs() / self.max_turn_rate,
        ]
        .into_iter()
        .fold(1.0f64, f64::max);
        Twist {
            v: t.v / over,
            omega: t.omega / over,
        }
    }

    /// The body as a box at a ground pose.
    pub fn body(&self, pose: &Pose) -> OrientedBox {
        body_box(
            pose.x,
            pose.y,
            pose.yaw,
            self.length,
            self.width,
            self.height,
        )
    }
}

/// The pose reached from `pose` after driving twist `t` for `dt` seconds: an exact arc
/// (a straight line when ω = 0).
pub fn integrate(pose: &Pose, t: Twist, dt: f64) -> Pose {
    let dyaw = t.omega * dt;
    let (s0, c0) = pose.yaw.sin_cos();
    let (dx, dy) = if dyaw.abs() < 1e-9 {
        // Second-order series of the arc; exact to rounding at this size.
        let d = t.v * dt;
        (d * (c0 - s0 * dyaw / 2.0), d * (s0 + c0 * dyaw / 2.0))
    } else {
        let (s1, c1) = (pose.yaw + dyaw).sin_cos();
        let r = t.v / t.omega;
        (r * (s1 - s0), r * (c0 - c1))
    };
    Pose {
        x: pose.x + dx,
        y: pose.y + dy,
        z: pose.z,
        yaw: wrap_angle(pose.yaw + dyaw),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn straight_line() {
        let mut p = Pose::new(1.0, 2.0, 0.0, FRAC_PI_2 / 3.0);
        for _ in 0..100 {
            p = integrate(&p, Twist { v: 0.5, omega: 0.0 }, 0.05);
        }
        // 2.5 m along 30°.
        assert!(close(p.x, 1.0 + 2.5 * (PI / 6.0).cos()));
        assert!(close(p.y, 2.0 + 2.5 * 0.5));
        assert!(close(p.yaw, PI / 6.0));
    }

    #[test]
    fn turn_in_place() {
        let mut p = Pose::new(3.0, -1.0, 0.0, 0.0);
        for _ in 0..40 {
            p = integrate(
                &p,
                Twist {
                    v: 0.0,
                    omega: FRAC_PI_2,
                },
                0.05,
            );
        }
        assert!(close(p.x, 3.0) && close(p.y, -1.0));
        assert!(wrap_angle(p.yaw - PI).abs() < 1e-9); // 2 s at 90°/s
    }

    #[test]
    fn arc_stays_on_its_circle() {
        // v = 0.4, ω = 0.5 → radius 0.8, centre at (0, 0.8) from the origin facing +x.
        let t = Twist { v: 0.4, omega: 0.5 };
        let mut p = Pose::default();
        for k in 1..=200 {
            p = integrate(&p, t, 0.05);
            let theta = 0.5 * 0.05 * k as f64;
            assert!((p.x - 0.8 * theta.sin()).abs() < 1e-9);
            assert!((p.y - 0.8 * (1.0 - theta.cos())).abs() < 1e-9);
            assert!((p.x * p.x + (p.y - 0.8).powi(2)).sqrt() - 0.8 < 1e-9);
        }
    }

    #[test]
    fn tracks_and_twist_agree() {
        let t = Twist { v: 0.3, omega: 0.8 };
        let (l, r) = P3AT.tracks(t);
        let back = P3AT.limit(DriveCommand::Tracks { left: l, right: r });
        assert!(close(back.v, t.v) && close(back.omega, t.omega));
        // USARSim spin speeds: 1 rad/s on both sides is 0.098 m/s forward.
        let u = P3AT.limit(DriveCommand::usarsim_drive(1.0, 1.0, &P3AT));
        assert!(close(u.v, 0.098) && close(u.omega, 0.0));
    }

    #[test]
    fn limits_keep_curvature() {
        let t = P3AT.limit(DriveCommand::twist(2.0, 1.0));
        let (l, r) = P3AT.tracks(t);
        assert!(l.abs() <= 0.7 + 1e-12 && r.abs() <= 0.7 + 1e-12);
        assert!(close(t.v / t.omega, 2.0));
        let spin = P3AT.limit(DriveCommand::twist(0.0, 10.0));
        assert!(close(spin.omega, P3AT.max_turn_rate));
        assert_eq!(
            P3AT.limit(DriveCommand::twist(f64::NAN, 0.0)),
            Twist::default()
        );
    }
}
