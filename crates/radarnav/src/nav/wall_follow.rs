//! Wall following on bumper states alone, by the thesis' rules (DESIGN §6).
//!
//! With the wall on side `s` (left or right) and sectors named from the robot's front:
//! 1. front (or the front diagonal on the wall side) pressed or too close: turn on the spot
//!    away from the wall until it releases (a concave corner, or the wall just met);
//! 2. wall-side bumper too close: veer away while creeping forward;
//! 3. wall-side bumper pressed: drive straight along the wall;
//! 4. wall-side bumper clear (a convex corner, or a gap the sensor sees through): arc toward
//!    the wall side on a circle of the wanted distance, so the robot rounds the corner.
//!
//! Until a bumper first reports something the robot drives straight ahead to find a wall; a
//! full circle of rule 4 without meeting anything sends it back to that search.
//!
//! At a gap in foliage the radar sees through, rule 4 turns the robot into the gap; the
//! returns inside the foliage on both sides of it then trip the front bumper and rule 1
//! turns it back out, so it passes gaps narrower than its safety circle without entering.

use std::f64::consts::TAU;

use super::bumper::{BumperState, Bumpers};
use crate::vehicle::DriveCommand;

/// Which side the wall is kept on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Wall on the left: the robot goes round an obstacle clockwise.
    Left,
    /// Wall on the right: counter-clockwise.
    Right,
}

impl Side {
    /// Parses `left` or `right`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "left" => Some(Self::Left),
            "right" => Some(Self::Right),
            _ => None,
        }
    }

    /// `left` or `right`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Left => "left",
            Self::Right => "right",
        }
    }

    /// +1 for left (counter-clockwise angles), −1 for right.
    pub fn sign(self) -> f64 {
        match self {
            Self::Left => 1.0,
            Self::Right => -1.0,
        }
    }
}

/// What the follower is doing, for logs and tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FollowRule {
    /// No wall yet: straight ahead.
    Search,
    /// Rule 1: turning away from the front.
    TurnAway,
    /// Rule 2: veering away from the wall.
    VeerAway,
    /// Rule 3: along the wall.
    Along,
    /// Rule 4: arcing toward the lost wall.
    TowardWall,
}

/// The wall-following behaviour (see the module docs).
#[derive(Clone, Debug)]
pub struct WallFollower {
    side: Side,
    speed: f64,
    turn_rate: f64,
    found: bool,
    lost_turn: f64,
    rule: FollowRule,
}

impl WallFollower {
    /// Follows with the wall on `side` at up to `speed` m/s, turning on the spot at
    /// `turn_rate` rad/s.
    pub fn new(side: Side, speed: f64, turn_rate: f64) -> Self {
        Self {
            side,
            speed,
            turn_rate,
            found: false,
            lost_turn: 0.0,
            rule: FollowRule::Search,
        }
    }

    /// The side the wall is kept on.
    pub fn side(&self) -> Side {
        self.side
    }

    /// The rule applied last.
    pub fn rule(&self) -> FollowRule {
        self.rule
    }

    /// Starts following a wall already met (Bug's hit point), skipping the search.
    pub fn engage(&mut self) {
        self.found = true;
        self.lost_turn = 0.0;
    }

    /// The command for the coming `dt` seconds; convex corners are rounded on circles of
    /// `radius` metres (the wanted wall distance, [`super::BumperSensor::follow_radius`]).
    pub fn command(&mut self, b: &Bumpers, dt: f64, radius: f64) -> DriveCommand {
        let s = self.side.sign();
        let quarter = b.sectors() as isize / 4;
        let si = s as isize;
        let front = b.state(0);
        let wall = b.state(si * quarter);
        // With 8 sectors, the diagonal between front and wall side.
        let diag = (quarter > 1).then(|| b.state(si));
        let blocked = |x: BumperState| x != BumperState::Clear;
        if b.states().iter().any(|&x| x != BumperState::Clear) {
            self.found = true;
        }
        let (rule, v, omega) = if blocked(front) || diag == Some(BumperState::TooClose) {
            (FollowRule::TurnAway, 0.0, -s * self.turn_rate)
        } else if !self.found {
            (FollowRule::Search, self.speed, 0.0)
        } else if wall == BumperState::TooClose || diag == Some(BumperState::Pressed) {
            (FollowRule::VeerAway, 0.5 * self.speed, -0.5 * s * self.turn_rate)
        } else if wall == BumperState::Pressed {
            (FollowRule::Along, self.speed, 0.0)
        } else {
            let v = 0.6 * self.speed;
            (FollowRule::TowardWall, v, s * (v / radius).min(self.turn_rate))
        };
        if rule == FollowRule::TowardWall {
            self.lost_turn += omega.abs() * dt;
            if self.lost_turn > TAU {
                self.found = false;
                self.lost_turn = 0.0;
            }
        } else if rule != FollowRule::Search {
            self.lost_turn = 0.0;
        }
        self.rule = rule;
        DriveCommand::twist(v, omega)
    }
}
