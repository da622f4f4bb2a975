//! Go-to-point waypoint following on the odometry estimate.

use glam::DVec2;

use crate::mission::WaypointMission;
use crate::pose::wrap_angle;
use crate::sim::{ControlInput, Controller, Decision, Ending};
use crate::vehicle::DriveCommand;

/// Heading error beyond which the robot turns on the spot before driving, rad (30°).
const TURN_IN_PLACE: f64 = 0.52;
/// Turn-rate gain, (rad/s) per rad of heading error.
const K_HEADING: f64 = 2.0;
/// Speed gain near a point, (m/s) per m of distance; the robot slows down as it arrives.
const K_DISTANCE: f64 = 1.0;

/// Visits the mission's points in turn: turn towards the point, drive while steering onto it,
/// slow down on arrival. It trusts the pose it is told to (the odometry by default, so its
/// path drifts with it).
#[derive(Clone, Debug)]
pub struct WaypointController {
    mission: WaypointMission,
    rate_hz: f64,
    next: usize,
}

impl WaypointController {
    /// A controller for `mission`, called at `rate_hz`.
    pub fn new(mission: WaypointMission, rate_hz: f64) -> Self {
        Self {
            mission,
            rate_hz,
            next: 0,
        }
    }

    /// Index of the point being driven to.
    pub fn target_index(&self) -> usize {
        self.next
    }
}

impl Controller for WaypointController {
    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn update(&mut self, input: &ControlInput<'_>) -> Decision {
        let pose = &super::nav_pose(self.mission.pose, input);
        let here = DVec2::new(pose.x, pose.y);
        loop {
            let Some(&target) = self.mission.points.get(self.next) else {
                return Decision::Finished(Ending::Completed);
            };
            let to = target - here;
            let dist = to.length();
            if dist <= self.mission.tolerance {
                self.next += 1;
                if self.next == self.mission.points.len() && self.mission.repeat {
                    self.next = 0;
                }
                if self.mission.points.len() == 1 && self.mission.repeat {
                    return Decision::Drive(DriveCommand::STOP);
                }
                continue;
            }
            let err = wrap_angle(to.y.atan2(to.x) - pose.yaw);
            let omega = K_HEADING * err;
            let v = if err.abs() > TURN_IN_PLACE {
                0.0
            } else {
                (K_DISTANCE * dist).min(self.mission.speed) * err.cos()
            };
            return Decision::Drive(DriveCommand::twist(v, omega));
        }
    }
}
