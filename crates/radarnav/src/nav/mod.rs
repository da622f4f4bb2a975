//! Navigation (DESIGN §6): virtual bumpers, wall following, Bug1 and Bug2, exploration, and
//! the simple controllers (teleop, waypoints, standing still).

pub mod bug;
pub mod bumper;
pub mod explore;
pub mod guard;
pub mod passage;
pub mod retrace;
mod teleop;
pub mod wall_follow;
mod waypoints;

pub use bug::{BugAlgorithm, BugController, BugMission, BugReport};
pub use bumper::{BumperConfig, BumperRule, BumperSensor, BumperState, Bumpers, read_first_echoes};
pub use explore::{ExploreController, ExploreMission, Strategy};
pub use teleop::TeleopController;
pub use wall_follow::{FollowRule, Side, WallFollower};
pub use waypoints::WaypointController;

use crate::map::PoseSource;
use crate::pose::Pose;
use crate::sim::{ControlInput, Controller, Decision};
use crate::vehicle::DriveCommand;
use guard::Guarded;

/// The robot pose a controller navigates on: the odometry, the localiser's estimate, or the
/// truth when asked. On `slam` without a localiser in the run (the scenario starts one
/// whenever a mission asks for it), the odometry.
pub fn nav_pose(source: PoseSource, input: &ControlInput<'_>) -> Pose {
    match source {
        PoseSource::Truth => *input.truth,
        PoseSource::Odometry => *input.odometry,
        PoseSource::Slam => input.slam.copied().unwrap_or(*input.odometry),
    }
}

/// The pose a controller navigates on at the time the latest scan of sensor `i` was taken
/// (`None` before its first scan).
pub fn scan_pose(source: PoseSource, input: &ControlInput<'_>, i: usize) -> Option<Pose> {
    match source {
        // The scan carries the true pose of the sensor; the robot's is that less the mount.
        PoseSource::Truth => {
            let scan = input.scans.get(i)?.as_ref()?;
            Some(scan.pose.compose(&input.sensors.get(i)?.mount.inverse()))
        }
        PoseSource::Odometry => input.scan_odometry.get(i).copied().flatten(),
        PoseSource::Slam => (input.scan_slam.get(i).copied().flatten())
            .or_else(|| input.scan_odometry.get(i).copied().flatten()),
    }
}

/// A navigation behaviour on bumpers; [`WithRecoil`] makes it a [`Controller`].
pub trait Behaviour {
    /// Calls per second.
    fn rate_hz(&self) -> f64;
    /// The command for the coming period; `bumped` is true on the first call after the
    /// robot recoiled from a bump.
    fn decide(&mut self, input: &ControlInput<'_>, bumped: bool) -> Decision;
    /// What the behaviour did, for `summary.json`.
    fn report(&self) -> Option<serde_json::Value> {
        None
    }
    /// The bumpers it decided on, for the [`guard`] (`None`: its commands go out unchecked).
    fn bumpers(&self) -> Option<&Bumpers> {
        None
    }
    /// The body touched something while driving `(v, omega)`: what a real bumper strip
    /// says, where the sensor saw nothing (behind a 270° laser). Default: nothing kept.
    fn touched(&mut self, _input: &ControlInput<'_>, _moving: (f64, f64)) {}
}

/// A behaviour with the reflex of a real bumper: after a refused move, back away from what
/// was hit for a moment (forward if the robot hit something while reversing, turning back
/// if it hit something turning on the spot) before the behaviour resumes, told that it
/// bumped: the sensor missed something (foliage the radar crosses whole), so the way it was
/// going is blocked. A recoil that is refused too (the body wedged between two obstacles)
/// is cut short and the behaviour decides at once. A turn on the spot that bumped is not
/// made again in the same sense until the robot has moved off that spot.
///
/// Before that reflex comes the [`guard`]: each command of the behaviour is swept against
/// its bumpers' returns, and one that would touch them is cut to a free part, or stopped
/// with the behaviour told it bumped. A robot whose turns on the spot the guard has stopped
/// for `STALL_PATIENCE` (10 s) without it moving off the spot (and no real bump there) has
/// them judged on a noisy sensor's denoised returns ([`guard::guard_steady`]): on the raw
/// ones a laser robot stood under a crate's corner its turn cleared by 5 cm until the
/// watchdog gave up.
#[derive(Clone, Debug)]
pub struct WithRecoil<B> {
    behaviour: B,
    remaining: u32,
    recoil: (f64, f64),
    last: (f64, f64),
    recoiled: bool,
    /// Whether the last command was a recoil.
    recoiling: bool,
    /// A turn on the spot that bumped or that the guard stopped: its sense (±1) and the
    /// odometry pose it was stopped at.
    pressed: Option<(f64, Pose)>,
    /// Where (odometry pose) and since when the guard has stopped turns on the spot without
    /// the robot moving off that spot; since never after a real bump there.
    stalled: Option<(Pose, f64)>,
}

/// A turn on the spot that bumped, or that the guard stopped, is not made again in the same
/// sense until the robot has moved this far, m ([`WithRecoil`]).
const PRESSED_MOVE: f64 = 0.02;

/// Stalled this long on one spot by the guard stopping its turns (see [`WithRecoil`]), a
/// robot with a noisy sensor has its turns on the spot checked on the denoised returns, s.
/// (The Bug's watchdog gives up after 30 s.)
const STALL_PATIENCE: f64 = 10.0;

/// How long a recoil lasts, s, its speed, m/s, and its turn rate after a turn, rad/s.
const RECOIL: (f64, f64, f64) = (0.6, 0.2, 0.5);

impl<B> WithRecoil<B> {
    /// `behaviour` with the reflex.
    pub fn new(behaviour: B) -> Self {
        Self {
            behaviour,
            remaining: 0,
            recoil: (0.0, 0.0),
            last: (0.0, 0.0),
            recoiled: false,
            recoiling: false,
            pressed: None,
            stalled: None,
        }
    }

    /// The behaviour.
    pub fn behaviour(&self) -> &B {
        &self.behaviour
    }
}

impl<B: Behaviour> Controller for WithRecoil<B> {
    fn rate_hz(&self) -> f64 {
        self.behaviour.rate_hz()
    }

    fn update(&mut self, input: &ControlInput<'_>) -> Decision {
        if input.bumped && self.recoiling {
            // The recoil itself was refused (wedged between two obstacles): repeating it
            // would push for ever. The behaviour decides, told that it bumped.
            self.remaining = 0;
            self.recoiled = true;
        } else if input.bumped && self.remaining == 0 {
            self.remaining = (RECOIL.0 * self.behaviour.rate_hz()).ceil() as u32;
            let (v, omega) = self.last;
            // A real bump: no patience on this spot.
            self.stalled = Some((*input.odometry, f64::INFINITY));
            if v == 0.0 && omega != 0.0 {
                self.pressed = Some((omega.signum(), *input.odometry));
            }
            self.behaviour.touched(input, self.last);
            // A turn on the spot that hit something is undone by turning back; a move by
            // moving the other way.
            self.recoil = if v == 0.0 && omega != 0.0 {
                (0.0, -omega.signum() * RECOIL.2)
            } else if v > 0.0 {
                (-RECOIL.1, 0.0)
            } else {
                (RECOIL.1, 0.0)
            };
            self.recoiled = true;
        }
        self.recoiling = self.remaining > 0;
        if self.recoiling {
            self.remaining -= 1;
            return Decision::Drive(DriveCommand::twist(self.recoil.0, self.recoil.1));
        }
        let mut d = self
            .behaviour
            .decide(input, std::mem::take(&mut self.recoiled));
        if self
            .stalled
            .is_some_and(|(at, _)| (input.odometry.xy() - at.xy()).length() > PRESSED_MOVE)
        {
            self.stalled = None;
        }
        let patient = self
            .stalled
            .is_some_and(|(_, since)| input.time - since >= STALL_PATIENCE);
        if let (Decision::Drive(cmd), Some(b)) = (d, self.behaviour.bumpers()) {
            let t = input.vehicle.limit(cmd);
            // Stalled, a turn on the spot is judged on the denoised returns: the nearest of
            // hundreds of raw ones lie centimetres short of a wall the turn clears, and the
            // robot would stand turning against it until the watchdog gave up.
            let steady = patient && t.v == 0.0 && t.omega != 0.0 && b.is_denoised();
            let guarded = if steady {
                guard::guard_steady(b.steady_clearance(), input.vehicle, t)
            } else {
                guard::guard(b.clearance(), input.vehicle, t)
            };
            match guarded {
                Guarded::Free if steady => self.pressed = None,
                Guarded::Free => {}
                Guarded::Replaced(t) => d = Decision::Drive(DriveCommand::Twist(t)),
                Guarded::Stop => {
                    // What a bumper would have said a moment later.
                    self.recoiled = true;
                    d = Decision::Drive(DriveCommand::STOP);
                    // Held as a bump is: on this spot the next scan's noise must not let
                    // through what this one stopped (a corner behind the body may be one
                    // remembered return, which the guard does not count alone).
                    if let DriveCommand::Twist(t) = cmd
                        && t.v == 0.0
                        && t.omega != 0.0
                        && self.pressed.is_none()
                    {
                        self.pressed = Some((t.omega.signum(), *input.odometry));
                    }
                    if t.v == 0.0 && t.omega != 0.0 && self.stalled.is_none() {
                        self.stalled = Some((*input.odometry, input.time));
                    }
                }
            }
        }
        // A turn on the spot that bumped (or that the guard stopped) presses the same corner
        // in again on that spot, whatever the returns say at the moment (range noise may
        // show the corner clear): that sense of turn stops until the robot has moved off the
        // spot. (Not until it has turned back: wheels spinning against a blocked turn turn
        // the odometry all the same.)
        if let Some((sense, at)) = self.pressed {
            if (input.odometry.xy() - at.xy()).length() > PRESSED_MOVE {
                self.pressed = None;
            } else if let Decision::Drive(DriveCommand::Twist(t)) = d
                && t.v == 0.0
                && t.omega * sense > 0.0
            {
                self.recoiled = true;
                d = Decision::Drive(DriveCommand::STOP);
            }
        }
        if let Decision::Drive(DriveCommand::Twist(t)) = d {
            self.last = (t.v, t.omega);
        }
        d
    }

    fn report(&self) -> Option<serde_json::Value> {
        self.behaviour.report()
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vehicle::Twist;

    /// Commands the same twist `(v, omega)` whatever happens, counting the calls that were
    /// told of a bump; its bumpers are whatever the test gives it.
    struct Steady {
        twist: (f64, f64),
        told: usize,
        bumpers: Option<Bumpers>,
    }

    impl Steady {
        fn new(v: f64, omega: f64) -> Self {
            Self {
                twist: (v, omega),
                told: 0,
                bumpers: None,
            }
        }
    }

    impl Behaviour for Steady {
        fn rate_hz(&self) -> f64 {
            10.0
        }

        fn decide(&mut self, _: &ControlInput<'_>, bumped: bool) -> Decision {
            self.told += usize::from(bumped);
            Decision::Drive(DriveCommand::twist(self.twist.0, self.twist.1))
        }

        fn bumpers(&self) -> Option<&Bumpers> {
            self.bumpers.as_ref()
        }
    }

    fn twist(d: Decision) -> Twist {
        match d {
            Decision::Drive(DriveCommand::Twist(t)) => t,
            other => panic!("a twist expected, got {other:?}"),
        }
    }

    /// One control step of a P3-AT standing at `pose` (odometry and truth alike), without
    /// scans: the twist `c` commands.
    fn step(c: &mut WithRecoil<Steady>, pose: Pose, bumped: bool) -> Twist {
        step_at(c, pose, bumped, 0.0)
    }

    /// [`step`] at `time` s.
    fn step_at(c: &mut WithRecoil<Steady>, pose: Pose, bumped: bool, time: f64) -> Twist {
        let vehicle = crate::vehicle::vehicle("p3at").expect("p3at");
        twist(c.update(&ControlInput {
            time,
            odometry: &pose,
            truth: &pose,
            bumped,
            scans: &[],
            scan_odometry: &[],
            slam: None,
            scan_slam: &[],
            sensors: &[],
            vehicle,
        }))
    }

    #[test]
    fn a_recoil_that_is_refused_too_hands_back_to_the_behaviour() {
        let here = Pose::default();
        let mut c = WithRecoil::new(Steady::new(0.4, 0.0));
        assert_eq!(step(&mut c, here, false).v, 0.4);
        // Driving on bumped: back away for RECOIL.0 s.
        assert_eq!(step(&mut c, here, true).v, -RECOIL.1);
        assert_eq!(step(&mut c, here, false).v, -RECOIL.1);
        // Backing away bumped as well (wedged): the behaviour decides, told of the bump,
        // instead of backing into the same obstacle for ever.
        assert_eq!(step(&mut c, here, true).v, 0.4);
        assert_eq!(c.behaviour().told, 1);
        // Its move bumping again starts a new recoil.
        assert_eq!(step(&mut c, here, true).v, -RECOIL.1);
    }

    /// A turn on the spot that bumped is not made again there (the returns may show the
    /// corner clear, as range noise did to a laser robot wedged in a slot, 40 bumps in one
    /// run): it stops, the behaviour told it bumped, until the robot has moved off the spot.
    #[test]
    fn a_turn_that_bumped_is_not_repeated_on_the_same_spot() {
        let here = Pose::default();
        let mut c = WithRecoil::new(Steady::new(0.0, -0.8));
        assert_eq!(step(&mut c, here, false).omega, -0.8);
        // It bumped: turn back for the recoil (the wheels may spin against it: the pose
        // given here does not change) ...
        assert_eq!(step(&mut c, here, true).omega, RECOIL.2);
        while c.remaining > 0 {
            assert_eq!(step(&mut c, here, false).omega, RECOIL.2);
        }
        // ... then the right turn stops, however often it is asked, the behaviour told.
        for _ in 0..5 {
            let t = step(&mut c, here, false);
            assert_eq!((t.v, t.omega), (0.0, 0.0));
        }
        assert_eq!(c.behaviour().told, 5);
        // Moved off the spot (3 cm), the turn goes out again.
        let moved = Pose::new(0.03, 0.0, 0.0, 0.0);
        assert_eq!(step(&mut c, moved, false).omega, -0.8);
    }

    /// A turn on the spot the guard stopped stays stopped on that spot when the next scan
    /// shows the way clear: a wall 2 cm beside the body, then a scan without it (range
    /// noise, or a corner behind remembered as one return, as on a random crates map
    /// where the let-through turn bumped).
    #[test]
    fn a_turn_the_guard_stopped_is_not_let_through_by_the_next_scan() {
        use super::bumper::BumperRule;
        use super::bumper::tests::ring_scan;
        let vehicle = crate::vehicle::vehicle("p3at").expect("p3at");
        let run = |c: &mut WithRecoil<Steady>, pose: Pose| step(c, pose, false);
        let sense = |f: &dyn Fn(f64) -> f32| {
            let scan = ring_scan(720, f);
            Bumpers::sense(&scan, &Pose::default(), 8, 1.27, 0.5, BumperRule::All)
        };
        // A wall along the right side, 2 cm from the body: the right turn's front corner
        // swings into it.
        let side = 0.5 * vehicle.width + 0.02;
        let wall = sense(&|a: f64| {
            if a.sin() < -0.1 {
                (side / -a.sin()) as f32
            } else {
                f32::INFINITY
            }
        });
        let clear = sense(&|_| f32::INFINITY);
        let here = Pose::default();
        let mut c = WithRecoil::new(Steady::new(0.0, -0.8));
        c.behaviour.bumpers = Some(wall);
        assert_eq!(run(&mut c, here).omega, 0.0);
        // The next scan shows nothing there: on the same spot the turn stays stopped.
        c.behaviour.bumpers = Some(clear);
        for _ in 0..3 {
            assert_eq!(run(&mut c, here).omega, 0.0);
        }
        // A turn the other way is not held back by it.
        c.behaviour.twist = (0.0, 0.8);
        assert_eq!(run(&mut c, here).omega, 0.8);
        // Moved off the spot (3 cm), the right turn goes out again.
        c.behaviour.twist = (0.0, -0.8);
        let moved = Pose::new(0.03, 0.0, 0.0, 0.0);
        assert_eq!(run(&mut c, moved).omega, -0.8);
    }

    /// A noisy sensor's robot the guard keeps from turning on one spot turns once it has
    /// stood there [`STALL_PATIENCE`], if the turn is free on the denoised returns: its raw
    /// returns' nearest lie centimetres short of the wall (as a laser robot stood under a
    /// crate's corner on `r22700-crates` until the watchdog gave up, its body 5 cm clear).
    /// Not where the denoised returns stop the turn too, nor after a real bump there.
    #[test]
    fn a_stalled_turn_is_judged_on_denoised_returns_after_a_while() {
        use super::bumper::BumperRule;
        use super::bumper::tests::ring_scan;
        let vehicle = crate::vehicle::vehicle("p3at").expect("p3at");
        // A wall ahead-left whose normal the front-left corner crosses turning left, `clear`
        // m beyond the corners' circle.
        let circle = 0.5 * vehicle.length.hypot(vehicle.width);
        let normal = vehicle.width.atan2(vehicle.length) + 0.2;
        let wall = |clear: f64| {
            let scan = ring_scan(720, |a: f64| {
                let c = (a - normal).cos();
                if c > 0.2 {
                    ((circle + clear) / c) as f32
                } else {
                    f32::INFINITY
                }
            });
            Bumpers::sense(&scan, &Pose::default(), 8, 1.27, 0.5, BumperRule::All)
        };
        let here = Pose::default();
        let stalled = |steady_clear: f64, bump: bool| {
            let mut c = WithRecoil::new(Steady::new(0.0, 0.8));
            // Raw returns 1 cm inside the circle; denoised ones `steady_clear` beyond it.
            let steady = wall(steady_clear).clearance().to_vec();
            c.behaviour.bumpers = Some(wall(-0.01).with_steady(steady));
            if bump {
                step_at(&mut c, here, true, 0.0);
            }
            (1..=200)
                .map(|k| step_at(&mut c, here, false, 0.1 * f64::from(k)).omega)
                .collect::<Vec<f64>>()
        };
        let turns = stalled(0.045, false);
        let first = turns.iter().position(|&w| w != 0.0).expect("turned");
        assert!(
            (0.1 * (first + 1) as f64 - 0.1 - STALL_PATIENCE).abs() < 0.15,
            "first turn at step {first}"
        );
        assert!(turns[first..].iter().all(|&w| w == 0.8));
        assert!(stalled(0.01, false).iter().all(|&w| w == 0.0));
        assert!(stalled(0.045, true).iter().all(|&w| w != 0.8));
    }
}
