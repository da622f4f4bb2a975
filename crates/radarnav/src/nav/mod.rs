//! Navigation controllers (DESIGN §6). So far: teleop, waypoint following and standing still.

mod teleop;
mod waypoints;

pub use teleop::TeleopController;
pub use waypoints::WaypointController;

use crate::sim::{ControlInput, Controller, Decision};
use crate::vehicle::DriveCommand;

/// Stands still for ever (a run with no mission: the sensors still scan).
#[derive(Clone, Copy, Debug)]
pub struct Idle {
    /// Calls per second.
    pub rate_hz: f64,
}

impl Controller for Idle {
    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn update(&mut self, _: &ControlInput<'_>) -> Decision {
        Decision::Drive(DriveCommand::STOP)
    }
}
