//! Bug1 and Bug2 (Choset et al. 2005, ch. 2) on virtual bumpers (DESIGN §6).
//!
//! Both drive straight at the goal until the bumper toward it trips (a *hit point*), then
//! follow the obstacle's boundary with a [`WallFollower`] until they may *leave* it:
//! * **Bug1** goes once round the whole obstacle, remembering the boundary point closest to
//!   the goal and how far along the boundary it lay; back at the hit point it goes to that
//!   point the shorter way round (turning about and following with the obstacle on the other
//!   side when going back is shorter, so it covers at most 1.5 perimeters) and leaves there.
//!   On a pose that does not drift (the true pose, SLAM) it goes there by **replaying the
//!   path it followed** ([`Retrace::replay`]): following the boundary again may pass a gap
//!   of a cluster the loop did not take, or the other way round, and never meet the point;
//!   the replay has no stand-in for the point (nor leaves for a neighbour) before it ends
//!   there. On odometry the path of a loop ago is off by the drift since, and where a replay
//!   is blocked the follower goes on as below. Following, it leaves there
//!   (or wherever it is within half the loop tolerance as close to the goal, or once it has
//!   followed the boundary as far as that point lay, within twice the loop tolerance of it).
//!   If the way toward the goal is blocked all along the loop tolerance round that point,
//!   or the robot hits an obstacle again before getting a follow radius nearer the goal, the
//!   line from the leave point re-enters the same obstacle (`no_path`) when the goal lies
//!   *beyond the loop's boundary*: inside the loop when it went round an obstacle, outside it
//!   when it went round the inside of a room (told by the loop's turning sense and the side
//!   the boundary was kept on). Otherwise what is in the way is a neighbour the follower
//!   left out of the loop (a cluster's gaps narrower than twice the standoff): the robot
//!   leaves and takes it up, and that loop must come nearer the goal than the leave point.
//!   Half a loop past the point without meeting it, the boundary followed has changed:
//!   `no_path`, and a standoff retry.
//! * **Bug2** leaves where it crosses the *m-line* (start to goal) closer to the goal than
//!   its hit point and the way toward the goal is open. A crossing is a change of side of the
//!   line between two calls, or a position within `mline_tolerance` of it, between start and
//!   goal. Where the body's corridor toward the goal is blocked at the crossing itself (the
//!   corner of a neighbouring obstacle), the leave waits for the loop tolerance along the
//!   boundary, and a crossing inside a gap being passed counts until the robot is through
//!   (leaving there only nearer the goal than the hit point, so each next hit point is
//!   nearer). Back at the hit point without such a crossing: `no_path` when the goal lies
//!   beyond the loop's boundary (as for Bug1). Otherwise the m-line leaves the loop nearer
//!   the goal, so a crossing was met there with the way blocked by a neighbour outside the
//!   loop: the robot goes on round to the blocked crossing nearest the goal and leaves
//!   there to take the neighbour up (`no_path` if it does not meet it within half a loop).
//!
//! The goal is reached within `tolerance` of it. The pose used is the odometry, or the true
//! pose when the mission asks for it; "back at the hit point" means within
//! `loop_tolerance` after having been at least twice that far away from it, going the way
//! the boundary was followed there at first, or within
//! `loop_tolerance` of any point of the path followed at least one small loop ago, going the
//! same way (see `Boundary::closes_loop`).
//!
//! Made to hold on maps nobody tuned it to (DESIGN §6):
//! * a hit takes up the obstacle in the goal's way: turning toward the goal on the spot, the
//!   bumper toward it may trip before the robot faces it; with the goal's sector past the
//!   front on the side away from the wall, the robot first turns on until the goal lies in
//!   the front sector (rule 1 then turns that obstacle onto the wall side; the follower's arc
//!   toward the wall side would take up whatever lies there);
//! * leaving needs the body's corridor toward the goal free, not only the goal's sector;
//! * a way ahead narrower than the body's turning circle is a hit on the way to the goal
//!   (its sides lie beside the body, outside the bumper toward the goal), and a move to
//!   where a refused turn on the spot is clear goes on through such a way only when backing
//!   cannot clear the turn: the body would squeeze through where its disc cannot (the
//!   trials' geometry calls it closed);
//! * Bug1: a hit before getting a follow radius nearer the goal than the leave point is the
//!   same obstacle (a notch or a concave side), a `no_path` condition;
//! * Bug1: a loop that closes on its own path rather than at the hit point (round a
//!   neighbour the follower took up on the way) need not pass the way that led onto it
//!   again: a closest point met on that way, which the loop does not come within the loop
//!   tolerance of, is taken on the loop instead. Where no point of that loop is nearer the
//!   goal than the hit point (by half the loop tolerance), the neighbour lies back from the
//!   goal and leaving from it would go back the way Bug1 came (the hits need not get
//!   nearer): a closest point met on the way onto the loop, nearer by as much, is driven
//!   back to along the path followed and left from; with none, a `no_path` condition;
//! * Bug2: a loop closed on its own path round a neighbour with no nearer crossing and no
//!   open point nearer the goal than the hit point (the goal not beyond it) says the
//!   follower left the hit obstacle's boundary on the way (at a dead end, across a gap),
//!   not that the goal is cut off. The first time at each standoff, Bug2 is **retried from
//!   the hit point the other way round**: the robot drives the way onto the loop back to the
//!   hit point ([`Retrace::replay`]) and starts again where that ends (its m-line from there,
//!   on the old one), with the boundary kept on the other side, so it meets the hit
//!   obstacle's other side first. The next time it is a `no_path` condition. (Bug1 keeps
//!   its `no_path` condition above: tried there too, on five sets it won two runs and lost
//!   three, two of them one map where the replay could not turn in a slot and a blind
//!   back-off bumped);
//! * a goal inside the standoff of an obstacle beyond it is approached slowly once the body's
//!   corridor to it is free (the bumpers would trip first);
//! * every `no_path` condition is first met with a **standoff retry**: the bumpers' safety
//!   distance shrinks to 0.6 of itself, down to the robot's half-diagonal plus
//!   [`MIN_CLEARANCE`], and the Bug starts again where the robot is (a new m-line for Bug2).
//!   At the floor it starts once more with the boundary kept on the **other side**: a real
//!   follower passes gaps and closes loops differently going the other way round, while a
//!   goal that cannot be reached is found so both ways. Only then is `no_path` reported.
//!   The retries (these and the ones from a hit point above) are in the report; the bumpers
//!   keep what they remember across them;
//! * a robot that has not got `STILL_RADIUS` from one place in `STILL_TIME` (turning on
//!   the spot between sides nearer together than twice its standoff, or bumping to and fro in
//!   a corner) first **retraces** the way it came until `RETRACE` metres from there and
//!   free to turn on the spot ([`super::retrace`]; the way it came has its loops and
//!   there-and-back detours taken out), remembers the place as a dead end whose gaps the
//!   follower does not pass again, and goes on (following the boundary from the point it
//!   retraced to, as far followed as it was there). Stuck again within
//!   [`DEAD_END_RADIUS`] of a dead end, it has met a `no_path` condition, and retries with a
//!   smaller standoff (dead ends are forgotten: at a smaller standoff the way may be open);
//! * coming back past the hit point the other way (out of a dead end) closes no loop;
//! * Bug2 leaves the boundary for a **goal in sight** (`GOAL_SIGHT`): nearer than its hit
//!   point, ahead of the body's side, the body's corridor to it free. Driving straight there
//!   meets nothing, so its progress holds off the m-line too (as in VisBug); a follower that
//!   took up a room wall passes goals beyond the m-line's end and never crosses it nearer.
//!   Bug1 leaves for it likewise: its loop would go on round past it and come back (72 m
//!   against 27 m on `nav/c-goal`), and a loop long enough to drift on odometry may then
//!   lose its way back to the loop's closest point;
//! * a turn on the spot with a return inside the body's circumscribed circle first drives
//!   on to where the turn is clear, if the sensor sees that within 0.5 m (a corner beside
//!   the body; a 270° laser is blind behind), else backs to where it is clear within 0.3 m,
//!   else backs off a little where the way behind is seen free and backing takes the body
//!   away from what it would sweep, else (a way narrower than the turning circle) drives on
//!   along it up to 3 m to where it is clear, or back as far, but no farther than it had
//!   just come forward along that line ([`Trail::straight_behind`], counted afresh each step,
//!   so backing along the way in keeps its room: behind, a 270° laser is blind); a sensor
//!   that sees all round (the radar) backs the whole 3 m where it sees the way free. A turn
//!   that bumped, or that the guard stopped, is taken for one whose circle holds a return,
//!   whatever the returns in the circle say: the same moves, not a fixed 0.15 m back-off
//!   (backing off so with the body turned part of the way off a narrow way's line, again
//!   after each stopped turn, took a rear corner onto the way's side);
//! * turning about or leaving waits while the follower is committed to a gap
//!   ([`super::passage::Passage::committed`]: in it, not on the way to it);
//! * every command then passes the [`super::guard`]: swept along its arc, it must not bring
//!   the body to touch a return.

use glam::DVec2;
use serde::Serialize;

use super::bumper::{BumperConfig, BumperSensor, BumperState};
use super::passage::{BACK_SPEED, backing_eases_turn, narrows_ahead, room_to_turn, turn_clear};
use super::retrace::{Retrace, RetraceStep, Trail};
use super::wall_follow::{DEAD_END_RADIUS, Side, WallFollower};
use super::{Behaviour, nav_pose};
use crate::map::PoseSource;
use crate::pose::wrap_angle;
use crate::sim::{ControlInput, Decision, Ending};
use crate::vehicle::DriveCommand;
use crate::vehicle::VehicleSpec;

/// Heading error beyond which the robot turns on the spot, rad (30°).
const TURN_IN_PLACE: f64 = 0.52;
/// Turn-rate gain toward the goal, (rad/s) per rad.
const K_HEADING: f64 = 1.5;
/// Turn rate on the spot, rad/s.
const TURN_RATE: f64 = 0.8;
/// How much closer than the hit point a Bug2 leave point must be, m: crossings at the hit
/// point itself do not count.
const CLOSER_BY: f64 = 0.2;
/// Smallest gap kept between the robot's body (its half-diagonal) and the bumpers' safety
/// distance when a standoff retry shrinks it, m.
pub const MIN_CLEARANCE: f64 = 0.15;
/// Each standoff retry keeps this share of the previous safety distance (the module docs say
/// 0.6).
const RETRY_FACTOR: f64 = 0.6;
/// Spacing of the followed path's remembered samples, m.
const TRAIL_STEP: f64 = 0.2;
/// Two passes whose headings differ by less than this go the same way round, rad (60°).
const SAME_WAY: f64 = 1.05;
/// A turn on the spot with a return inside the circle the body sweeps (or one that bumped)
/// backs the robot off this far where no short move clears it, m (a box-shaped body turning
/// near a corner sweeps past its sides); twice this at most before turning anyway.
const BACK_OFF: f64 = 0.15;
/// A turn on the spot with a return inside the circle the body sweeps drives on first to
/// where it is clear, if that is seen free within this distance, m (half a body length
/// past a corner beside it).
const SHIFT_MAX: f64 = 0.5;
/// With no short move clearing a turn on the spot (a way between two sides nearer together
/// than the body's turning circle), the robot drives on along the way (past a pair of sides
/// nearer together than that circle only when backing cannot clear it), or back, up to this
/// far to where the turn is clear, m: standing still there is stuck for good.
const ESCAPE_MAX: f64 = 3.0;
/// Speed of the final approach to a goal inside the standoff distance, m/s.
const APPROACH_SPEED: f64 = 0.2;
/// A robot that stays within this distance of one place ...
const STILL_RADIUS: f64 = 0.3;
/// ... for this long is stuck (turning on the spot between sides nearer than its standoff,
/// or bumping to and fro in a corner), s: a `no_path` condition.
const STILL_TIME: f64 = 30.0;
/// Bug2 leaves the boundary for a goal in sight this near (nearer than its hit point, with
/// the body's corridor to it free), m: a few times the bumpers' reach, well inside either
/// sensor's range and resolution.
const GOAL_SIGHT: f64 = 3.0;
/// A stuck robot drives the way it came back until it is this far from where it got stuck
/// (and on until it can turn on the spot), m: out of a pocket entered through a gap, with
/// room to turn and follow on.
const RETRACE: f64 = 2.0;

/// The smallest safety distance a standoff retry goes down to: the robot's half-diagonal
/// plus [`MIN_CLEARANCE`], m.
pub fn safety_floor(vehicle: &VehicleSpec) -> f64 {
    0.5 * vehicle.length.hypot(vehicle.width) + MIN_CLEARANCE
}

/// The safety distance a standoff retry tries after `safety`, or `None` at the floor
/// ([`safety_floor`]).
pub fn retry_safety(safety: f64, vehicle: &VehicleSpec) -> Option<f64> {
    let floor = safety_floor(vehicle);
    (safety > floor + 1e-9).then(|| (safety * RETRY_FACTOR).max(floor))
}

/// Which Bug.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BugAlgorithm {
    /// Circumnavigate, then leave at the closest point.
    Bug1,
    /// Leave at a closer m-line crossing.
    Bug2,
}

impl BugAlgorithm {
    /// `bug1` or `bug2`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Bug1 => "bug1",
            Self::Bug2 => "bug2",
        }
    }
}

/// The parameters of a Bug mission (`[mission] type = "bug1"` or `"bug2"`).
#[derive(Clone, Debug, PartialEq)]
pub struct BugMission {
    /// Which algorithm.
    pub algorithm: BugAlgorithm,
    /// Goal, m.
    pub goal: DVec2,
    /// The goal counts as reached within this distance, m.
    pub tolerance: f64,
    /// Distance to the m-line that counts as on it, m (Bug2).
    pub mline_tolerance: f64,
    /// Distance to the hit (or leave) point that counts as back at it, m.
    pub loop_tolerance: f64,
    /// The side the obstacle is kept on while following it.
    pub follow: Side,
    /// Cruise speed, m/s.
    pub speed: f64,
    /// The pose the algorithm believes in.
    pub pose: PoseSource,
    /// Bumpers.
    pub bumpers: BumperConfig,
}

impl BugMission {
    /// A mission to `goal` with the defaults of a scenario file's `[mission]`: reached within
    /// 0.3 m, on the m-line within 0.1 m, back at a point within 0.75 m, obstacles kept on
    /// the left, 0.4 m/s, steering on the odometry (as a real robot), the default bumpers on
    /// the robot's first sensor.
    pub fn new(algorithm: BugAlgorithm, goal: DVec2) -> Self {
        Self {
            algorithm,
            goal,
            tolerance: 0.3,
            mline_tolerance: 0.1,
            loop_tolerance: 0.75,
            follow: Side::Left,
            speed: 0.4,
            pose: PoseSource::Odometry,
            bumpers: BumperConfig::default(),
        }
    }
}

/// What a Bug run did, for `summary.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BugReport {
    /// `bug1` or `bug2`.
    pub algorithm: Option<BugAlgorithm>,
    /// Goal, m.
    pub goal: [f64; 2],
    /// `truth` or `odometry`.
    pub pose: &'static str,
    /// Where the robot met obstacles, in its believed frame.
    pub hit_points: Vec<[f64; 2]>,
    /// Where it left them.
    pub leave_points: Vec<[f64; 2]>,
    /// Bug2: m-line crossings seen while following boundaries.
    pub mline_crossings: usize,
    /// Distance driven while following boundaries (believed), m.
    pub boundary_distance: f64,
    /// Believed distance to the goal at the end, m.
    pub goal_distance: f64,
    /// Why the run ended, in words.
    pub reason: String,
    /// Standoff retries: each time a `no_path` condition was met with a safety distance above
    /// the floor, the safety distance tried next, where and why.
    pub retries: Vec<RetryReport>,
    /// Safety distance of the bumpers at the end, m.
    pub safety: f64,
    /// Loops closed while following (back at the hit point, or on the path already followed).
    pub loops: usize,
    /// Where the robot got stuck and retraced the way it came (believed), m.
    pub dead_ends: Vec<[f64; 2]>,
}

/// One standoff retry.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RetryReport {
    /// Where the robot was (believed), m.
    pub at: [f64; 2],
    /// The `no_path` condition that was met.
    pub after: String,
    /// The new safety distance, m.
    pub safety: f64,
    /// The side the boundary is kept on from here: `left` or `right` (the other side than
    /// before once the standoff is at its floor).
    pub follow: &'static str,
}

#[derive(Clone, Debug)]
enum Mode {
    ToGoal,
    /// Boxed: the boundary's record is large beside `ToGoal`.
    Follow(Box<Boundary>),
}

/// Bug1's last leave from a loop, as far as the next hit needs it.
#[derive(Clone, Copy, Debug)]
struct Leave {
    /// The leave point's distance to the goal, m.
    goal_dist: f64,
    /// The distance to the goal of the loop's closest point, which the leave may stand in for
    /// as much as half the loop tolerance farther, m.
    closest: f64,
    /// The goal lay beyond the boundary of the loop left.
    goal_beyond: bool,
}

#[derive(Clone, Debug)]
struct Boundary {
    hit: DVec2,
    hit_goal_dist: f64,
    /// Distance followed when the robot first got twice the loop tolerance from the hit
    /// point (`None` before).
    away: Option<f64>,
    /// Bug1: closest point to the goal so far, its distance and the boundary distance
    /// from the hit point at which it was met. Bug2, once circled: the blocked crossing it
    /// goes back to.
    closest: (DVec2, f64, f64),
    /// Distance followed along this boundary, m.
    travelled: f64,
    /// Bug1: turn still to make on the spot to go back the other way, rad.
    about_turn: f64,
    /// The boundary distance at which the robot is back at `closest`, once the loop is
    /// closed.
    leave_at: f64,
    /// The loop is closed; heading for `closest`.
    circled: bool,
    /// Bug1: been away from `closest` since circling (it may be the hit point itself).
    away_from_closest: bool,
    /// Bug1: been within the loop tolerance of `closest` since circling.
    near_closest: bool,
    /// Length of the closed loop, m.
    loop_len: f64,
    /// Bug1: the goal lies beyond the closed loop's boundary (inside the obstacle it went
    /// round, or outside the room it went round the inside of).
    goal_beyond: bool,
    /// Bug1: this boundary was taken up where the way from the last leave point met another
    /// obstacle at once; its closest point must come nearer the goal than this, m.
    nearer_than: Option<f64>,
    /// Bug2: within the m-line tolerance at the last call.
    on_mline: bool,
    /// Bug2: a closer crossing was met, at this distance followed; leave there (once out of
    /// a gap being passed), or within the loop tolerance on where the way toward the goal
    /// was blocked at the crossing itself.
    leave: Option<f64>,
    /// The followed path: (position, heading, distance followed), every [`TRAIL_STEP`].
    trail: Vec<(DVec2, f64, f64)>,
    /// Distance followed where the closed loop begins: 0 when it closed at the hit point,
    /// else where the path it closed on was followed.
    loop_from: f64,
    /// Bug2: the crossing nearest the goal met so far, closer than the hit point but left
    /// behind because the way toward the goal was blocked there: (position, distance to the
    /// goal, distance followed).
    blocked_crossing: Option<(DVec2, f64, f64)>,
    /// Bug2: the followed points where the way toward the goal was open, every
    /// [`TRAIL_STEP`]: (position, distance to the goal, distance followed).
    open: Vec<(DVec2, f64, f64)>,
    /// Bug1, once circled: the way to the closest point is the loop run backwards (shorter
    /// than going on).
    replay_back: bool,
    /// Bug1, once circled: the way to the closest point is still to be set out on (once no
    /// gap is being passed).
    replay_pending: bool,
    /// Bug1: driving the followed path back to the closest point.
    replay: Option<Retrace>,
    /// Bug1: the loop closed round a neighbour no nearer the goal than the hit point, and
    /// the closest point lies on the way onto it: it is reached going back only.
    back_to_tail: bool,
}

impl Boundary {
    /// Following starts at the hit point `hit`, `goal_dist` from the goal.
    fn at_hit(hit: DVec2, goal_dist: f64) -> Self {
        Self {
            hit,
            hit_goal_dist: goal_dist,
            away: None,
            closest: (hit, goal_dist, 0.0),
            travelled: 0.0,
            about_turn: 0.0,
            leave_at: f64::INFINITY,
            circled: false,
            away_from_closest: false,
            near_closest: false,
            loop_len: 0.0,
            goal_beyond: false,
            nearer_than: None,
            on_mline: true,
            leave: None,
            trail: Vec::new(),
            loop_from: 0.0,
            blocked_crossing: None,
            open: Vec::new(),
            replay_back: false,
            replay_pending: false,
            replay: None,
            back_to_tail: false,
        }
    }

    /// The way onto a loop closed on its own path (round a neighbour), run backwards from
    /// where the loop closed to the hit point; empty for a loop closed at the hit point.
    fn way_back_to_hit(&self) -> Vec<DVec2> {
        if self.loop_from <= 0.0 {
            return Vec::new();
        }
        (self.trail.iter().rev())
            .filter(|s| s.2 <= self.loop_from)
            .map(|s| s.0)
            .chain(std::iter::once(self.hit))
            .collect()
    }

    /// Bug1, once circled: the followed path from where the robot at `p` stands on it to
    /// the closest point, as points to drive in turn: the loop run backwards from here when
    /// `back`, else the loop from its start (from the sample nearest `p` within the stretch
    /// followed since it closed, and `tol` more). Empty when the closest point lies before
    /// the loop's start, unless it is to be reached going back (`back_to_tail`).
    fn way_to_closest(&self, p: DVec2, back: bool, tol: f64) -> Vec<DVec2> {
        let c = self.closest.2;
        if c < self.loop_from && !self.back_to_tail {
            return Vec::new();
        }
        if back {
            return (self.trail.iter().rev())
                .take_while(|s| s.2 >= c)
                .map(|s| s.0)
                .collect();
        }
        let on: Vec<DVec2> = (self.trail.iter())
            .filter(|s| s.2 >= self.loop_from && s.2 <= c)
            .map(|s| s.0)
            .collect();
        let since = self.travelled - self.loop_len + tol;
        let from = (self.trail.iter())
            .filter(|s| s.2 >= self.loop_from && s.2 <= c)
            .take_while(|s| s.2 <= self.loop_from + since)
            .enumerate()
            .min_by(|a, b| (a.1.0 - p).length().total_cmp(&(b.1.0 - p).length()))
            .map_or(0, |(k, _)| k);
        on[from..].to_vec()
    }

    /// Bug1, as the loop closes: `closest` if the loop meets it again (it was followed on the
    /// loop, or the loop passes within `tol` of it), else the loop's followed point nearest
    /// `goal` (the loop closed on its own path, away from where `closest` was met), or `None`
    /// when that point is not nearer the goal than the hit point by half of `tol`: the loop
    /// went round a neighbour lying back from the goal, and leaving from it would go back the
    /// way Bug1 came (each leave point must be nearer the goal than its hit point, or the
    /// hits need not get nearer and the run need not end).
    fn closest_on_loop(
        &self,
        closest: (DVec2, f64, f64),
        goal: DVec2,
        tol: f64,
    ) -> Option<(DVec2, f64, f64)> {
        let on_loop = || (self.trail.iter()).filter(|s| s.2 >= self.loop_from);
        if closest.2 >= self.loop_from || on_loop().any(|s| (s.0 - closest.0).length() <= tol) {
            return Some(closest);
        }
        match (on_loop().map(|s| (s.0, (goal - s.0).length(), s.2)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
        {
            Some(c) => (c.1 <= self.hit_goal_dist - tol / 2.0).then_some(c),
            None => Some(closest),
        }
    }

    /// Bug2, as the loop closes: the loop's followed point nearest the goal where the way
    /// toward the goal was open, if it is nearer than the hit point by `by`.
    fn open_on_loop(&self, by: f64) -> Option<(DVec2, f64, f64)> {
        (self.open.iter())
            .filter(|o| o.2 >= self.loop_from && o.1 < self.hit_goal_dist - by)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .copied()
    }

    /// Takes back the last part of the followed path, which went `length` metres into a dead
    /// end the robot has left again for the followed point nearest `to`: following goes on
    /// from there as far followed as it was then. What was met in the dead end is forgotten
    /// (Bug1's closest point, Bug2's crossings), since it cannot be met again. A closed loop
    /// is left as it is.
    fn rewind_to(&mut self, to: DVec2, length: f64, goal: DVec2) {
        if self.circled {
            return;
        }
        let before = self.travelled - length / 2.0;
        let Some(k) = self
            .trail
            .iter()
            .enumerate()
            .filter(|(_, s)| s.2 <= before && (s.0 - to).length() <= 2.0 * TRAIL_STEP)
            .min_by(|a, b| (a.1.0 - to).length().total_cmp(&(b.1.0 - to).length()))
            .map(|(k, _)| k)
        else {
            return;
        };
        self.trail.truncate(k + 1);
        self.travelled = self.trail[k].2;
        let t = self.travelled;
        self.away = self.away.filter(|a| *a <= t);
        self.leave = self.leave.filter(|l| *l <= t);
        self.blocked_crossing = self.blocked_crossing.filter(|c| c.2 <= t);
        self.open.retain(|o| o.2 <= t);
        if self.closest.2 > t {
            let from = self.away.unwrap_or(f64::INFINITY);
            self.closest = self
                .trail
                .iter()
                .filter(|s| s.2 >= from)
                .map(|s| (s.0, (goal - s.0).length(), s.2))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((self.hit, self.hit_goal_dist, 0.0));
        }
    }

    /// Whether the robot at `p` heading `yaw` has closed a loop: back within `tol` of the hit
    /// point after having been away, going the way it followed there before, or within `tol`
    /// of its own followed path, going the same way, at least `min_cycle` metres of following
    /// ago. The second catches a loop that
    /// passes the hit point wide (the hit point lies where the bumper first tripped, nearer
    /// the obstacle than the settled path; odometry drifts) and a loop on a boundary the
    /// follower took up instead of the one it hit.
    fn closes_loop(&mut self, p: DVec2, yaw: f64, tol: f64, min_cycle: f64) -> bool {
        if self
            .trail
            .last()
            .is_none_or(|l| self.travelled - l.2 >= TRAIL_STEP)
        {
            self.trail.push((p, yaw, self.travelled));
        }
        let old = self.travelled - min_cycle;
        // The sample at the hit point itself holds the heading the robot met the obstacle
        // with, not a way along the boundary.
        let same_way = |s: &&(DVec2, f64, f64)| {
            s.2 > 0.0 && (s.0 - p).length() <= tol && wrap_angle(s.1 - yaw).abs() <= SAME_WAY
        };
        // Back at the hit point going the way the boundary was first followed there: coming
        // back the other way is the return from a dead end (a corridor narrower than twice
        // the tolerance), not a loop.
        let first = self.away.unwrap_or(f64::NEG_INFINITY);
        let back_at_hit = (p - self.hit).length() <= tol
            && self
                .trail
                .iter()
                .take_while(|s| s.2 <= first)
                .any(|s| same_way(&s));
        if back_at_hit {
            self.loop_from = 0.0;
            return true;
        }
        match self
            .trail
            .iter()
            .take_while(|s| s.2 <= old)
            .find(|s| same_way(s))
        {
            Some(s) => {
                self.loop_from = s.2;
                true
            }
            None => false,
        }
    }
}

/// A Bug1 or Bug2 controller.
#[derive(Clone, Debug)]
pub struct BugController {
    mission: BugMission,
    rate_hz: f64,
    bumpers: BumperSensor,
    follower: WallFollower,
    mode: Mode,
    start: Option<DVec2>,
    last: Option<DVec2>,
    /// Bug1: the last leave from a loop.
    last_leave: Option<Leave>,
    /// Where the robot last stood still and since when (s): the no-progress watchdog.
    still: Option<(DVec2, f64)>,
    /// Whether the last command turned on the spot.
    turned: bool,
    /// Distance moved (on or back) before the turn now wanted (believed), m, and where from.
    shifted: (f64, Option<DVec2>),
    /// How far straight back along the body's axis the robot's own trail still runs, m
    /// ([`Trail::straight_behind`]), counted afresh each step.
    behind: f64,
    /// Whether the retry with the boundary on the other side was made.
    side_retried: bool,
    /// Whether the retry from a hit point the other way round was made at this standoff.
    other_way_tried: bool,
    /// Driving back to a hit point for that retry: the Bug starts again (its m-line too)
    /// where the drive ends.
    restart: bool,
    /// The last metres driven (believed), for leaving a dead end.
    trail: Trail,
    /// Driving the trail back out of a dead end.
    retrace: Option<Retrace>,
    /// Dead ends met at this standoff (believed).
    dead_ends: Vec<DVec2>,
    /// The Bug left the boundary for the goal in sight: it is approached while the body's
    /// corridor to it stays free, whatever the bumpers beside the corridor say.
    sighted: bool,
    report: BugReport,
}

impl BugController {
    /// A controller for `mission`, called at `rate_hz`.
    pub fn new(mission: BugMission, rate_hz: f64) -> Self {
        let report = BugReport {
            algorithm: Some(mission.algorithm),
            goal: mission.goal.to_array(),
            pose: mission.pose.as_str(),
            ..Default::default()
        };
        Self {
            bumpers: BumperSensor::new(mission.bumpers.clone())
                .believing(mission.pose)
                .denoising(),
            follower: WallFollower::new(mission.follow, mission.speed, TURN_RATE),
            mission,
            rate_hz,
            mode: Mode::ToGoal,
            start: None,
            last: None,
            last_leave: None,
            still: None,
            turned: false,
            shifted: (0.0, None),
            behind: 0.0,
            side_retried: false,
            other_way_tried: false,
            restart: false,
            trail: Trail::default(),
            retrace: None,
            dead_ends: Vec::new(),
            sighted: false,
            report,
        }
    }

    /// A follower keeping the boundary on `side`, passing gaps but none near a dead end.
    fn new_follower(&self, side: Side, vehicle: &VehicleSpec) -> WallFollower {
        let mut f = WallFollower::new(side, self.mission.speed, TURN_RATE)
            .passing_gaps(vehicle.length, vehicle.width);
        for d in &self.dead_ends {
            f.avoid(*d);
        }
        f.engage();
        f
    }

    /// Stuck at `p` at `time`: drive back the way the robot came, unless it was stuck near
    /// here before (the retrace did not help) or no way in is known. Whether it does.
    fn start_retrace(&mut self, p: DVec2, time: f64) -> bool {
        if self
            .dead_ends
            .iter()
            .any(|d| (*d - p).length() <= DEAD_END_RADIUS)
        {
            return false;
        }
        let Some(retrace) = Retrace::along(&self.trail, RETRACE, time) else {
            return false;
        };
        self.dead_ends.push(p);
        self.report.dead_ends.push(p.to_array());
        self.follower.avoid(p);
        self.retrace = Some(retrace);
        true
    }

    /// What the run did so far.
    pub fn bug_report(&self) -> &BugReport {
        &self.report
    }

    fn end(&mut self, ending: Ending, reason: &str) -> Decision {
        self.report.reason = reason.to_owned();
        Decision::Finished(ending)
    }

    /// A `no_path` condition was met at `p`. Before believing it, retry from here with the
    /// bumpers' safety distance shrunk step by step down to the body plus [`MIN_CLEARANCE`]:
    /// a way narrower than twice the standoff (a doorway, a gap between a hedge and a wall)
    /// looks closed at the standoff and open nearer in. At the floor, retry once more with
    /// the boundary kept on the other side: a real follower passes gaps and closes loops
    /// differently going the other way round, while a goal that cannot be reached is found
    /// so both ways.
    fn no_path(&mut self, reason: &str, p: DVec2, vehicle: &VehicleSpec) -> Decision {
        let safety = self.bumpers.config().safety_for(vehicle);
        let next = match retry_safety(safety, vehicle) {
            Some(next) => next,
            None if !self.side_retried => {
                self.side_retried = true;
                self.mission.follow = self.mission.follow.other();
                safety
            }
            None => return self.end(Ending::NoPath, reason),
        };
        self.report.safety = next;
        self.bumpers.set_safety(next);
        self.dead_ends.clear();
        self.retrace = None;
        self.other_way_tried = false;
        self.restart = false;
        self.start = Some(p);
        self.retry(p, reason.to_owned(), next)
    }

    /// Starts the Bug again toward the goal (a retry made at `at` after `after`, at the
    /// safety distance `safety` and the side now kept, goes into the report).
    fn retry(&mut self, at: DVec2, after: String, safety: f64) -> Decision {
        self.report.retries.push(RetryReport {
            at: at.to_array(),
            after,
            safety,
            follow: self.mission.follow.as_str(),
        });
        self.sighted = false;
        self.mode = Mode::ToGoal;
        self.last_leave = None;
        Decision::Drive(DriveCommand::STOP)
    }

    /// Bug2: a loop closed round a neighbour at `p` with nothing on it to leave from
    /// (`reason`): the follower left the hit obstacle's boundary on the way (at a dead end,
    /// across a gap), which says nothing of the goal. Once at each standoff the Bug is
    /// retried from the hit point with the boundary kept on the other side: the robot drives
    /// `way` (the way onto the loop, back to the hit point) and starts again where that
    /// ends, meeting the hit obstacle's other side first. Otherwise (or with no way back
    /// known) a `no_path` condition.
    fn other_way_retry(
        &mut self,
        reason: &str,
        p: DVec2,
        way: Vec<DVec2>,
        time: f64,
        vehicle: &VehicleSpec,
    ) -> Decision {
        if self.other_way_tried {
            return self.no_path(reason, p, vehicle);
        }
        let Some(replay) = Retrace::replay(way, self.mission.speed, time) else {
            return self.no_path(reason, p, vehicle);
        };
        self.other_way_tried = true;
        self.mission.follow = self.mission.follow.other();
        self.retrace = Some(replay);
        self.restart = true;
        let safety = self.bumpers.config().safety_for(vehicle);
        let after = format!("{reason}: back to the hit point, the other way round");
        self.retry(p, after, safety)
    }

    /// The signed distance of `p` to the m-line and whether its foot lies between start and
    /// goal.
    fn mline(&self, p: DVec2) -> (f64, bool) {
        let s = self.start.unwrap_or(p);
        let d = self.mission.goal - s;
        let len = d.length().max(1e-9);
        let u = d / len;
        let r = p - s;
        let along = r.dot(u);
        (
            u.perp_dot(r),
            (-self.mission.loop_tolerance..=len).contains(&along),
        )
    }
}

impl Behaviour for BugController {
    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn report(&self) -> Option<serde_json::Value> {
        serde_json::to_value(&self.report).ok()
    }

    fn bumpers(&self) -> Option<&super::Bumpers> {
        self.bumpers.latest()
    }

    fn touched(&mut self, input: &ControlInput<'_>, moving: (f64, f64)) {
        self.bumpers.touched(input, moving);
    }

    fn decide(&mut self, input: &ControlInput<'_>, bumped: bool) -> Decision {
        // The last command turned on the spot and bumped (or the guard stopped it).
        let refused = bumped && self.turned;
        let mut d = self.next_decision(input, bumped);
        self.turned = matches!(d, Decision::Drive(c) if c.is_turn_on_the_spot());
        let p = nav_pose(self.mission.pose, input).xy();
        if !self.turned {
            self.shifted = (0.0, None);
        }
        // A turn on the spot sweeps the body's circumscribed circle: with a corner inside it,
        // move to where it is clear first, then turn: ahead, where the sensor sees, or else
        // back a little. (A retrace turns only where its sweep is free.)
        let replaying = matches!(&self.mode, Mode::Follow(bd) if bd.replay.is_some());
        let radius = self.bumpers.follow_radius(input.vehicle);
        if self.turned
            && self.retrace.is_none()
            && !replaying
            && let Some(b) = self.bumpers.update(input)
        {
            let v = input.vehicle;
            // Backing far is blind for a 270° laser (it sees nothing behind, remembered
            // returns drift): only as far as the robot had just come forward that way.
            self.behind = self
                .trail
                .straight_behind(&nav_pose(self.mission.pose, input));
            let behind = self.behind;
            let (moved, from) = &mut self.shifted;
            *moved += from.map_or(0.0, |f| (p - f).length());
            *from = Some(p);
            if refused || !turn_clear(b.clearance(), v.length, v.width) {
                // On between two sides nearer together than the turning circle only when
                // backing cannot clear the turn either: what lies past them need be no part of
                // the way the robot came by (its body squeezes through where its disc does
                // not). A robot that has no way back (it stands in a dead end that narrow)
                // drives on out all the same.
                let sigma = b.steady_sigma(radius);
                let room = |max: f64, sign: f64, squeeze: bool| {
                    room_to_turn(b.clearance(), v.length, v.width, max - *moved, sign)
                        .filter(|&s| {
                            sign < 0.0
                                || squeeze
                                || !narrows_ahead(b.steady_clearance(), v.length, v.width, sigma, s)
                        })
                        .map(|_| sign * BACK_SPEED)
                };
                // No short move clears the turn: back off a little all the same where the way
                // behind is seen free and backing takes the body away from what it would
                // sweep, then turn.
                let back_off = *moved < 2.0 * BACK_OFF
                    && behind_free(b, v, BACK_OFF)
                    && backing_eases_turn(b.clearance(), v.length, v.width);
                let speed = room(SHIFT_MAX, 1.0, false)
                    .or_else(|| room(2.0 * BACK_OFF, -1.0, false))
                    .or(back_off.then_some(-BACK_SPEED))
                    .or_else(|| room(ESCAPE_MAX, 1.0, false))
                    .or_else(|| {
                        // A sensor that sees all round sees the way behind as well as ahead.
                        let back = if b.sees_all_round() {
                            ESCAPE_MAX
                        } else {
                            ESCAPE_MAX.min(behind + *moved)
                        };
                        room(back, -1.0, false)
                    })
                    .or_else(|| room(ESCAPE_MAX, 1.0, true));
                if let Some(speed) = speed {
                    d = Decision::Drive(DriveCommand::twist(speed, 0.0));
                    self.turned = false;
                }
            }
        }
        d
    }
}

/// The winding number of the closed path through `ring` (its last point joined to its
/// first) round `q`: +1 once round anticlockwise, 0 when `q` lies outside.
fn winding(ring: &[DVec2], q: DVec2) -> i32 {
    let d: Vec<DVec2> = ring
        .iter()
        .map(|&p| p - q)
        .filter(|d| d.length() > 1e-9)
        .collect();
    let turned: f64 = d
        .iter()
        .zip(d.iter().cycle().skip(1))
        .map(|(a, b)| a.angle_to(*b))
        .sum();
    (turned / std::f64::consts::TAU).round() as i32
}

/// Whether a followed loop `ring` leaves `q` on the side of the boundary it kept on its
/// `side`: inside the obstacle it went round, or, round the inside of a room (a loop the
/// other way about), outside the room. Bug1's leave point then faces the same obstacle.
fn beyond_boundary(ring: &[DVec2], q: DVec2, side: Side) -> bool {
    // Twice the signed area: positive anticlockwise, the inside on the left.
    let area: f64 = ring
        .iter()
        .zip(ring.iter().cycle().skip(1))
        .map(|(a, b)| a.perp_dot(*b))
        .sum();
    let inside_is_obstacle = (area > 0.0) == (side == Side::Left);
    (winding(ring, q) != 0) == inside_is_obstacle
}

/// Whether the strip `distance` metres long behind the body's rear face, as wide as the
/// body, is free of returns (a corner beside the body does not block backing off).
fn behind_free(b: &super::Bumpers, v: &VehicleSpec, distance: f64) -> bool {
    b.corridor_free_from(
        std::f64::consts::PI,
        v.length / 2.0,
        v.length / 2.0 + distance,
        v.width / 2.0,
    )
}

impl BugController {
    fn next_decision(&mut self, input: &ControlInput<'_>, bumped: bool) -> Decision {
        let pose = nav_pose(self.mission.pose, input);
        let p = pose.xy();
        self.start.get_or_insert(p);
        let step = self.last.map_or(0.0, |l| (p - l).length());
        let prev = self.last.replace(p);
        let goal = self.mission.goal;
        let goal_dist = (goal - p).length();
        self.report.goal_distance = goal_dist;
        let vehicle = input.vehicle;
        if self.report.safety == 0.0 {
            self.report.safety = self.bumpers.config().safety_for(vehicle);
        }
        if goal_dist <= self.mission.tolerance {
            return self.end(Ending::Reached, "goal reached");
        }
        let (anchor, since) = *self.still.get_or_insert((p, input.time));
        if (p - anchor).length() > STILL_RADIUS {
            self.still = Some((p, input.time));
        } else if input.time - since > STILL_TIME {
            self.still = None;
            if self.start_retrace(p, input.time) {
                return Decision::Drive(DriveCommand::STOP);
            }
            let reason = format!("stuck: no progress for {STILL_TIME} s at this standoff");
            return self.no_path(&reason, p, vehicle);
        }
        let dt = 1.0 / self.rate_hz;
        let radius = self.bumpers.follow_radius(vehicle);
        let reach = self.bumpers.reach(vehicle);
        let heading = wrap_angle((goal - p).to_angle() - pose.yaw);
        let Some(b) = self.bumpers.update(input).cloned() else {
            // No scan yet: wait for the bumpers.
            return Decision::Drive(DriveCommand::STOP);
        };
        if let Some(r) = &mut self.retrace {
            let step = r.step(
                &pose,
                input.time,
                b.clearance(),
                vehicle.length,
                vehicle.width,
            );
            self.trail.record(p);
            match step {
                RetraceStep::Drive(c) if !bumped => return Decision::Drive(c),
                _ => {
                    // The boundary goes on from here: the pocket was no part of it.
                    if let Mode::Follow(bd) = &mut self.mode {
                        bd.rewind_to(p, r.driven(), goal);
                    }
                    self.retrace = None;
                    self.still = None;
                    self.follower.engage();
                    if std::mem::take(&mut self.restart) {
                        self.start = Some(p);
                    }
                }
            }
        } else {
            self.trail.record(p);
        }
        let half_width = vehicle.width / 2.0 + MIN_CLEARANCE;
        // A goal inside the standoff of an obstacle beyond it: the bumpers trip before the
        // goal is reached, but the body's corridor to the goal (and a margin past it) is free.
        // So for a goal in sight that Bug2 left the boundary for.
        let way_to_goal_free = || {
            b.corridor_free(
                heading,
                goal_dist + vehicle.length / 2.0 + MIN_CLEARANCE,
                half_width,
            )
        };
        let final_approach = (goal_dist <= reach + vehicle.length || self.sighted)
            && heading.abs() <= TURN_IN_PLACE
            && way_to_goal_free();
        if final_approach && !bumped {
            if let Mode::Follow(_) = self.mode {
                self.report.leave_points.push(p.to_array());
                self.mode = Mode::ToGoal;
            }
            let omega = (K_HEADING * heading).clamp(-TURN_RATE, TURN_RATE);
            let v = goal_dist.min(APPROACH_SPEED) * heading.cos();
            return Decision::Drive(DriveCommand::twist(v, omega));
        }
        // Hit: the bumper toward the goal trips. Leaving needs more: the body's corridor
        // toward the goal free up to the band's far edge (or the goal).
        // A way ahead narrower than the turning circle is closed like a wall: the body would
        // squeeze between its sides (the bumpers' sectors see them beside it, not ahead),
        // to where it could not turn, as the passages' narrowing check says likewise.
        let narrows = heading.abs() <= TURN_IN_PLACE
            && narrows_ahead(
                b.steady_clearance(),
                vehicle.length,
                vehicle.width,
                b.steady_sigma(radius),
                vehicle.length / 2.0 + 0.15,
            );
        let hit = bumped || b.toward(heading) != BumperState::Clear || narrows;
        let goal_blocked = !b.corridor_free(heading, goal_dist.min(reach), half_width)
            || b.toward(heading) == BumperState::TooClose;
        let tol = self.mission.loop_tolerance;
        // The smallest loop round an obstacle: a circle of the follow radius, and some.
        let min_cycle = std::f64::consts::TAU * radius + 2.0 * tol;
        let (side, within) = self.mline(p);
        let prev_side = prev.map_or(side, |q| self.mline(q).0);
        match &mut self.mode {
            Mode::ToGoal => {
                if hit && heading.abs() <= TURN_IN_PLACE {
                    // The boundary followed is the obstacle's in the goal's direction. Turning
                    // toward the goal on the spot trips the bumper toward it up to
                    // `TURN_IN_PLACE` before facing it; with the goal's sector on the side away
                    // from the wall, the follower would turn toward the wall side (away from
                    // that obstacle) and take up whatever lies there. Face the goal's sector
                    // first: rule 1 then turns the obstacle in it onto the wall side.
                    let s = self.mission.follow.sign();
                    if !bumped && s * heading < -std::f64::consts::PI / b.sectors() as f64 {
                        let omega = heading.signum() * TURN_RATE;
                        return Decision::Drive(DriveCommand::twist(0.0, omega));
                    }
                    // Bug1: hitting again before getting a standoff nearer the goal than the
                    // leave point is the same obstacle in the way (a notch, a concave side)
                    // when the loop left went round the goal; else it is a neighbour, whose
                    // own loop must then come nearer the goal.
                    let mut nearer_than = None;
                    if self.mission.algorithm == BugAlgorithm::Bug1
                        && let Some(left) = self.last_leave
                        && goal_dist > left.goal_dist - radius
                    {
                        if left.goal_beyond {
                            return self.no_path(
                                "bug1: the line from the leave point toward the goal re-enters the obstacle",
                                p,
                                vehicle,
                            );
                        }
                        // Nearer than the leave point by half the loop tolerance (a
                        // wobbly path's excursions), and nearer than the closest point it
                        // stood in for: a leave short of the closest point that hits at that
                        // point again would otherwise count the same loop as nearer, and
                        // go round it again, lap after lap.
                        nearer_than = Some((left.goal_dist - tol / 2.0).min(left.closest));
                    }
                    self.report.hit_points.push(p.to_array());
                    self.sighted = false;
                    self.follower = self.new_follower(self.mission.follow, vehicle);
                    self.mode = Mode::Follow(Box::new(Boundary {
                        nearer_than,
                        ..Boundary::at_hit(p, goal_dist)
                    }));
                    return Decision::Drive(self.follower.command(&b, &pose, dt, radius));
                }
                let omega = (K_HEADING * heading).clamp(-TURN_RATE, TURN_RATE);
                let v = if heading.abs() > TURN_IN_PLACE {
                    0.0
                } else {
                    goal_dist.min(self.mission.speed) * heading.cos()
                };
                Decision::Drive(DriveCommand::twist(v, omega))
            }
            Mode::Follow(bd) => {
                if bumped {
                    self.follower.bumped();
                }
                let passing = self.follower.passing();
                self.report.boundary_distance += step;
                bd.travelled += step;
                let from_hit = (p - bd.hit).length();
                if from_hit > 2.0 * tol {
                    bd.away.get_or_insert(bd.travelled);
                }
                let looped = !bd.circled && bd.closes_loop(p, pose.yaw, tol, min_cycle);
                if looped {
                    self.report.loops += 1;
                }
                // The goal in sight (within `GOAL_SIGHT`, where the sensor looks), nearer than
                // the hit point, the body's corridor to it (and a margin past it) free:
                // driving straight there reaches it and meets nothing.
                let in_sight = |hit_goal_dist: f64| {
                    goal_dist <= GOAL_SIGHT
                        && heading.abs() <= std::f64::consts::FRAC_PI_2
                        && goal_dist < hit_goal_dist - CLOSER_BY / 2.0
                        && way_to_goal_free()
                };
                match self.mission.algorithm {
                    BugAlgorithm::Bug1 => {
                        // As Bug2's below: the loop would go on round past the goal and
                        // come back, and on odometry drift may lose the way back.
                        if in_sight(bd.hit_goal_dist) && !passing {
                            self.report.leave_points.push(p.to_array());
                            self.sighted = true;
                            self.mode = Mode::ToGoal;
                            return Decision::Drive(DriveCommand::STOP);
                        }
                        // Points met while turning away at the hit point are not on the
                        // followed path: candidates start once the robot has left it.
                        if !bd.circled && bd.away.is_some() && goal_dist < bd.closest.1 {
                            bd.closest = (p, goal_dist, bd.travelled);
                        }
                        if looped {
                            bd.circled = true;
                            // A loop closed on its own path rather than at the hit point
                            // (the follower took up a neighbour's boundary and went round
                            // it) may not pass the way that led onto it again: a closest
                            // point met there, off the loop, is taken on the loop instead,
                            // which the robot stands at the start of.
                            // When that loop comes no nearer the goal than the hit point
                            // but the way onto it did, the robot drives the path it followed
                            // back to that point and leaves there: leaving nearer the goal
                            // than the hit point is all Bug1's progress needs.
                            let on_loop = match bd.closest_on_loop(bd.closest, goal, tol) {
                                Some(c) => c,
                                None if bd.closest.1 <= bd.hit_goal_dist - tol / 2.0 => {
                                    bd.back_to_tail = true;
                                    bd.closest
                                }
                                None => {
                                    return self.no_path(
                                        "bug1: round a neighbour without getting nearer the goal than the hit point",
                                        p,
                                        vehicle,
                                    );
                                }
                            };
                            let tail = on_loop != bd.closest;
                            bd.closest = on_loop;
                            // Going on reaches the closest point after `closest.2`, going
                            // back after the rest of the loop: turn about when that is
                            // shorter. (A point met on the loop is counted from the hit
                            // point even when the loop closed a little past it, off the
                            // settled path: that overstates the way on by the stretch
                            // before the loop, and the slack it gives the odometer and the
                            // half-loop limit kept runs that counting from the loop's
                            // start lost, measured on the trial and random maps.)
                            let ahead = if bd.back_to_tail {
                                f64::INFINITY
                            } else {
                                bd.closest.2 - if tail { bd.loop_from } else { 0.0 }
                            };
                            let behind = bd.travelled - bd.closest.2;
                            bd.replay_back = behind < ahead;
                            bd.replay_pending = true;
                            bd.leave_at = bd.travelled + ahead.min(behind);
                            bd.loop_len = bd.travelled;
                            let from = if tail || bd.back_to_tail {
                                bd.loop_from
                            } else {
                                0.0
                            };
                            let ring: Vec<DVec2> = (bd.trail.iter())
                                .filter(|s| s.2 >= from)
                                .map(|s| s.0)
                                .collect();
                            bd.goal_beyond = beyond_boundary(&ring, goal, self.follower.side());
                            if bd.nearer_than.is_some_and(|d| bd.closest.1 > d) {
                                return self.no_path(
                                    "bug1: round a neighbour and back without getting nearer the goal",
                                    p,
                                    vehicle,
                                );
                            }
                        }
                        // Back to the closest point along the path followed: following
                        // the boundary again may pass a gap the loop did not take, or the
                        // other way round, and never meet the point. Where the path cannot
                        // be driven (or is not known), the follower goes on (or turns
                        // about to go back) as far as the point lay.
                        if bd.replay_pending && !passing {
                            bd.replay_pending = false;
                            // On dead reckoning the path followed a loop ago is off by
                            // the drift since: the follower finds the boundary again,
                            // unless the point lies on the way onto the loop. Going back,
                            // a follower keeps the neighbour's boundary, from which that
                            // way branched off; the path replayed is off by the drift, and
                            // the bumpers and the guard keep the robot off what is there.
                            if self.mission.pose != PoseSource::Odometry || bd.back_to_tail {
                                let way = bd.way_to_closest(p, bd.replay_back, tol);
                                bd.replay = Retrace::replay(way, self.mission.speed, input.time);
                            }
                            if bd.replay.is_none() && bd.replay_back {
                                bd.about_turn = std::f64::consts::PI;
                            }
                            if (p - bd.closest.0).length() > 2.0 * tol {
                                bd.away_from_closest = true;
                            }
                        }
                        // Turning about or leaving waits until a gap being passed is
                        // behind (its sides are nearer than the body's turning circle).
                        if bd.about_turn > 0.0 && !passing {
                            let s = self.follower.side().sign();
                            bd.about_turn -= TURN_RATE * dt;
                            if bd.about_turn <= 0.0 {
                                let other = self.follower.side().other();
                                self.follower = self.new_follower(other, vehicle);
                            }
                            return Decision::Drive(DriveCommand::twist(0.0, -s * TURN_RATE));
                        }
                        if bd.circled {
                            let from_closest = (p - bd.closest.0).length();
                            if from_closest > 2.0 * tol {
                                bd.away_from_closest = true;
                            }
                            // The closest point may be the hit point itself. It is also the
                            // farthest excursion of a wobbly path toward the goal, which the
                            // next pass may miss: as close to the goal within half the loop
                            // tolerance counts as there, and so does having followed the
                            // boundary as far as the closest point lay (Bug1's odometer) near
                            // it, where the way toward the goal is open.
                            let near = from_closest <= tol
                                && (bd.away_from_closest || bd.closest.0 == bd.hit);
                            // A replay drives the very path to the point: no stand-in
                            // for it counts, nor does leaving for a neighbour before it
                            // ends there.
                            let replaying = bd.replay.is_some();
                            let as_close =
                                near || goal_dist <= bd.closest.1 + tol / 2.0 && !replaying;
                            let odometer = bd.travelled >= bd.leave_at && !replaying;
                            let at_closest = as_close || odometer && from_closest <= 2.0 * tol;
                            // Blocked there: when the loop went round the goal the same
                            // obstacle lies in the way, once the robot has passed the closest
                            // point with the way blocked all along; else a neighbour does,
                            // and the robot leaves to take it up (just past the point when it
                            // was passing a gap there).
                            // Beyond the same boundary, Bug1's odometer says it too.
                            let passed = (bd.near_closest && !near || bd.goal_beyond && odometer)
                                && !replaying;
                            bd.near_closest |= near;
                            let leave = at_closest && !goal_blocked
                                || (as_close || passed) && !bd.goal_beyond && !replaying;
                            if leave && !passing {
                                self.report.leave_points.push(p.to_array());
                                self.last_leave = Some(Leave {
                                    goal_dist,
                                    closest: bd.closest.1,
                                    goal_beyond: bd.goal_beyond,
                                });
                                self.mode = Mode::ToGoal;
                                return Decision::Drive(DriveCommand::STOP);
                            }
                            if passed && !passing {
                                return self.no_path(
                                    "bug1: the way toward the goal from the closest point is blocked by the same obstacle",
                                    p,
                                    vehicle,
                                );
                            }
                            // The odometer alone does not find the point again: the way back
                            // may skip a gap the way out went into (or the other way round).
                            // Half a loop more and it is lost (the boundary followed changed).
                            if bd.travelled >= bd.leave_at + bd.loop_len / 2.0 && !passing {
                                return self.no_path(
                                    "bug1: the closest point was not met again within half a loop",
                                    p,
                                    vehicle,
                                );
                            }
                        }
                        if let Some(r) = &mut bd.replay {
                            let step = r.step(
                                &pose,
                                input.time,
                                b.clearance(),
                                vehicle.length,
                                vehicle.width,
                            );
                            match step {
                                RetraceStep::Drive(c) if !bumped => return Decision::Drive(c),
                                _ => {
                                    bd.replay = None;
                                    if step == RetraceStep::Done {
                                        bd.travelled = bd.travelled.max(bd.leave_at);
                                    }
                                    if bd.replay_back {
                                        let other = self.follower.side().other();
                                        self.follower = self.new_follower(other, vehicle);
                                    } else {
                                        self.follower.engage();
                                    }
                                    return Decision::Drive(DriveCommand::STOP);
                                }
                            }
                        }
                    }
                    BugAlgorithm::Bug2 => {
                        let near = side.abs() <= self.mission.mline_tolerance;
                        // Entering the tolerance band, or jumping across the line between
                        // two calls; leaving the band on the far side is the same crossing.
                        let on = within && (near || side.signum() != prev_side.signum());
                        if on && !bd.on_mline {
                            self.report.mline_crossings += 1;
                        }
                        bd.on_mline = near;
                        // Staying on the line counts as well: a gap that lies on it is
                        // passed along the line, never entering the band from outside.
                        // A crossing inside a gap being passed is left from once through:
                        // the way out of the gap counts as the crossing.
                        let closer = on && goal_dist < bd.hit_goal_dist - CLOSER_BY;
                        if closer || passing && bd.leave.is_some() {
                            bd.leave = Some(bd.travelled);
                        }
                        if !goal_blocked
                            && !bd.circled
                            && (bd.open.last()).is_none_or(|o| bd.travelled - o.2 >= TRAIL_STEP)
                        {
                            bd.open.push((p, goal_dist, bd.travelled));
                        }
                        if closer
                            && goal_blocked
                            && !bd.circled
                            && bd.blocked_crossing.is_none_or(|c| goal_dist < c.1)
                        {
                            bd.blocked_crossing = Some((p, goal_dist, bd.travelled));
                        }
                        // The goal in sight, nearer than the hit point, the body's corridor to
                        // it (and a margin past it) free: driving straight there reaches it and
                        // meets nothing, so Bug2's progress holds off the m-line too (as in
                        // VisBug). Only where the sensor looks (a 270° laser is blind
                        // behind) and within `GOAL_SIGHT`. A follower that took up the room
                        // wall passes such goals and never crosses the m-line nearer.
                        if in_sight(bd.hit_goal_dist) && !passing {
                            self.report.leave_points.push(p.to_array());
                            self.sighted = true;
                            self.mode = Mode::ToGoal;
                            return Decision::Drive(DriveCommand::STOP);
                        }
                        // Where the way toward the goal is blocked at the crossing (a corner
                        // of the next obstacle in the body's corridor), a little farther
                        // along the boundary it may be open: the leave waits for the loop
                        // tolerance.
                        if let Some(at) = bd.leave
                            && !passing
                        {
                            // The way out of a gap may lie farther from the goal than the
                            // crossing; leaving there must still be nearer than the hit
                            // point, or the next hit point need not be nearer and Bug2 can
                            // go round the same loop for ever.
                            if !goal_blocked && goal_dist < bd.hit_goal_dist - CLOSER_BY / 2.0 {
                                bd.leave = None;
                                self.report.leave_points.push(p.to_array());
                                self.mode = Mode::ToGoal;
                                return Decision::Drive(DriveCommand::STOP);
                            }
                            if bd.travelled - at > tol {
                                bd.leave = None;
                            }
                        }
                        // A loop round an obstacle that leaves the goal outside crossed
                        // the m-line nearer the goal, where the line leaves the loop. If the
                        // way was blocked at every such crossing, what blocked it lies
                        // outside the loop: a neighbour the follower left out (a cluster's
                        // gaps narrower than twice the standoff). Bug2 goes on round to the
                        // crossing nearest the goal and leaves there to take the neighbour
                        // up; the hit point that follows is nearer the goal, so this ends.
                        // With no such crossing on the loop, the follower took up a neighbour
                        // the m-line does not cross (beside the hit obstacle, closer to it than
                        // twice the standoff): the loop round it meets the line nowhere nearer.
                        // Bug2 then leaves as Bug1 would, from the loop's point nearest the
                        // goal, but only where the way toward the goal was open (at a dead end
                        // of a corridor round a goal it cannot reach, it is blocked: leaving
                        // there would only hit again), and nearer than the hit point by as
                        // much as a crossing must be, so each hit point is nearer and this
                        // ends too.
                        if looped {
                            let ring: Vec<DVec2> = (bd.trail.iter())
                                .filter(|s| s.2 >= bd.loop_from)
                                .map(|s| s.0)
                                .collect();
                            let beyond = beyond_boundary(&ring, goal, self.follower.side());
                            let leave_from = (bd.blocked_crossing)
                                .filter(|c| c.2 >= bd.loop_from)
                                .or_else(|| bd.open_on_loop(CLOSER_BY));
                            match leave_from {
                                Some(c) if !beyond => {
                                    bd.circled = true;
                                    bd.closest = c;
                                    bd.loop_len = bd.travelled - bd.loop_from;
                                    bd.leave_at = bd.travelled + (c.2 - bd.loop_from);
                                }
                                _ if !beyond => {
                                    let way = bd.way_back_to_hit();
                                    return self.other_way_retry(
                                        "bug2: round a neighbour without a closer m-line crossing",
                                        p,
                                        way,
                                        input.time,
                                        vehicle,
                                    );
                                }
                                _ => {
                                    return self.no_path(
                                        "bug2: back at the hit point without a closer m-line crossing",
                                        p,
                                        vehicle,
                                    );
                                }
                            }
                        }
                        if bd.circled && !passing {
                            let from = (p - bd.closest.0).length();
                            // Leaving nearer the goal than the hit point by as much as the
                            // crossing was is what makes each next hit point nearer.
                            let there = from <= tol && bd.travelled >= bd.leave_at - 2.0 * tol
                                || from <= 2.0 * tol && bd.travelled >= bd.leave_at;
                            if there && goal_dist < bd.hit_goal_dist - CLOSER_BY {
                                self.report.leave_points.push(p.to_array());
                                self.mode = Mode::ToGoal;
                                return Decision::Drive(DriveCommand::STOP);
                            }
                            if bd.travelled >= bd.leave_at + bd.loop_len / 2.0 {
                                return self.no_path(
                                    "bug2: the point to leave from (the nearest blocked crossing or open point) was not met again within half a loop",
                                    p,
                                    vehicle,
                                );
                            }
                        }
                    }
                }
                Decision::Drive(self.follower.command(&b, &pose, dt, radius))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};

    use super::*;

    fn boundary(hit: DVec2) -> Boundary {
        Boundary::at_hit(hit, 10.0)
    }

    /// Follows `path` (points and headings) in steps of 5 cm as the controller does and
    /// returns where a loop closed first.
    fn first_loop(bd: &mut Boundary, path: &[(DVec2, f64)]) -> Option<DVec2> {
        let (tol, min_cycle) = (0.75, 9.5);
        let mut last = path[0].0;
        for w in path.windows(2) {
            let ((a, yaw), (b, _)) = (w[0], w[1]);
            let n = ((b - a).length() / 0.05).ceil().max(1.0) as usize;
            for i in 1..=n {
                let p = a + (b - a) * (i as f64 / n as f64);
                bd.travelled += (p - last).length();
                last = p;
                if (p - bd.hit).length() > 2.0 * tol {
                    bd.away.get_or_insert(bd.travelled);
                }
                if bd.closes_loop(p, yaw, tol, min_cycle) {
                    return Some(p);
                }
            }
        }
        None
    }

    #[test]
    fn the_goal_lies_beyond_a_loop_round_an_obstacle_inside_it_and_round_a_room_outside() {
        // A square followed anticlockwise, 0.2 m samples, with a dead-end spike out of its
        // side.
        let square = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];
        let mut ring = Vec::new();
        for (i, &(x, y)) in square.iter().enumerate() {
            let (nx, ny) = square[(i + 1) % square.len()];
            for k in 0..20 {
                let f = f64::from(k) / 20.0;
                ring.push(DVec2::new(x + (nx - x) * f, y + (ny - y) * f));
                if i == 1 && k == 10 {
                    ring.extend((1..=10).map(|j| DVec2::new(4.0 + 0.2 * f64::from(j), 2.1)));
                    ring.extend(
                        (0..10)
                            .rev()
                            .map(|j| DVec2::new(4.0 + 0.2 * f64::from(j), 2.1)),
                    );
                }
            }
        }
        let (inside, outside, past_spike) = (
            DVec2::new(2.0, 2.0),
            DVec2::new(9.0, 2.0),
            DVec2::new(5.0, 2.0),
        );
        assert_eq!(winding(&ring, inside), 1);
        assert_eq!(winding(&ring, outside), 0);
        assert_eq!(winding(&ring, past_spike), 0);
        let back: Vec<DVec2> = ring.iter().rev().copied().collect();
        assert_eq!(winding(&back, inside), -1);
        // Anticlockwise with the boundary on the left: round an obstacle. The goal is beyond
        // it only inside.
        assert!(beyond_boundary(&ring, inside, Side::Left));
        assert!(!beyond_boundary(&ring, outside, Side::Left));
        // Anticlockwise with the boundary on the right: round the inside of a room. The goal
        // is beyond it only outside.
        assert!(!beyond_boundary(&ring, inside, Side::Right));
        assert!(beyond_boundary(&ring, outside, Side::Right));
        assert!(beyond_boundary(&back, inside, Side::Right));
        assert_eq!(winding(&[], DVec2::ZERO), 0);
    }

    #[test]
    fn coming_back_out_of_a_dead_end_past_the_hit_point_closes_no_loop() {
        // Up a corridor from the hit point, back down past it (0.3 m off) and on.
        let hit = DVec2::new(1.0, 1.0);
        let path = [
            (hit, FRAC_PI_2),
            (DVec2::new(1.0, 12.0), -FRAC_PI_2),
            (DVec2::new(0.8, 1.3), 0.0),
            (DVec2::new(8.0, 0.9), 0.0),
        ];
        assert_eq!(first_loop(&mut boundary(hit), &path), None);
    }

    /// One decision of `c` at `time` and `pose` (true pose = odometry) on a full-circle radar
    /// scan taken then of a wall across the world x axis at `x = 1.2`, from far to the right
    /// up to `y = 0.05`.
    fn decide_before_wall_end(
        c: &mut BugController,
        time: f64,
        pose: &crate::pose::Pose,
    ) -> Decision {
        use crate::nav::bumper::tests::ring_scan;
        use crate::setup::MountedSensor;
        let (yaw, dx) = (pose.yaw, 1.2 - pose.x);
        let mut scan = ring_scan(360, |a: f64| {
            let (s, c) = (a + yaw).sin_cos();
            let r = dx / c;
            if c > 1e-9 && pose.y + r * s <= 0.05 {
                r as f32
            } else {
                f32::INFINITY
            }
        });
        scan.pose = *pose;
        scan.stamp = time;
        let sensors = [MountedSensor {
            name: "radar".into(),
            config: crate::sensor::preset("radar_thesis").expect("preset"),
            mount: crate::pose::Pose::default(),
        }];
        let input = ControlInput {
            time,
            odometry: pose,
            truth: pose,
            bumped: false,
            scans: &[Some(scan)],
            scan_odometry: &[Some(*pose)],
            slam: None,
            scan_slam: &[],
            sensors: &sensors,
            vehicle: crate::vehicle::vehicle("p3at").expect("p3at"),
        };
        c.decide(&input, false)
    }

    /// The twist of a decision to drive.
    fn twist_of(d: Decision) -> crate::vehicle::Twist {
        match d {
            Decision::Drive(DriveCommand::Twist(t)) => t,
            d => panic!("a twist expected: {d:?}"),
        }
    }

    #[test]
    fn a_hit_with_the_goal_past_the_front_on_the_far_side_first_faces_the_goal() {
        use super::super::wall_follow::FollowRule;
        use crate::pose::Pose;
        // The goal straight along +x beyond the end of a wall 1.2 m off. Keeping the boundary
        // on its left, the robot faces 28 degrees left of the goal: the bumper toward the
        // goal (the right diagonal, past the front sector's 22.5 degrees) has tripped, the
        // front and the left are clear. Following from here would arc left, away from the
        // wall in the goal's way.
        let mission = BugMission {
            pose: PoseSource::Truth,
            ..BugMission::new(BugAlgorithm::Bug2, DVec2::new(10.0, 0.0))
        };
        let mut c = BugController::new(mission.clone(), 10.0);
        let turned = Pose::new(0.0, 0.0, 0.0, 28f64.to_radians());
        // Not a hit yet: it turns right on the spot, toward the goal.
        let t = twist_of(decide_before_wall_end(&mut c, 0.0, &turned));
        assert!(t.v == 0.0 && t.omega < 0.0, "{t:?}");
        assert!(c.bug_report().hit_points.is_empty());
        // With the goal in the front sector the wall trips the front: a hit, and rule 1 turns
        // the wall onto the left, the wall side.
        let facing = Pose::new(0.0, 0.0, 0.0, 20f64.to_radians());
        let t = twist_of(decide_before_wall_end(&mut c, 0.1, &facing));
        assert!(t.v == 0.0 && t.omega < 0.0, "{t:?}");
        assert_eq!(c.bug_report().hit_points.len(), 1);
        assert_eq!(c.follower.rule(), FollowRule::TurnAway);
        // Keeping the boundary on the right, the goal lies on the wall side: a hit at once.
        let mut c = BugController::new(
            BugMission {
                follow: Side::Right,
                ..mission
            },
            10.0,
        );
        decide_before_wall_end(&mut c, 0.0, &turned);
        assert_eq!(c.bug_report().hit_points.len(), 1);
    }

    /// From the hit point at the origin round a 6 m square anticlockwise and `on` metres
    /// past it, with the headings followed.
    fn round_a_square(on: f64) -> [(DVec2, f64); 6] {
        [
            (DVec2::ZERO, 0.0),
            (DVec2::new(6.0, 0.0), FRAC_PI_2),
            (DVec2::new(6.0, 6.0), PI),
            (DVec2::new(0.0, 6.0), -FRAC_PI_2),
            (DVec2::ZERO, 0.0),
            (DVec2::new(on, 0.0), 0.0),
        ]
    }

    /// From `hit` (the origin) 4 m east, then north and round a 3 m square clockwise (a
    /// neighbour taken up) and on, with the headings followed.
    fn onto_a_neighbour(hit: DVec2) -> [(DVec2, f64); 8] {
        [
            (hit, 0.0),
            (DVec2::new(4.0, 0.0), FRAC_PI_2),
            (DVec2::new(4.0, 3.0), PI),
            (DVec2::new(1.0, 3.0), FRAC_PI_2),
            (DVec2::new(1.0, 6.0), 0.0),
            (DVec2::new(4.0, 6.0), -FRAC_PI_2),
            (DVec2::new(4.0, 3.0), PI),
            (DVec2::new(2.0, 3.0), PI),
        ]
    }

    #[test]
    fn a_loop_closed_round_a_neighbour_has_its_closest_point_on_that_loop() {
        // From the hit point east toward the goal's side, then north and round a 3 m square
        // clockwise (a neighbour taken up) and on: the loop closes on its own path, not at
        // the hit point, and leaves the way onto it (nearest the goal) behind.
        let (hit, goal) = (DVec2::ZERO, DVec2::new(6.0, -1.0));
        let path = onto_a_neighbour(hit);
        let mut bd = boundary(hit);
        let at = first_loop(&mut bd, &path).expect("loop");
        assert!((at - DVec2::new(4.0, 3.0)).length() < 0.8, "{at}");
        assert!(bd.loop_from > 6.6, "closed at {}", bd.loop_from);
        let tail = DVec2::new(4.0, 0.0);
        let on_tail = (tail, (goal - tail).length(), 4.0);
        let (c, d, along) = bd.closest_on_loop(on_tail, goal, 0.75).expect("nearer");
        assert!(along >= bd.loop_from, "{along} before {}", bd.loop_from);
        assert!((c - DVec2::new(4.0, 3.0)).length() < 0.25, "{c}");
        assert!((d - (goal - c).length()).abs() < 1e-12);
        // A closest point on the loop stays.
        let on_loop = (DVec2::new(1.0, 4.0), 6.4, bd.loop_from + 5.0);
        assert_eq!(bd.closest_on_loop(on_loop, goal, 0.75), Some(on_loop));
        // So does one met on the way in that the loop passes within the tolerance of.
        let beside = DVec2::new(4.0, 2.6);
        let passed = (beside, (goal - beside).length(), 6.6);
        assert_eq!(bd.closest_on_loop(passed, goal, 0.75), Some(passed));
    }

    #[test]
    fn a_loop_closed_round_a_neighbour_back_from_the_goal_leaves_nowhere() {
        // The same way onto a neighbour and loop round it, with the goal west of the hit
        // point: every point of the loop lies farther from the goal than the hit point.
        // Leaving from the loop's nearest point would take Bug1 back the way it came.
        let (hit, goal) = (DVec2::ZERO, DVec2::new(-6.0, -1.0));
        let path = onto_a_neighbour(hit);
        let mut bd = Boundary::at_hit(hit, (goal - hit).length());
        first_loop(&mut bd, &path).expect("loop");
        assert_eq!(bd.closest_on_loop(bd.closest, goal, 0.75), None);
        // A goal the loop's west side comes nearer to than the hit point by half the
        // tolerance: its nearest point there.
        let goal = DVec2::new(1.0, 10.0);
        let mut bd = Boundary::at_hit(hit, (goal - hit).length());
        first_loop(&mut bd, &path).expect("loop");
        let (c, d, _) = bd.closest_on_loop(bd.closest, goal, 0.75).expect("nearer");
        assert!((c - DVec2::new(1.0, 6.0)).length() < 0.1, "{c}");
        assert!(d < 4.1, "{d}");
    }

    #[test]
    fn a_closest_point_on_the_way_onto_a_loop_round_a_neighbour_is_reached_going_back() {
        // The way onto the neighbour passes nearest the goal (4, 0); the loop round the
        // neighbour comes no nearer than the hit point. The way back to that point runs
        // back round the loop and down the way onto it.
        let (hit, goal) = (DVec2::ZERO, DVec2::new(6.0, -4.0));
        let path = onto_a_neighbour(hit);
        let mut bd = Boundary::at_hit(hit, (goal - hit).length());
        let end = first_loop(&mut bd, &path).expect("loop");
        let tail = DVec2::new(4.0, 0.0);
        bd.closest = (tail, (goal - tail).length(), 4.0);
        assert_eq!(bd.closest_on_loop(bd.closest, goal, 0.75), None);
        assert!(bd.closest.1 < bd.hit_goal_dist - 0.75 / 2.0);
        // Only the loop is driven back to a point on it: none off it.
        assert!(bd.way_to_closest(end, true, 0.75).is_empty());
        bd.back_to_tail = true;
        let way = bd.way_to_closest(end, true, 0.75);
        assert!((way[0] - end).length() < 0.25, "{}", way[0]);
        let last = *way.last().expect("a way");
        assert!((last - tail).length() < 0.25, "{last}");
        // It passes the loop's far side on the way.
        assert!(
            way.iter()
                .any(|q| (*q - DVec2::new(1.0, 6.0)).length() < 0.25)
        );
    }

    #[test]
    fn the_way_back_from_a_loop_round_a_neighbour_to_the_hit_point_is_the_way_onto_it() {
        // The way onto the neighbour runs 4 m east and 3 m north of the hit point; the loop
        // round the neighbour closes where that way met it. The way back to the hit point is
        // that way run backwards, not the loop.
        let (hit, goal) = (DVec2::ZERO, DVec2::new(-6.0, -1.0));
        let path = onto_a_neighbour(hit);
        let mut bd = Boundary::at_hit(hit, (goal - hit).length());
        let end = first_loop(&mut bd, &path).expect("loop");
        let way = bd.way_back_to_hit();
        assert!((way[0] - end).length() < 0.8, "{} from {end}", way[0]);
        assert_eq!(way.last(), Some(&hit));
        assert!(
            way.iter()
                .any(|q| (*q - DVec2::new(4.0, 0.0)).length() < 0.25)
        );
        assert!(
            way.iter().all(|q| q.y <= 3.0 + 1e-9),
            "no point off the way on"
        );
        // A loop closed at the hit point went round the hit obstacle itself: no way back.
        let mut square = Boundary::at_hit(hit, 10.0);
        first_loop(&mut square, &round_a_square(2.0)).expect("loop");
        assert_eq!(square.loop_from, 0.0);
        assert!(square.way_back_to_hit().is_empty());
    }

    #[test]
    fn bug2_leaves_a_loop_without_crossings_from_its_nearest_open_point() {
        // `boundary` puts the hit point 10 m from the goal; the loop closed 5 m along.
        let mut bd = boundary(DVec2::ZERO);
        bd.loop_from = 5.0;
        let at = |d: f64, along: f64| (DVec2::new(along, 0.0), d, along);
        // Before the loop (never met again), on it but not nearer by enough, on it.
        bd.open = vec![at(3.0, 2.0), at(9.9, 6.0), at(7.0, 8.0), at(8.0, 9.0)];
        assert_eq!(bd.open_on_loop(CLOSER_BY), Some(at(7.0, 8.0)));
        bd.open = vec![at(3.0, 2.0), at(9.9, 6.0)];
        assert_eq!(bd.open_on_loop(CLOSER_BY), None);
        // A loop closed at the hit point holds all of it.
        bd.loop_from = 0.0;
        assert_eq!(bd.open_on_loop(CLOSER_BY), Some(at(3.0, 2.0)));
    }

    #[test]
    fn a_loop_back_to_the_hit_point_the_same_way_closes() {
        // Round a 6 m square from the hit point, anticlockwise, and on past it.
        let hit = DVec2::ZERO;
        let path = round_a_square(3.0);
        let at = first_loop(&mut boundary(hit), &path).expect("loop");
        assert!(at.length() < 0.8, "{at}");
    }
}
