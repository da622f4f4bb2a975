//! Leaving a dead end the way the robot came in (DESIGN §6).
//!
//! A robot that makes no progress for a while (the Bug controller's no-progress watchdog)
//! stands where its rules give it no way on. An example is a pocket between bushes entered
//! through a gap passage, whose other ways out are narrower than the body. Every heading
//! there is blocked within the safety distance, so the follower turns on the spot for ever,
//! and a retry with a smaller standoff starts in the same pocket.
//!
//! The way in is known to be passable: the robot drove it. [`Trail`] keeps the last metres
//! of the believed path, and [`Retrace`] drives a stretch of it back. The robot goes forward
//! where the next point of the trail lies ahead and backs where it lies behind, so a body
//! that cannot turn in a narrow way reverses out along the path it came in on. Held in the
//! believed frame, the trail is as good as the odometry over a few metres. Every command
//! still passes the bumpers' sweep check ([`super::guard::sweep_touches`]).
//!
//! The controller remembers the place as a dead end. Its follower passes no gap near it
//! again (see [`super::wall_follow::WallFollower::avoid`]).

use std::collections::VecDeque;
use std::f64::consts::{FRAC_PI_2, PI};

use glam::DVec2;

use super::guard::sweep_touches;
use super::passage::BACK_SPEED;
use crate::pose::{Pose, wrap_angle};
use crate::vehicle::{DriveCommand, Twist};

/// Spacing of the trail's samples, m.
const SPACING: f64 = 0.1;
/// Path kept in the trail, m: more than one retrace takes.
const KEEP: f64 = 6.0;
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
/// Trail points this near the body's axis lie straight behind it, m.
const ALONG_AXIS: f64 = 0.1;

/// The last few metres of the believed path.
#[derive(Clone, Debug, Default)]
pub struct Trail {
    points: VecDeque<DVec2>,
    /// Length of the path through `points`, m.
    length: f64,
}

impl Trail {
    /// Adds the robot's believed position `p`, if it is far enough from the last sample.
    pub fn record(&mut self, p: DVec2) {
        if self
            .points
            .back()
            .is_some_and(|l| (p - *l).length() < SPACING)
        {
            return;
        }
        self.length += self.points.back().map_or(0.0, |l| (p - *l).length());
        self.points.push_back(p);
        while self.length > KEEP
            && let (Some(a), Some(b)) = (self.points.front(), self.points.get(1))
        {
            self.length -= (*b - *a).length();
            self.points.pop_front();
        }
    }

    /// How far straight back from the believed `pose` the robot came forward along its own
    /// trail, m: the trail's newest points within [`ALONG_AXIS`] of the body's axis behind it.
    /// Backing that far goes where the body has just been; a 270° laser sees nothing there.
    pub fn straight_behind(&self, pose: &Pose) -> f64 {
        let to_body = pose.inverse();
        let mut behind: f64 = 0.0;
        for q in self.points.iter().rev() {
            let r = to_body.compose(&Pose::new(q.x, q.y, 0.0, 0.0)).xy();
            if r.x > ALONG_AXIS || r.y.abs() > ALONG_AXIS {
                break;
            }
            behind = behind.max(-r.x);
        }
        behind
    }

    /// Takes the trail off it back to the first point `away` metres from its newest one
    /// (all of it when none is), newest first: the way back. Counted in straight line, not
    /// along the trail: shuffling to and fro where the robot got stuck lays down trail
    /// without getting anywhere.
    fn take_back(&mut self, away: f64) -> Vec<DVec2> {
        let mut back: Vec<DVec2> = Vec::new();
        while let Some(q) = self.points.pop_back() {
            self.length -= back.last().map_or(0.0, |l| (q - *l).length());
            back.push(q);
            if (q - back[0]).length() >= away {
                // The last point taken is where the trail goes on from next time.
                self.points.push_back(q);
                break;
            }
        }
        if self.points.len() < 2 {
            self.length = 0.0;
        }
        back
    }
}

/// What one step of a [`Retrace`] gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RetraceStep {
    /// Drive this.
    Drive(DriveCommand),
    /// Back at the far end of the stretch.
    Done,
    /// No free move along it (or out of time).
    Blocked,
}

/// Driving a stretch of the trail back (module docs).
#[derive(Clone, Debug)]
pub struct Retrace {
    /// The way back, newest first: from where the robot stands to the stretch's far end.
    path: Vec<DVec2>,
    /// Index of the point steered for.
    next: usize,
    /// When the retrace started, s.
    since: f64,
}

impl Retrace {
    /// A retrace of `trail` (taken off it) back to where it was `away` metres from where
    /// the robot is, started at `time`: `None` when no point of the trail lies half that
    /// far (no way in is known).
    pub fn along(trail: &mut Trail, away: f64, time: f64) -> Option<Self> {
        let newest = *trail.points.back()?;
        if trail
            .points
            .iter()
            .all(|q| (*q - newest).length() < away / 2.0)
        {
            return None;
        }
        Some(Self {
            path: trail.take_back(away),
            next: 0,
            since: time,
        })
    }

    /// Where the retrace ends (believed frame).
    pub fn end(&self) -> DVec2 {
        self.path.last().copied().unwrap_or_default()
    }

    /// Length of the way back, m.
    pub fn length(&self) -> f64 {
        self.path.windows(2).map(|w| (w[1] - w[0]).length()).sum()
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
        if time - self.since > TIMEOUT {
            return RetraceStep::Blocked;
        }
        let p = pose.xy();
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
        let (error, speed) = if bearing.abs() <= FRAC_PI_2 {
            (bearing, FORWARD_SPEED)
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
        [drive, turn, straight]
            .into_iter()
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

    #[test]
    fn the_trail_keeps_its_last_metres_at_its_spacing() {
        let t = trail_of(&[DVec2::ZERO, DVec2::new(10.0, 0.0)]);
        assert!((KEEP - 0.2..=KEEP).contains(&t.length), "{}", t.length);
        let direct: f64 = t
            .points
            .iter()
            .zip(t.points.iter().skip(1))
            .map(|(a, b)| (*b - *a).length())
            .sum();
        assert!((direct - t.length).abs() < 1e-9);
        let last = *t.points.back().unwrap();
        assert!((last.x - 10.0).abs() < SPACING + 1e-9, "{last}");
    }

    #[test]
    fn taking_back_a_stretch_leaves_its_far_end_on_the_trail() {
        let mut t = trail_of(&[DVec2::ZERO, DVec2::new(3.0, 0.0)]);
        let r = Retrace::along(&mut t, 2.0, 0.0).unwrap();
        // Whole samples: up to one spacing (0.1 m, plus the rounding of the walk) over.
        assert!((2.0..2.0 + 0.12).contains(&r.length()), "{}", r.length());
        // Shuffling to and fro at the end lays down trail but gets nowhere: the way back
        // still goes as far from where the robot stands.
        let mut t = trail_of(&[
            DVec2::ZERO,
            DVec2::new(3.0, 0.0),
            DVec2::new(2.5, 0.0),
            DVec2::new(3.0, 0.0),
        ]);
        let newest = *t.points.back().unwrap();
        let r = Retrace::along(&mut t, 2.0, 0.0).unwrap();
        let away = newest.x - r.end().x;
        assert!((2.0..2.12).contains(&away), "{newest} {}", r.end());
        let mut t = trail_of(&[DVec2::ZERO, DVec2::new(3.0, 0.0)]);
        let r = Retrace::along(&mut t, 2.0, 0.0).unwrap();
        assert!((r.end().x - (3.0 - r.length())).abs() < 0.12, "{}", r.end());
        assert!((t.length + r.length() - 3.0).abs() < 0.12, "{}", t.length);
        assert_eq!(*t.points.back().unwrap(), r.end());
        // Too little trail left for another stretch that long.
        assert!(Retrace::along(&mut t, 2.5, 0.0).is_none());
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
        let mut t = trail_of(&[
            DVec2::new(-1.5, -1.5),
            DVec2::new(-0.8, 0.0),
            DVec2::new(2.5, 0.0),
        ]);
        let mut r = Retrace::along(&mut t, 3.5, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.5, 0.0, 0.0, 0.0), &world);
        assert_eq!(end, RetraceStep::Done);
        let last = poses.last().unwrap();
        assert!((last.xy() - r.end()).length() < LOOK + 0.05, "{last:?}");
        // Backing all the way: the body never turned inside the way.
        for q in &poses {
            if q.x > 0.3 {
                assert!(q.yaw.abs() < 0.05, "{q:?}");
            }
        }
    }

    #[test]
    fn a_robot_with_room_to_turn_drives_its_trail_back_forward() {
        let mut t = trail_of(&[DVec2::ZERO, DVec2::new(2.0, 0.0)]);
        let mut r = Retrace::along(&mut t, 1.5, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.0, 0.0, 0.0, PI), &[]);
        assert_eq!(end, RetraceStep::Done);
        assert!(poses.iter().all(|q| q.yaw.abs() > 3.0));
        assert!(poses.windows(2).all(|w| w[1].x <= w[0].x + 1e-9));
    }

    #[test]
    fn a_wall_across_the_way_back_blocks_the_retrace() {
        let world = side(DVec2::new(0.8, -1.0), DVec2::new(0.8, 1.0));
        let mut t = trail_of(&[DVec2::ZERO, DVec2::new(2.0, 0.0)]);
        let mut r = Retrace::along(&mut t, 2.0, 0.0).unwrap();
        let (end, poses) = drive(&mut r, Pose::new(2.0, 0.0, 0.0, 0.0), &world);
        assert_eq!(end, RetraceStep::Blocked);
        let last = poses.last().unwrap();
        assert!(last.x - L / 2.0 > 0.8, "{last:?}");
    }
}
