//! Replays a timed list of drive commands.

use crate::mission::TeleopStep;
use crate::sim::{ControlInput, Controller, Decision, Ending};

/// Plays each step's command for its duration, then finishes. The command in force at a call
/// is the one whose time slot contains the call's time, so slots are honoured to within one
/// controller period.
#[derive(Clone, Debug)]
pub struct TeleopController {
    steps: Vec<TeleopStep>,
    /// End time of each step.
    ends: Vec<f64>,
    rate_hz: f64,
}

impl TeleopController {
    /// A controller for `steps`, called at `rate_hz`.
    pub fn new(steps: Vec<TeleopStep>, rate_hz: f64) -> Self {
        let ends = steps
            .iter()
            .scan(0.0, |t, s| {
                *t += s.duration;
                Some(*t)
            })
            .collect();
        Self {
            steps,
            ends,
            rate_hz,
        }
    }

    /// Total length of the list, s.
    pub fn duration(&self) -> f64 {
        self.ends.last().copied().unwrap_or(0.0)
    }
}

impl Controller for TeleopController {
    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn update(&mut self, input: &ControlInput<'_>) -> Decision {
        // Slack of a nanosecond so a slot ending exactly on a call time is not played again.
        let i = self.ends.partition_point(|&end| end <= input.time + 1e-9);
        self.steps
            .get(i)
            .map_or(Decision::Finished(Ending::Completed), |s| {
                Decision::Drive(s.command)
            })
    }
}
