//! Leaving a dead end the way the robot came in (DESIGN §6).
//!
//! A robot that makes no progress for a while (the Bug controller's no-progress watchdog)
//! stands where its rules give it no way on. An example is a pocket between bushes entered
//! through a gap passage, whose other ways out are narrower than the body. Every heading
//! there is blocked within the safety distance, so the follower turns on the spot for ever,
//! and a retry with a smaller standoff starts in the same pocket.
//!
//! The way in is known to be passable: the robot drove it. [`Trail`] keeps the last metres
//! of the believed path with its loops taken out: where the robot comes back near where it
//! was (it backed out of a narrow way, or went round something), the path since is cut. So
//! the trail is the way in to where the robot stands, not a detour it already came back
//! from. [`Retrace`] drives the trail back until the robot is far enough from the dead end
//! *and* can turn on the spot. The robot goes forward where the next point of the trail lies
//! ahead and backs where it lies behind, so a body that cannot turn in a narrow way reverses
//! out along the path it came in on, all the way out. Held in the believed frame, the trail
//! is as good as the odometry over a few metres. Every command still passes the bumpers'
//! sweep check ([`super::guard::sweep_touches`]).
//!
//! The controller remembers the place as a dead end. Its follower passes no gap near it
//! again (see [`super::wall_follow::WallFollower::avoid`]).
//!
//! A [`Retrace::replay`] drives a given path forward to its end, turning on the spot (sweep
//! checked) to face it where needed: Bug1 goes back to its closest point so, along the loop
//! it followed.
//!
//! Either ends blocked where, facing its way on, the robot gets no farther for a few seconds.
//! On a drifting pose the believed path can run into what the sensor sees (a replay of 50 m
//! drove into a room's corner so): the drive is refused there, and what the sweep check left,
//! a turn on the spot of a milliradian a step, went on for half a minute, standing at the
//! wall (the timeout is 90 s and more).

use std::collections::VecDeque;
use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec2;

use super::guard::sweep_touches;
use super::passage::{BACK_SPEED, turn_clear};
use crate::pose::{Pose, wrap_angle};
use crate::vehicle::{DriveCommand, Twist};

/// Spacing of the trail's samples, m.
const SPACING: f64 = 0.1;
/// Path kept in the trail, m: more than one retrace takes.
const KEEP: f64 = 6.0;
/// Back this near an older sample of the trail, the path since is a loop, m.
const RETURNED: f64 = 1.5 * SPACING;
/// A trail point nearer than this is passed; the next one is steered for, m.
const LOOK: f64 = 0.3;
/// Speed driving forward along the trail, m/s.
const FORWARD_SPEED: f64 = 0.2;
/// Turn rate, rad/s.
const TURN: f64 = 0.5;
/// Heading gain, (rad/s) per rad.
const K_HEADING: f64 = 2.0;
/// Off the trail's direction by more than this, the robot turns on the spot first, rad.
const DRIVE_WITHIN: f64 = 0.5;
/// A retrace taking longer than this has failed, s.
const TIMEOUT: f64 = 90.0;
/// Facing the way on, a retrace that gets no farther than this along it ...
const STALL_DISTANCE: f64 = 0.05;
/// ... in this long is blocked, s.
const STALL: f64 = 4.0;
/// Trail points this near the body's axis lie straight behind it, m.
const ALONG_AXIS: f64 = 0.1;

/// The way the robot came: the last few metres of the believed path with its loops taken
/// out. A robot that backs out of a narrow way, or goes round and comes back to where it
/// was, took a detour that is no way out of where it stands now.
#[derive(Clone, Debug, Default)]
pub struct Trail {
    /// Samples, oldest first, each with the distance driven to it (along the kept path), m.
    points: VecDeque<(DVec2, f64)>,
}

impl Trail {
    /// Adds the robot's believed position `p`, if it is far enough from the last sample.
    /// Back near an older sample, the trail is cut back to it.
    pub fn record(&mut self, p: DVec2) {
        let Some(&(last, driven)) = self.points.back() else {
            self.points.push_back((p, 0.0));
            return;
        };
        if (p - last).length() < SPACING {
            return;
        }
        let driven = driven + (p - last).length();
        // The newest samples lie near `p` on any path: only a return from farther along
        // than a there-and-back across the radius closes a loop.
        if let Some(k) = self
            .points
            .iter()
            .position(|(q, d)| (p - *q).length() < RETURNED && driven - d > 2.0 * RETURNED)
        {
            self.points.truncate(k + 1);
            return;
        }
        self.points.push_back((p, driven));
        while self.length() > KEEP && self.points.len() > 2 {
            self.points.pop_front();
        }
    }

    /// Length of the path the trail keeps, m.
    fn length(&self) -> f64 {
        match (self.points.front(), self.points.back()) {
            (Some(a), Some(b)) => b.1 - a.1,
            _ => 0.0,
        }
    }

    /// How far straight back from the believed `pose` the robot came forward along its own
    /// trail, m: the farthest behind of the trail's newest points that lie within
    /// `ALONG_AXIS` of the body's axis line. Backing that far goes where the body has just
    /// been; a 270° laser sees nothing there. Points ahead on the line count as on it: a robot
    /// backing along the way it came has the stretch it backed over ahead of it.
    pub fn straight_behind(&self, pose: &Pose) -> f64 {
        let to_body = pose.inverse();
        let mut behind: f64 = 0.0;
        for (q, _) in self.points.iter().rev() {
            let r = to_body.compose(&Pose::new(q.x, q.y, 0.0, 0.0)).xy();
            if r.y.abs() > ALONG_AXIS {
                break;
            }
            behind = behind.max(-r.x);
        }
        behind
    }
}

/// What one step of a [`Retrace`] gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RetraceStep {
    /// Drive this.
    Drive(DriveCommand),
    /// Far enough back, with room to turn (or at the trail's oldest point).
    Done,
    /// No free move along it (or out of time).
    Blocked,
}

/// Driving the trail back (module docs).
#[derive(Clone, Debug)]
pub struct Retrace {
    /// The way back, newest first: from where the robot stood to the trail's oldest point.
    path: Vec<DVec2>,
    /// Index of the point steered for.
    next: usize,
    /// Straight-line distance from `path[0]` to go at least, m.
    away: f64,
    /// When the retrace started, s.
    since: f64,
    /// Distance driven (believed), m, and the last position it was counted from.
    driven: (f64, Option<DVec2>),
    /// Whether the robot may back where the next point lies behind (a retrace) or always
    /// faces it first (a replay: the sensor looks where the robot goes).
    backs: bool,
    /// Speed driving forward, m/s.
    speed: f64,
    /// Time the drive may take, s.
    timeout: f64,
    /// When the robot last got [`STALL_DISTANCE`] farther facing the way on (or was turning
    /// to face it), s, and the distance driven then, m.
    progress: (f64, f64),
}

impl Retrace {
    /// A retrace of `trail` that goes back until at least `away` metres (straight line)
    /// from where the robot is and then on until the body can turn on the spot, started at
    /// `time`: `None` when no point of the trail lies half that far (no way in is known).
    /// The trail itself takes the way back as the robot drives it: its loops close.
    pub fn along(trail: &Trail, away: f64, time: f64) -> Option<Self> {
        let newest = trail.points.back()?.0;
        if trail
            .points
            .iter()
            .all(|(q, _)| (*q - newest).length() < away / 2.0)
        {
            return None;
        }
        Some(Self {
            path: trail.points.iter().rev().map(|(q, _)| *q).collect(),
            next: 0,
            away,
            since: time,
            driven: (0.0, None),
            progress: (time, 0.0),
            backs: true,
            speed: FORWARD_SPEED,
            timeout: TIMEOUT,
        })
    }

    /// A replay of `path` (believed points, in the order to drive them) at up to `speed`
    /// m/s, started at `time`: forward only, turning on the spot to face the next point where
    /// it lies off the way ahead; done at its last point. `None` for fewer than two points.
    /// Bug1 goes back to its closest point so: along the path it followed, which it knows
    /// to be passable, where following the boundary again may pass a gap the first loop did
    /// not take (or the other way round).
    pub fn replay(path: Vec<DVec2>, speed: f64, time: f64) -> Option<Self> {
        if path.len() < 2 {
            return None;
        }
        let length: f64 = path.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let speed = speed.clamp(FORWARD_SPEED, 1.5 * FORWARD_SPEED);
        Some(Self {
            path,
            next: 0,
            away: f64::INFINITY,
            since: time,
            driven: (0.0, None),
            progress: (time, 0.0),
            backs: false,
            speed,
            // Twice the time driving takes, turns on the spot on top.
            timeout: TIMEOUT + 2.0 * length / speed,
        })
    }

    /// How far the robot has driven back so far (believed), m.
    pub fn driven(&self) -> f64 {
        self.driven.0
    }

    /// The move for a robot at the believed `pose` at `time`, with the robot-frame returns
    /// `points` (what its clearance is checked against) and a body of `length` × `width` m.
    pub fn step(
        &mut self,
        pose: &Pose,
        time: f64,
        points: &[DVec2],
        length: f64,
        width: f64,
    ) -> RetraceStep {
        if time - self.since > self.timeout {
            return RetraceStep::Blocked;
        }
        let p = pose.xy();
        let (driven, from) = &mut self.driven;
        *driven += from.map_or(0.0, |f| (p - f).length());
        *from = Some(p);
        // Far enough from the dead end and free to turn: the follower takes over. A narrow
        // way goes on being backed out of; the follower would only turn into its sides.
        if (p - self.path[0]).length() >= self.away && turn_clear(points, length, width) {
            return RetraceStep::Done;
        }
        // Points passed are dropped; so are the ones where the robot stood turning.
        while self
            .path
            .get(self.next)
            .is_some_and(|q| (*q - p).length() < LOOK)
        {
            self.next += 1;
        }
        let Some(&target) = self.path.get(self.next) else {
            return RetraceStep::Done;
        };
        let bearing = wrap_angle((target - p).to_angle() - pose.yaw);
        // Forward where the trail goes on ahead, backing where it goes on behind.
        let (error, speed) = if bearing.abs() <= FRAC_PI_2 || !self.backs {
            (bearing, self.speed)
        } else {
            (wrap_angle(bearing - PI), -BACK_SPEED)
        };
        let omega = (K_HEADING * error).clamp(-TURN, TURN);
        let drive = Twist {
            v: if error.abs() <= DRIVE_WITHIN {
                speed * error.cos()
            } else {
                0.0
            },
            omega,
        };
        let turn = Twist { v: 0.0, omega };
        let straight = Twist {
            v: speed,
            omega: 0.0,
        };
        // Straight on helps a replay only when it faces the way on.
        let straight_on = self.backs || error.abs() <= DRIVE_WITHIN;
        // Facing the way on, the robot drives; turns on the spot there only steer. Where they
        // go on without the robot getting anywhere (the believed path runs into what the
        // sensor sees: the drive is blocked, each turn a milliradian), it is blocked.
        if error.abs() > DRIVE_WITHIN || *driven >= self.progress.1 + STALL_DISTANCE {
            self.progress = (time, *driven);
        } else if time - self.progress.0 > STALL {
            return RetraceStep::Blocked;
        }
        [Some(drive), Some(turn), straight_on.then_some(straight)]
            .into_iter()
            .flatten()
            .find(|t| !sweep_touches(points, length, width, *t))
            .map_or(RetraceStep::Blocked, |t| {
                RetraceStep::Drive(DriveCommand::twist(t.v, t.omega))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::integrate;

    const L: f64 = 0.508;
    const W: f64 = 0.497;

    fn trail_of(points: &[DVec2]) -> Trail {
        let mut t = Trail::default();
        for w in points.windows(2) {
            let n = ((w[1] - w[0]).length() / 0.01).ceil() as usize;
            for k in 0..=n {
                t.record(w[0] + (w[1] - w[0]) * (k as f64 / n as f64));
            }
        }
        t
    }

    fn xs(t: &Trail) -> Vec<DVec2> {
        t.points.iter().map(|(q, _)| *q).collect()
    }

    #[test]
    fn the_trail_keeps_its_last_metres_at_its_spacing() {
        let t = trail_of(&[DVec2::ZERO, DVec2::new(10.0, 0.0)]);
        assert!((KEEP - 0.2..=KEEP).contains(&t.length()), "{}", t.length());
        let direct: f64 = xs(&t).windows(2).map(|w| (w[1] - w[0]).length()).sum();
        assert!((direct - t.length()).abs() < 1e-9);
        let last = *xs(&t).last().unwrap();
        assert!((last.x - 10.0).abs() < SPACING + 1e-9, "{last}");
    }

    #[test]
    fn a_way_driven_back_or_round_to_where_the_robot_was_leaves_the_trail() {
        // In 3 m along x, backed 2 m: the trail ends a metre in.
        let t = trail_of(&[DVec2::ZERO, DVec2::new(3.0, 0.0), DVec2::new(1.0, 0.03)]);
        let last = *xs(&t).last().unwrap();
        assert!((last.x - 1.0).abs() < 0.16, "{last}");
        assert!((t.length() - 1.0).abs() < 0.16, "{}", t.length());
        // Round a square and back near its corner: the loop goes.
        let t = trail_of(&[
            DVec2::new(-1.0, 0.0),
            DVec2::ZERO,
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.05, 0.0),
        ]);
        assert!(
            xs(&t).iter().all(|q| q.x <= 0.1 && q.y <= 0.1),
            "{:?}",
            xs(&t)
        );
        // A tight turn keeps its samples: they are near each other only along the path.
        let arc: Vec<DVec2> = (0..=16)
            .map(|k| DVec2::from_angle(k as f64 * PI / 16.0) * 0.2)
            .collect();
        let t = trail_of(&arc);
        assert!(t.length() > 0.5, "{}", t.length());
    }

    #[test]
    fn a_retrace_after_backing_out_of_a_narrow_way_goes_back_the_way_in() {
        // In along x to the mouth of a way north, up it 3 m, and backed out again.
        let t = trail_of(&[
            DVec2::new(-3.0, 0.0),
            DVec2::ZERO,
            DVec2::new(0.0, 3.0),
            DVec2::new(0.02, 0.2),
        ]);
        let r = Retrace::along(&t, 2.0, 0.0).unwrap();
        assert!(r.path.iter().all(|q| q.y < 0.3), "{:?}", r.path);
        assert!(r.path.last().unwrap().x < -2.5, "{:?}", r.path);
        // Too little trail for a way back that long.
        let t = trail_of(&[DVec2::ZERO, DVec2::new(0.8, 0.0)]);
        assert!(Retrace::along(&t, 2.0, 0.0).is_none());
    }

    #[test]
    fn straight_behind_is_as_far_as_the_trail_runs_along_the_axis() {
        // In along x, then a bend: 1.5 m straight behind a robot at the trail's end facing +x.
        let t = trail_of(&[
            DVec2::new(-1.0, 2.0),
            DVec2::new(-1.0, 0.0),
            DVec2::new(0.5, 0.0),
        ]);
        let b = t.straight_behind(&Pose::new(0.5, 0.0, 0.0, 0.0));
        assert!((b - 1.5).abs() < 0.11, "{b}");
        // Turned 90° at the end: nothing of the trail lies behind.
        assert!(t.straight_behind(&Pose::new(0.5, 0.0, 0.0, FRAC_PI_2)) < 1e-9);
        // Facing back down the trail: it lies ahead.
        assert!(t.straight_behind(&Pose::new(0.5, 0.0, 0.0, PI)) < 1e-9);
    }

    #[test]
    fn straight_behind_holds_while_backing_along_the_trail() {
        // In along x to x = 2, then backing: each step back, the trail behind is still there
        // (the stretch just backed over lies ahead on the axis). Counted as nothing, it cut
        // a turn guard's escape back short after one step, and the turn went on anyway.
        let mut t = trail_of(&[DVec2::new(0.0, 0.0), DVec2::new(2.0, 0.0)]);
        for k in 1..=15 {
            let x = 2.0 - 0.01 * k as f64;
            t.record(DVec2::new(x, 0.0));
            let b = t.straight_behind(&Pose::new(x, 0.0, 0.0, 0.0));
            assert!((b - x).abs() < 0.11, "at x = {x}: {b}");
        }
        // Turned off the line while backing: only what lies along the new axis counts.
        let b = t.straight_behind(&Pose::new(1.85, 0.0, 0.0, 0.3));
        assert!(b < 0.4, "{b}");
    }

    /// Drives `r` from `pose` among the world points `world` until it ends; the poses.
    fn drive(r: &mut Retrace, mut pose: Pose, world: &[DVec2]) -> (RetraceStep, Vec<Pose>) {
        let dt = 0.1;
        let mut poses = vec![pose];
        for k in 0..2000 {
            let inv = pose.inverse();
            let local: Vec<DVec2> = world
                .iter()
                .map(|q| inv.compose(&Pose::new(q.x, q.y, 0.0, 0.0)).xy())
                .collect();
            match r.step(&pose, k as f64 * dt, &local, L, W) {
                RetraceStep::Drive(DriveCommand::Twist(t)) => {
                    pose = integrate(&pose, t, dt);
                    poses.push(pose);
                }
                RetraceStep::Drive(c) => panic!("not a twist: {c:?}"),
                end => return (end, poses),
            }
        }
        (RetraceStep::Blocked, poses)
    }

    /// Points every 2 cm along the segment from `a` to `b`.
    fn side(a: DVec2, b: DVec2) -> Vec<DVec2> {
        let n = ((b - a).length() / 0.02).ceil() as usize;
        (0..=n)
            .map(|k| a + (b - a) * (k as f64 / n as f64))
            .collect()
    }

    #[test]
    fn a_robot_at_the_end_of_a_narrow_way_backs_out_along_its_trail() {
        // A way 0.65 m wide (too narrow to turn in) along x from 0 to 3, entered from the
        // open end at x = 0 on a path that came in from the side.
        let mut world = side(DVec2::new(0.0, 0.325), DVec2::new(3.0, 0.325));
        world.extend(side(DVec2::new(0.0, -0.325), DVec2::new(3.0, -0.325)));
        world.extend(side(DVec2::new(3.0, -0.325), DVec2::new(3.0, 0.325)));
        let t = trail_of(&[
            DVec2::new(-1.5, -1.5),
            DVec2::new(-0.8, 0.0),
            DVec2::new(2.5, 0.0),
        ]);
        // Asked to go 1 m back: it goes on until the body is out of the way and can turn.
        let mut r = Retrace::along(&t, 1.0, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.5, 0.0, 0.0, 0.0), &world);
        assert_eq!(end, RetraceStep::Done);
        let last = poses.last().unwrap();
        assert!((-0.5..0.0).contains(&last.x), "{last:?}");
        let driven: f64 = poses
            .windows(2)
            .map(|w| w[0].xy().distance(w[1].xy()))
            .sum();
        assert!(
            (r.driven() - driven).abs() < 0.05,
            "{} {driven}",
            r.driven()
        );
        // Backing all the way: the body never turned inside the way.
        for q in &poses {
            if q.x > 0.3 {
                assert!(q.yaw.abs() < 0.05, "{q:?}");
            }
        }
    }

    #[test]
    fn a_robot_with_room_to_turn_drives_its_trail_back_forward() {
        let t = trail_of(&[DVec2::ZERO, DVec2::new(2.0, 0.0)]);
        let mut r = Retrace::along(&t, 1.5, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.0, 0.0, 0.0, PI), &[]);
        assert_eq!(end, RetraceStep::Done);
        // With room to turn, it ends as soon as it is far enough.
        let last = poses.last().unwrap();
        assert!((0.35..=0.5).contains(&last.x), "{last:?}");
        assert!(poses.iter().all(|q| q.yaw.abs() > 3.0));
        assert!(poses.windows(2).all(|w| w[1].x <= w[0].x + 1e-9));
    }

    #[test]
    fn a_wall_across_the_way_back_blocks_the_retrace() {
        let world = side(DVec2::new(0.8, -1.0), DVec2::new(0.8, 1.0));
        let t = trail_of(&[DVec2::ZERO, DVec2::new(2.0, 0.0)]);
        let mut r = Retrace::along(&t, 2.0, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.0, 0.0, 0.0, 0.0), &world);
        assert_eq!(end, RetraceStep::Blocked);
        let last = poses.last().unwrap();
        assert!(last.x - L / 2.0 > 0.8, "{last:?}");
    }

    #[test]
    fn a_replay_turns_to_face_its_path_and_drives_it_forward_to_its_end() {
        // An L (east 2 m, then north 2 m) behind a robot facing west at its start: a retrace
        // would back; a replay turns about and drives it forward, through a way 0.8 m wide
        // round the corner, to its last point.
        let path: Vec<DVec2> = (0..=20)
            .map(|k| DVec2::new(0.1 * k as f64, 0.0))
            .chain((1..=20).map(|k| DVec2::new(2.0, 0.1 * k as f64)))
            .collect();
        let mut world = side(DVec2::new(-1.0, -0.4), DVec2::new(2.4, -0.4));
        world.extend(side(DVec2::new(2.4, -0.4), DVec2::new(2.4, 2.5)));
        world.extend(side(DVec2::new(0.5, 0.4), DVec2::new(1.6, 0.4)));
        world.extend(side(DVec2::new(1.6, 0.4), DVec2::new(1.6, 2.5)));
        let mut r = Retrace::replay(path, 0.4, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(0.0, 0.0, 0.0, PI), &world);
        assert_eq!(end, RetraceStep::Done);
        let last = poses.last().unwrap();
        assert!(last.xy().distance(DVec2::new(2.0, 2.0)) < 0.35, "{last:?}");
        // Never backing: each step goes the way the body faces.
        for w in poses.windows(2) {
            let d = w[1].xy() - w[0].xy();
            assert!(d.dot(DVec2::from_angle(w[0].yaw)) >= -1e-9, "{w:?}");
        }
        // It ends facing north, having turned about first.
        assert!((last.yaw - FRAC_PI_2).abs() < 0.5, "{last:?}");
        assert!(Retrace::replay(vec![DVec2::ZERO], 0.4, 0.0).is_none());
    }

    #[test]
    fn a_replay_facing_a_wall_across_its_way_ends_blocked_instead_of_shuffling() {
        // The believed path runs on through a wall 1.5 m ahead (odometry drifted): the robot
        // faces it within a few milliradians. Driving on is blocked; the turns on the spot
        // left at that error are a shuffle of milliradians a step, standing against the wall
        // until the timeout. Once the robot gets no farther for a while, the follower is
        // handed the wall instead.
        let path: Vec<DVec2> = (0..=40).map(|k| DVec2::new(0.1 * k as f64, 0.0)).collect();
        let world = side(DVec2::new(1.5, -2.0), DVec2::new(1.5, 2.0));
        let mut r = Retrace::replay(path, 0.3, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(0.0, 0.0, 0.0, 0.03), &world);
        assert_eq!(end, RetraceStep::Blocked);
        let last = poses.last().unwrap();
        assert!(last.x + L / 2.0 < 1.5, "{last:?}");
        // Blocked soon after the drive is (about 4 s to get there, 4 s more): not at the
        // timeout (90 s and more).
        let time = 0.1 * poses.len() as f64;
        assert!(time < 15.0, "{time} s, {last:?}");
    }
}
