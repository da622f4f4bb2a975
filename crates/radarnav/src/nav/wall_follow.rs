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
//!
//! A follower told its body ([`WallFollower::passing_gaps`]) also keeps the boundary it
//! follows where a neighbour comes nearer than twice the follow radius: a gap on the wall
//! side wide enough for the body to turn in is passed by a [`Passage`] (see
//! [`super::passage`]) instead of being rounded on a circle that runs into the neighbour.

use std::f64::consts::TAU;

use glam::DVec2;

use super::bumper::{BumperState, Bumpers};
use super::passage::{PassStep, Passage, find_gap};
use crate::pose::Pose;
use crate::vehicle::DriveCommand;

/// How far the follower turns away after a bump, rad (45°).
pub const BUMP_TURN: f64 = std::f64::consts::FRAC_PI_4;
/// A gap whose middle lies this near a dead end is not passed ([`WallFollower::avoid`]), m.
pub const DEAD_END_RADIUS: f64 = 1.5;

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

    /// The other side.
    pub fn other(self) -> Self {
        match self {
            Self::Left => Self::Right,
            Self::Right => Self::Left,
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
    /// Passing a gap narrower than twice the follow radius.
    Gap,
}

/// Gap passing: the body and what it has passed.
#[derive(Clone, Debug)]
struct GapPassing {
    length: f64,
    width: f64,
    stamp: f64,
    travelled: f64,
    last: Option<DVec2>,
    passage: Option<Passage>,
    /// The last gap passed or given up (world middle) and the distance travelled then.
    done: Option<(DVec2, f64)>,
    /// Dead ends left back along the trail ([`super::retrace`]): no gap near one is passed.
    dead_ends: Vec<DVec2>,
}

/// The wall-following behaviour (see the module docs).
#[derive(Clone, Debug)]
pub struct WallFollower {
    side: Side,
    speed: f64,
    turn_rate: f64,
    found: bool,
    lost_turn: f64,
    bump_turn: f64,
    rule: FollowRule,
    gaps: Option<GapPassing>,
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
            bump_turn: 0.0,
            rule: FollowRule::Search,
            gaps: None,
        }
    }

    /// Also passes gaps on the wall side narrower than twice the follow radius (module
    /// docs), for a body of `length` × `width` m.
    pub fn passing_gaps(mut self, length: f64, width: f64) -> Self {
        self.gaps = Some(GapPassing {
            length,
            width,
            stamp: f64::NEG_INFINITY,
            travelled: 0.0,
            last: None,
            passage: None,
            done: None,
            dead_ends: Vec::new(),
        });
        self
    }

    /// Passes no gap whose middle lies within [`DEAD_END_RADIUS`] of the dead end `at` (world
    /// frame, believed): the gap led into it. A passage under way near it is dropped.
    pub fn avoid(&mut self, at: DVec2) {
        if let Some(g) = &mut self.gaps {
            if g.passage
                .as_ref()
                .is_some_and(|p| (p.gap().mid - at).length() <= DEAD_END_RADIUS)
            {
                g.passage = None;
            }
            g.dead_ends.push(at);
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

    /// Whether a gap is being passed and turning on the spot or leaving the boundary now
    /// could touch its sides ([`Passage::committed`]): not once through it, in a passage
    /// with room to turn.
    pub fn passing(&self) -> bool {
        self.gaps
            .as_ref()
            .is_some_and(|g| g.passage.as_ref().is_some_and(Passage::committed))
    }

    /// Starts following a wall already met (Bug's hit point), skipping the search.
    pub fn engage(&mut self) {
        self.found = true;
        self.lost_turn = 0.0;
    }

    /// The robot bumped into something its sensor missed: turn away from the wall side on
    /// the spot by [`BUMP_TURN`] before following on.
    pub fn bumped(&mut self) {
        self.bump_turn = BUMP_TURN;
        if let Some(g) = &mut self.gaps
            && let Some(p) = g.passage.take()
        {
            g.done = Some((p.gap().mid, g.travelled));
        }
    }

    /// A gap to pass or being passed: the move, or `None` for the ordinary rules.
    fn pass_gap(&mut self, b: &Bumpers, pose: &Pose, dt: f64, radius: f64) -> Option<DriveCommand> {
        let side = self.side.sign();
        let ready = self.found && self.bump_turn <= 0.0;
        let g = self.gaps.as_mut()?;
        let p = pose.xy();
        g.travelled += g.last.map_or(0.0, |l| (p - l).length());
        g.last = Some(p);
        if b.stamp() != g.stamp && ready {
            g.stamp = b.stamp();
            let turn_diameter = g.length.hypot(g.width);
            let seen = find_gap(
                b.points(),
                b.origin(),
                b.noise(),
                side,
                2.0 * radius + 0.5,
                radius + 0.5,
                turn_diameter..2.0 * radius,
            )
            .map(|gap| gap.in_frame(pose));
            // A gap at a place remembered as a dead end is not passed again.
            let dead_end = seen.is_some_and(|s| {
                g.dead_ends
                    .iter()
                    .any(|d| (s.mid - *d).length() <= DEAD_END_RADIUS)
            });
            match (&mut g.passage, seen) {
                (Some(passage), Some(seen)) => {
                    if !dead_end {
                        passage.note_aside(&seen, pose);
                    }
                    passage.refine(&seen);
                }
                (None, Some(seen)) => {
                    // Not the gap just passed or given up, until a small loop later.
                    let fresh = g.done.is_none_or(|(mid, at)| {
                        (seen.mid - mid).length() > 1.0 || g.travelled - at > TAU * radius + 2.0
                    });
                    if fresh && !dead_end {
                        g.passage = Some(
                            Passage::new(seen, 2.0 * radius, self.speed)
                                .with_noise(b.steady_sigma(radius)),
                        );
                    }
                }
                _ => {}
            }
        }
        let passage = g.passage.as_mut()?;
        let (raw, steady) = (b.clearance(), b.steady_clearance());
        let mut step = passage.step(pose, raw, steady, g.length, g.width, dt);
        if let PassStep::Aside(aside) = step {
            g.done = Some((passage.gap().mid, g.travelled));
            *passage =
                Passage::new(aside, 2.0 * radius, self.speed).with_noise(b.steady_sigma(radius));
            step = passage.step(pose, raw, steady, g.length, g.width, dt);
        }
        match step {
            PassStep::Drive(v, omega) => Some(DriveCommand::twist(v, omega)),
            PassStep::Done | PassStep::Blocked | PassStep::Aside(_) => {
                g.done = Some((passage.gap().mid, g.travelled));
                g.passage = None;
                None
            }
        }
    }

    /// The command for the coming `dt` seconds at the believed `pose`; convex corners are
    /// rounded on circles of `radius` metres (the wanted wall distance,
    /// [`super::BumperSensor::follow_radius`]).
    pub fn command(&mut self, b: &Bumpers, pose: &Pose, dt: f64, radius: f64) -> DriveCommand {
        if let Some(c) = self.pass_gap(b, pose, dt, radius) {
            self.rule = FollowRule::Gap;
            self.lost_turn = 0.0;
            return c;
        }
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
        let (rule, v, omega) = if self.bump_turn > 0.0 {
            self.bump_turn -= self.turn_rate * dt;
            (FollowRule::TurnAway, 0.0, -s * self.turn_rate)
        } else if blocked(front) || diag == Some(BumperState::TooClose) {
            (FollowRule::TurnAway, 0.0, -s * self.turn_rate)
        } else if !self.found {
            (FollowRule::Search, self.speed, 0.0)
        } else if wall == BumperState::TooClose || diag == Some(BumperState::Pressed) {
            (
                FollowRule::VeerAway,
                0.5 * self.speed,
                -0.5 * s * self.turn_rate,
            )
        } else if wall == BumperState::Pressed {
            (FollowRule::Along, self.speed, 0.0)
        } else {
            let v = 0.6 * self.speed;
            (
                FollowRule::TowardWall,
                v,
                s * (v / radius).min(self.turn_rate),
            )
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav::bumper::BumperRule;
    use crate::nav::bumper::tests::ring_scan;
    use crate::pose::Pose;
    use crate::vehicle::Twist;

    /// Bumpers of a full-circle scan of a straight wall at distance `d` in direction `dir`
    /// (rad from the front), or of nothing.
    fn wall(d: Option<f64>, dir: f64) -> Bumpers {
        let scan = ring_scan(360, |a: f64| match d {
            Some(d) if (a - dir).cos() > 1e-9 => (d / (a - dir).cos()) as f32,
            _ => f32::INFINITY,
        });
        Bumpers::sense(&scan, &Pose::default(), 8, 1.27, 0.5, BumperRule::All)
    }

    fn twist(c: DriveCommand) -> Twist {
        match c {
            DriveCommand::Twist(t) => t,
            DriveCommand::Tracks { .. } => panic!("twist expected"),
        }
    }

    #[test]
    fn each_rule_on_its_bumper_states() {
        use std::f64::consts::FRAC_PI_2;
        let mut f = WallFollower::new(Side::Right, 0.4, 0.8);
        let step = |f: &mut WallFollower, b: &Bumpers| {
            let t = twist(f.command(b, &Pose::default(), 0.1, 1.5));
            (f.rule(), t.v, t.omega)
        };
        // Nothing anywhere: search straight ahead.
        assert_eq!(
            step(&mut f, &wall(None, 0.0)),
            (FollowRule::Search, 0.4, 0.0)
        );
        // The wall on the right, in the band: along it.
        assert_eq!(
            step(&mut f, &wall(Some(1.4), -FRAC_PI_2)),
            (FollowRule::Along, 0.4, 0.0)
        );
        // Too close on the right (1.2 m; the diagonal, 1.2 / cos 22.5° = 1.3 m, is not):
        // veer left while creeping.
        let (r, v, w) = step(&mut f, &wall(Some(1.2), -FRAC_PI_2));
        assert_eq!(r, FollowRule::VeerAway);
        assert!(v > 0.0 && w > 0.0);
        // A wall ahead (concave corner): turn left on the spot.
        let (r, v, w) = step(&mut f, &wall(Some(1.4), 0.0));
        assert_eq!((r, v), (FollowRule::TurnAway, 0.0));
        assert!(w > 0.0);
        // The wall lost after it was found: arc right on a 1.5 m circle.
        let (r, v, w) = step(&mut f, &wall(None, 0.0));
        assert_eq!(r, FollowRule::TowardWall);
        assert!((w + v / 1.5).abs() < 1e-12, "{v} {w}");
        // A full circle of that without a wall: back to searching.
        for _ in 0..400 {
            f.command(&wall(None, 0.0), &Pose::default(), 0.1, 1.5);
        }
        assert_eq!(f.rule(), FollowRule::Search);
        // After a bump: turn away by 45° before anything else.
        f.bumped();
        let (r, v, w) = step(&mut f, &wall(Some(1.4), -FRAC_PI_2));
        assert_eq!((r, v), (FollowRule::TurnAway, 0.0));
        assert!(w > 0.0);
        let mut turns = 1;
        while step(&mut f, &wall(Some(1.4), -FRAC_PI_2)).0 == FollowRule::TurnAway {
            turns += 1;
        }
        assert_eq!(turns, (BUMP_TURN / 0.08).ceil() as usize);
        // The mirror image for a wall on the left.
        let mut l = WallFollower::new(Side::Left, 0.4, 0.8);
        l.engage();
        let (r, _, w) = step(&mut l, &wall(Some(1.2), FRAC_PI_2));
        assert_eq!(r, FollowRule::VeerAway);
        assert!(w < 0.0);
    }
}
