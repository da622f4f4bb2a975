//! Missions: what a robot does during a run (`[mission]` in a scenario file).
//!
//! * `teleop`: a timed list of drive commands, inline or from a CSV file.
//! * `waypoints`: visit points in turn with a go-to-point controller steering on odometry.
//! * `bug1`, `bug2`: reach a goal with the Bug algorithms on virtual bumpers.
//! * `explore`: explore with a strategy (`bounce`, `wall_follow`, `spiral`, `frontier`).
//!
//! A teleop CSV has a header naming its columns, then one command per line:
//! `duration,v,omega_deg_s` (m/s, degrees/s) or `duration,left,right` (track speeds, m/s).
//! Blank lines and lines starting with `#` are skipped.

use glam::DVec2;
use thiserror::Error;

use crate::map::PoseSource;
use crate::nav::{
    BugController, BugMission, ExploreController, ExploreMission, TeleopController,
    WaypointController, WithRecoil,
};
use crate::sim::Controller;
use crate::vehicle::DriveCommand;

/// Default controller rate, Hz.
pub const DEFAULT_CONTROLLER_HZ: f64 = 10.0;

/// A mission of a scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Mission {
    /// The robot that runs it (`None`: the scenario's first robot).
    pub robot: Option<String>,
    /// Controller calls per second.
    pub controller_hz: f64,
    /// What to do.
    pub kind: MissionKind,
}

/// The kinds of mission.
#[derive(Clone, Debug, PartialEq)]
pub enum MissionKind {
    /// Timed drive commands.
    Teleop(TeleopSource),
    /// Go to each point in turn.
    Waypoints(WaypointMission),
    /// Bug1 or Bug2 to a goal.
    Bug(BugMission),
    /// Explore.
    Explore(ExploreMission),
}

/// Where teleop commands come from.
#[derive(Clone, Debug, PartialEq)]
pub enum TeleopSource {
    /// Written in the scenario.
    Steps(Vec<TeleopStep>),
    /// A CSV file, as written in the scenario (relative to the scenario file); the caller reads
    /// it and turns it into steps with [`parse_teleop_csv`] (the library does no file I/O).
    File(String),
}

/// A command held for a while.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeleopStep {
    /// Seconds.
    pub duration: f64,
    /// The command.
    pub command: DriveCommand,
}

/// The waypoint mission's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct WaypointMission {
    /// Points to visit, in order.
    pub points: Vec<DVec2>,
    /// Cruise speed, m/s.
    pub speed: f64,
    /// Distance at which a point counts as reached, m.
    pub tolerance: f64,
    /// Start over after the last point.
    pub repeat: bool,
    /// The pose it steers on (default: the odometry).
    pub pose: PoseSource,
}

/// A mission that cannot be started.
#[derive(Debug, Error, PartialEq)]
pub enum MissionError {
    /// The teleop file was named but not read.
    #[error("teleop file `{0}` has not been read (call parse_teleop_csv and use the steps)")]
    UnreadFile(String),
    /// A line of a teleop CSV.
    #[error("{file}:{line}: {message}")]
    Csv {
        /// File name as given.
        file: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

impl Mission {
    /// A mission of the first robot at the default controller rate.
    pub fn new(kind: MissionKind) -> Self {
        Self {
            robot: None,
            controller_hz: DEFAULT_CONTROLLER_HZ,
            kind,
        }
    }

    /// The controller that carries the mission out; `seed` feeds the random choices of the
    /// strategies that make some.
    pub fn controller(&self, seed: u64) -> Result<Box<dyn Controller>, MissionError> {
        Ok(match &self.kind {
            MissionKind::Teleop(TeleopSource::Steps(steps)) => {
                Box::new(TeleopController::new(steps.clone(), self.controller_hz))
            }
            MissionKind::Teleop(TeleopSource::File(f)) => {
                return Err(MissionError::UnreadFile(f.clone()));
            }
            MissionKind::Waypoints(w) => {
                Box::new(WaypointController::new(w.clone(), self.controller_hz))
            }
            MissionKind::Bug(b) => Box::new(WithRecoil::new(BugController::new(
                b.clone(),
                self.controller_hz,
            ))),
            MissionKind::Explore(e) => Box::new(WithRecoil::new(ExploreController::new(
                e.clone(),
                self.controller_hz,
                seed,
            ))),
        })
    }

    /// The pose the mission steers on (`None` for teleop).
    pub fn pose(&self) -> Option<PoseSource> {
        match &self.kind {
            MissionKind::Teleop(_) => None,
            MissionKind::Waypoints(w) => Some(w.pose),
            MissionKind::Bug(b) => Some(b.pose),
            MissionKind::Explore(e) => Some(e.pose),
        }
    }

    /// A one-word name of the kind, as in files.
    pub fn kind_name(&self) -> &'static str {
        match &self.kind {
            MissionKind::Teleop(_) => "teleop",
            MissionKind::Waypoints(_) => "waypoints",
            MissionKind::Bug(b) => b.algorithm.as_str(),
            MissionKind::Explore(_) => "explore",
        }
    }
}

/// Parses a teleop CSV (see the module docs). `file` is only used in error messages.
pub fn parse_teleop_csv(src: &str, file: &str) -> Result<Vec<TeleopStep>, MissionError> {
    use crate::limits::{STEPS, TELEOP_DURATION, TELEOP_SPEED, TELEOP_TURN};
    let err = |line: usize, message: String| MissionError::Csv {
        file: file.to_owned(),
        line,
        message,
    };
    let mut lines = src
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (hline, header) = lines
        .next()
        .ok_or_else(|| err(1, "empty file: expected a header line".into()))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let tracks = match cols.as_slice() {
        ["duration", "v", "omega_deg_s"] => false,
        ["duration", "left", "right"] => true,
        _ => {
            return Err(err(
                hline,
                format!(
                    "expected the header `duration,v,omega_deg_s` or `duration,left,right`, found `{header}`"
                ),
            ));
        }
    };
    let mut steps = Vec::new();
    for (n, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 3 {
            return Err(err(n, format!("expected 3 fields, found {}", fields.len())));
        }
        let mut vals = [0.0; 3];
        for (k, (f, v)) in fields.iter().zip(vals.iter_mut()).enumerate() {
            *v = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    err(
                        n,
                        format!("`{}`: expected a finite number, found `{f}`", cols[k]),
                    )
                })?;
        }
        let limits = if tracks {
            [TELEOP_DURATION, TELEOP_SPEED, TELEOP_SPEED]
        } else {
            [TELEOP_DURATION, TELEOP_SPEED, TELEOP_TURN]
        };
        for ((v, limit), col) in vals.iter().zip(&limits).zip(&cols) {
            limit
                .check(*v)
                .map_err(|m| err(n, format!("`{col}`: {m}")))?;
        }
        if !STEPS.contains((steps.len() + 1) as f64) {
            return Err(err(n, format!("more than {} commands", STEPS.max)));
        }
        let command = if tracks {
            DriveCommand::Tracks {
                left: vals[1],
                right: vals[2],
            }
        } else {
            DriveCommand::twist(vals[1], vals[2].to_radians())
        };
        steps.push(TeleopStep {
            duration: vals[0],
            command,
        });
    }
    if steps.is_empty() {
        return Err(err(hline, "no commands after the header".into()));
    }
    Ok(steps)
}

/// A robot driven from outside the simulation (a USARSim client's `DRIVE`, a ROS 2
/// `/cmd_vel`): every call returns the last command set through [`Remote::command`].
pub struct Remote {
    command: std::rc::Rc<std::cell::Cell<DriveCommand>>,
    rate: f64,
}

impl Remote {
    /// Called at `rate_hz` (the simulation step's rate takes a command at the next step).
    pub fn new(rate_hz: f64) -> Self {
        Self {
            command: std::rc::Rc::new(std::cell::Cell::new(DriveCommand::STOP)),
            rate: rate_hz,
        }
    }

    /// The command cell shared with whoever sets it (the vehicle's limits apply in the step).
    pub fn command(&self) -> std::rc::Rc<std::cell::Cell<DriveCommand>> {
        std::rc::Rc::clone(&self.command)
    }
}

impl Controller for Remote {
    fn rate_hz(&self) -> f64 {
        self.rate
    }

    fn update(&mut self, _input: &crate::sim::ControlInput<'_>) -> crate::sim::Decision {
        crate::sim::Decision::Drive(self.command.get())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_both_headers() {
        let s = parse_teleop_csv(
            "# drive\nduration,v,omega_deg_s\n2,0.5,0\n\n1.5,0,90\n",
            "a.csv",
        )
        .unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].command, DriveCommand::twist(0.0, 90f64.to_radians()));
        let t = parse_teleop_csv("duration,left,right\n1,0.2,0.4\n", "b.csv").unwrap();
        assert_eq!(
            t[0].command,
            DriveCommand::Tracks {
                left: 0.2,
                right: 0.4
            }
        );
    }

    #[test]
    fn csv_errors_name_the_line() {
        let e = |src| parse_teleop_csv(src, "c.csv").unwrap_err().to_string();
        assert_eq!(
            e("duration,v,omega_deg_s\n1,0.5,0\n2,fast,0\n"),
            "c.csv:3: `v`: expected a finite number, found `fast`"
        );
        assert!(e("t,v,w\n").starts_with("c.csv:1: expected the header"));
        assert_eq!(
            e("duration,v,omega_deg_s\n0,1,0\n"),
            "c.csv:2: `duration`: expected 0.001 to 1e6 s, found 0"
        );
        assert_eq!(
            e("duration,left,right\n1,1e300,0\n"),
            "c.csv:2: `left`: expected -10 to 10 m/s, found 1e300"
        );
        assert_eq!(
            e("duration,v,omega_deg_s\n1,2\n"),
            "c.csv:2: expected 3 fields, found 2"
        );
        assert_eq!(e(""), "c.csv:1: empty file: expected a header line");
        assert_eq!(
            e("duration,left,right\n"),
            "c.csv:1: no commands after the header"
        );
    }
}
