//! The last check before a command goes out (DESIGN §6): driven by it for a moment, the body
//! must not touch a return its bumpers hold.
//!
//! The behaviours check the way they mean to go (the corridor toward the goal, the turning
//! circle, the strip through a gap), but a command is an arc: a robot turning away from a
//! wall beside it swings its rear into a corner it has just passed, and one heading for the
//! goal past a crate's corner clips it with a front corner while the goal's sector is clear.
//! So every command is swept along its arc for `HORIZON` seconds against the returns
//! ([`super::Bumpers::clearance`]); one that would bring the body to touch them is replaced
//! by its straight part, or by its turn on the spot, whichever is free of all returns but
//! one (the command itself may pass two, which may be range noise), or else the robot
//! stops and the behaviour is told it bumped, as a real bumper would have told it a moment
//! later.
//!
//! Counting returns suits a sensor whose rays are few or exact. A noisy fine-grained laser
//! puts hundreds of rays near the body, and the nearest few lie some 2.5 σ short of the
//! surface (7 cm with a 3 cm laser): a turn its body clears by 5 cm is stopped at every
//! scan. A robot stalled that way ([`super::WithRecoil`]) has its turns on the spot judged
//! by [`guard_steady`] on the denoised returns instead.

use glam::DVec2;

use super::passage::HITS_TO_BLOCK;
use crate::pose::Pose;
use crate::vehicle::{Twist, VehicleSpec, integrate};

/// How far ahead a command is swept, s: past the next control call at 10 Hz, with time to
/// spare for the one after.
const HORIZON: f64 = 0.3;
/// A return nearer the body than this touches it, m.
const MARGIN: f64 = 0.01;
/// [`MARGIN`] on denoised returns, which sit up to a centimetre out from a corner's tip (the
/// median rounds it off) and keep a few millimetres of noise, m.
const STEADY_MARGIN: f64 = 0.025;
/// Already nearer than [`MARGIN`], a move must not bring the body this much nearer still, m.
const NEARER: f64 = 1e-3;
/// Largest move and turn between two checked poses of a sweep, m and rad.
const SWEEP_STEP: (f64, f64) = (0.01, 0.02);
/// A part of a command that touches must come no nearer than [`MARGIN`] to this many returns
/// (one fewer than [`HITS_TO_BLOCK`]: only a single stray return is let pass).
const PART_HITS: usize = HITS_TO_BLOCK - 1;
/// Turns on the spot slower than this are no way out of a blocked arc, rad/s.
const MIN_TURN: f64 = 0.2;

/// What the guard made of a command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Guarded {
    /// The command is free.
    Free,
    /// The command touches; this part of it is free.
    Replaced(Twist),
    /// Neither the command nor a part of it is free: stop.
    Stop,
}

/// Signed distance from the robot-frame point `q` to a body of `length` × `width` m centred
/// on the robot, m: inside it, minus the distance to its nearest face. Signed, so that a
/// return already inside the body (range noise, a remembered return a little off) still
/// tells a move that goes deeper from one that backs out: with 0 for every point inside,
/// a turn swinging a corner into a wall was as free as one swinging it away.
fn body_distance(q: DVec2, length: f64, width: f64) -> f64 {
    let ex = q.x.abs() - length / 2.0;
    let ey = q.y.abs() - width / 2.0;
    if ex <= 0.0 && ey <= 0.0 {
        return ex.max(ey);
    }
    ex.max(0.0).hypot(ey.max(0.0))
}

/// The body's clearance among `points` (robot frame) at `pose`: the distance of the
/// `hits`-th nearest of them (1 to [`HITS_TO_BLOCK`]) to a body of `length` × `width` m
/// there, m; negative when that many lie inside it ([`body_distance`]).
fn clearance(points: &[DVec2], pose: &Pose, length: f64, width: f64, hits: usize) -> f64 {
    let to_body = pose.inverse();
    let mut nearest = [f64::INFINITY; HITS_TO_BLOCK];
    let last = hits.clamp(1, HITS_TO_BLOCK) - 1;
    for q in points {
        let d = body_distance(
            to_body.compose(&Pose::new(q.x, q.y, 0.0, 0.0)).xy(),
            length,
            width,
        );
        if d < nearest[last] {
            nearest[last] = d;
            nearest[..=last].sort_by(f64::total_cmp);
        }
    }
    nearest[last]
}

/// Whether a body of `length` × `width` m driven by `t` for `HORIZON` seconds comes nearer
/// the robot-frame returns `points` than `MARGIN` (its `clearance` by the
/// `HITS_TO_BLOCK`-th nearest return: one or two may be range noise), or, already that
/// near, nearer than it is now: a robot beside a wall may drive along it, not turn into it.
pub fn sweep_touches(points: &[DVec2], length: f64, width: f64, t: Twist) -> bool {
    sweep_touches_by(points, length, width, t, HITS_TO_BLOCK, MARGIN)
}

/// [`sweep_touches`] with the clearance taken at the `hits`-th nearest return, touching
/// nearer than `margin` m.
fn sweep_touches_by(
    points: &[DVec2],
    length: f64,
    width: f64,
    t: Twist,
    hits: usize,
    margin: f64,
) -> bool {
    if t.v == 0.0 && t.omega == 0.0 {
        return false;
    }
    let reach = 0.5 * length.hypot(width) + t.v.abs() * HORIZON + margin;
    let near: Vec<DVec2> = points
        .iter()
        .copied()
        .filter(|q| q.length() <= reach)
        .collect();
    let floor = margin.min(clearance(&near, &Pose::default(), length, width, hits) - NEARER);
    let n = ((t.v.abs() * HORIZON / SWEEP_STEP.0).max(t.omega.abs() * HORIZON / SWEEP_STEP.1))
        .ceil()
        .max(1.0) as usize;
    (1..=n).any(|k| {
        let pose = integrate(&Pose::default(), t, HORIZON * k as f64 / n as f64);
        clearance(&near, &pose, length, width, hits) < floor
    })
}

/// Checks the (limited) command `t` of a robot `vehicle` among the robot-frame returns
/// `points`: free, or a free part of it (straight on, or the turn on the spot), or stop.
///
/// A part must be free of all returns but one (a stray), not of all but two: it is a move
/// the behaviour did not choose, made where its own already touches. Counting past two
/// returns, the straight part of an arc turning into a wall's end was free while the end's
/// corner lay in its way, seen by the two returns nearest it (the rest of the end face falls
/// away from the body's side), and the robot bumped.
pub fn guard(points: &[DVec2], vehicle: &VehicleSpec, t: Twist) -> Guarded {
    guard_by(points, vehicle, t, MARGIN)
}

/// [`guard`] on a noisy sensor's denoised returns ([`super::Bumpers::steady_clearance`]),
/// touching nearer than `STEADY_MARGIN` (2.5 cm; module docs). Only for a robot the raw
/// returns have stalled: with every command judged on these, the laser robot turned and
/// squeezed through ways narrower than its turning circle that the raw returns had kept it
/// out of (`nav/door-narrow`, `nav/crates-squeeze` reached where the trials say `no_path`).
pub fn guard_steady(points: &[DVec2], vehicle: &VehicleSpec, t: Twist) -> Guarded {
    guard_by(points, vehicle, t, STEADY_MARGIN)
}

/// [`guard`] touching nearer than `margin` m.
fn guard_by(points: &[DVec2], vehicle: &VehicleSpec, t: Twist, margin: f64) -> Guarded {
    let (length, width) = (vehicle.length, vehicle.width);
    if !sweep_touches_by(points, length, width, t, HITS_TO_BLOCK, margin) {
        return Guarded::Free;
    }
    let touches = |t: Twist| sweep_touches_by(points, length, width, t, PART_HITS, margin);
    let straight = Twist { omega: 0.0, ..t };
    let turn = Twist { v: 0.0, ..t };
    if t.v != 0.0 && t.omega != 0.0 && !touches(straight) {
        Guarded::Replaced(straight)
    } else if t.v != 0.0 && t.omega.abs() >= MIN_TURN && !touches(turn) {
        Guarded::Replaced(turn)
    } else {
        Guarded::Stop
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: f64 = 0.6;
    const W: f64 = 0.5;

    /// Points every 5 mm along the segment from `a` to `b`.
    fn edge(a: DVec2, b: DVec2) -> Vec<DVec2> {
        let n = ((b - a).length() / 0.005).ceil() as usize;
        (0..=n)
            .map(|k| a + (b - a) * (k as f64 / n as f64))
            .collect()
    }

    fn twist(v: f64, omega: f64) -> Twist {
        Twist { v, omega }
    }

    #[test]
    fn a_wall_ahead_stops_a_move_toward_it_once_the_move_would_reach_it() {
        // A wall across the way, 0.1 m ahead of the front face.
        let wall = edge(DVec2::new(0.4, -1.0), DVec2::new(0.4, 1.0));
        // 0.3 s at 0.4 m/s covers 0.12 m: it would touch; at 0.2 m/s (6 cm) it would not.
        assert!(sweep_touches(&wall, L, W, twist(0.4, 0.0)));
        assert!(!sweep_touches(&wall, L, W, twist(0.2, 0.0)));
        // Backing away, or turning on the spot (the corners sweep a 0.39 m circle), is free.
        assert!(!sweep_touches(&wall, L, W, twist(-0.4, 0.0)));
        assert!(!sweep_touches(&wall, L, W, twist(0.0, 0.8)));
    }

    #[test]
    fn driving_along_a_wall_beside_the_body_is_free_and_turning_into_it_is_not() {
        // A wall on the right, 5 mm from the body's side.
        let wall = edge(DVec2::new(-2.0, -0.255), DVec2::new(2.0, -0.255));
        assert!(!sweep_touches(&wall, L, W, twist(0.4, 0.0)));
        assert!(!sweep_touches(&wall, L, W, twist(-0.4, 0.0)));
        // Turning either way swings a corner into it.
        assert!(sweep_touches(&wall, L, W, twist(0.0, 0.8)));
        assert!(sweep_touches(&wall, L, W, twist(0.0, -0.8)));
    }

    #[test]
    fn an_arc_that_swings_the_rear_into_a_corner_goes_straight_on_instead() {
        // A corner 2 cm to the right of the body's side, behind its middle: turning left on
        // the move swings the rear right into it, straight on passes it.
        let v = crate::vehicle::vehicle("p3at").expect("p3at");
        let (l, w) = (v.length, v.width);
        let side = -(w / 2.0 + 0.02);
        let corner = [
            edge(DVec2::new(-0.1, side), DVec2::new(-0.1, side - 0.7)),
            edge(DVec2::new(-0.1, side), DVec2::new(-1.0, side)),
        ]
        .concat();
        assert!(sweep_touches(&corner, l, w, twist(0.24, 0.32)));
        assert_eq!(
            guard(&corner, v, twist(0.24, 0.32)),
            Guarded::Replaced(twist(0.24, 0.0))
        );
        // Nothing near: free. Boxed in on every side: stop.
        assert_eq!(guard(&[], v, twist(0.24, 0.32)), Guarded::Free);
        let (hl, hw) = (l / 2.0 + 0.005, w / 2.0 + 0.005);
        let boxed = [
            edge(DVec2::new(-hl, -hw), DVec2::new(hl, -hw)),
            edge(DVec2::new(hl, -hw), DVec2::new(hl, hw)),
            edge(DVec2::new(hl, hw), DVec2::new(-hl, hw)),
            edge(DVec2::new(-hl, hw), DVec2::new(-hl, -hw)),
        ]
        .concat();
        assert_eq!(guard(&boxed, v, twist(0.24, 0.32)), Guarded::Stop);
        assert_eq!(guard(&boxed, v, twist(0.0, 0.8)), Guarded::Stop);
    }

    #[test]
    fn a_wall_already_inside_the_body_still_stops_a_turn_that_goes_deeper() {
        // A wall on the left beside the rear half, its returns 1 cm inside the body's side
        // (range noise, or a remembered return a little off). A right turn on the spot
        // swings the rear corner further in: it touches. A left turn swings it out, and
        // backing or driving along the wall keeps it as deep: both free. With every return
        // inside the body counted 0 m away, the right turn was free as well.
        let wall = edge(
            DVec2::new(-2.0, W / 2.0 - 0.01),
            DVec2::new(-0.05, W / 2.0 - 0.01),
        );
        assert!(body_distance(DVec2::new(-0.2, W / 2.0 - 0.01), L, W) < 0.0);
        assert!(sweep_touches(&wall, L, W, twist(0.0, -0.8)));
        assert!(!sweep_touches(&wall, L, W, twist(0.0, 0.8)));
        assert!(!sweep_touches(&wall, L, W, twist(-0.2, 0.0)));
        assert!(!sweep_touches(&wall, L, W, twist(0.2, 0.0)));
    }

    #[test]
    fn the_straight_part_of_an_arc_into_a_wall_end_is_no_way_past_its_corner() {
        // A thin wall's end ahead on the right, as the radar saw it in a random map where the
        // robot bumped: its corner 1 mm inside the line of the body's right side, 3 cm ahead
        // of the front face, its end face falling away back-left and its long face
        // back-right, returns 9 mm apart on the end face (1° at 0.5 m) and 2.5 cm apart on
        // the long face (seen at a grazing angle). Driving straight, only the two returns
        // nearest the corner come within the margin of the body; the arc turning right into
        // the wall touches by every count.
        let v = crate::vehicle::vehicle("p3at").expect("p3at");
        let (l, w) = (v.length, v.width);
        let corner = DVec2::new(l / 2.0 + 0.03, -(w / 2.0 - 0.001));
        let end_face = DVec2::new(-0.51, -0.86).normalize();
        let long_face = DVec2::new(0.877, -0.481).normalize();
        let wall: Vec<DVec2> = (0..30)
            .flat_map(|k| {
                let s = 0.009 * f64::from(k);
                [
                    corner + end_face * s,
                    corner + long_face * 0.025 * f64::from(k + 1),
                ]
            })
            .collect();
        let (arc, straight) = (twist(0.4, -0.167), twist(0.4, 0.0));
        assert!(sweep_touches(&wall, l, w, arc));
        // By all but two returns, the straight part looks free...
        assert!(!sweep_touches(&wall, l, w, straight));
        // ...but the guard does not take it, nor any part: the robot stops.
        assert_eq!(guard(&wall, v, arc), Guarded::Stop);
        // With the wall's end 2 cm clear of the body's side, driving straight past it is free.
        let clear: Vec<DVec2> = wall.iter().map(|q| *q - DVec2::new(0.0, 0.02)).collect();
        assert_eq!(guard(&clear, v, straight), Guarded::Free);
    }

    #[test]
    fn a_single_stray_return_does_not_stop_the_robot() {
        let stray = [DVec2::new(0.35, 0.0)];
        assert!(!sweep_touches(&stray, L, W, twist(0.4, 0.0)));
    }
}
