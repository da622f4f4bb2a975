//! Passing a gap narrower than twice the follow radius (DESIGN §6): a doorway, the way
//! between a hedge's end and a room wall, a corridor.
//!
//! The thesis' wall follower keeps one distance from the wall it follows and rounds convex
//! corners on a circle of that distance. Where the next obstacle is nearer than twice that
//! distance, the circle runs into it: the follower turns away and takes up the neighbour's
//! boundary (or circles the corner for ever), and a doorway narrower than twice the standoff
//! is never passed. A robot's body needs much less: its width plus a margin.
//!
//! [`find_gap`] looks for such a gap on the followed side in the robot's returns: the returns
//! within a look radius, taken in angle order from behind on the wall side, fall into
//! *segments* wherever two neighbours lie farther apart than the body can pass; the segment
//! holding the nearest return on the wall side is the followed boundary, the next one round
//! is its neighbour, and the gap is the closest pair of returns between the two. A gap at
//! least the robot's turning diameter (twice its half-diagonal, so it can turn inside it) and
//! narrower than twice the follow radius is passed by a [`Passage`]: go to a point in front
//! of the gap's middle, turn to face through it, and drive through on the line through its
//! middle, slowly, with the body's own clearance as the only check. The gap is held in the
//! world frame (the believed pose), so scans at a low rate do not leave it behind.

use glam::DVec2;

use crate::pose::{Pose, wrap_angle};

/// Extra clearance kept around the body while passing, m.
pub const BODY_MARGIN: f64 = 0.02;
/// Speed through a gap, m/s.
const PASS_SPEED: f64 = 0.2;
/// Speed toward the point in front of a gap, m/s.
const APPROACH_SPEED: f64 = 0.3;
/// Turn rate while passing, rad/s.
const PASS_TURN: f64 = 0.5;
/// Heading gain, (rad/s) per rad.
const K_HEADING: f64 = 2.0;
/// Distance of the approach point in front of the gap beyond the body's half-length, m.
const APPROACH_OFFSET: f64 = 0.4;
/// Close enough to the approach point, m.
const AT_APPROACH: f64 = 0.1;
/// Facing through the gap within this, rad.
const ALIGNED: f64 = 0.03;
/// Look-ahead along the line through the gap, m.
const LOOK_AHEAD: f64 = 0.5;
/// Give up on a gap after this long, s.
const PASS_TIMEOUT: f64 = 60.0;
/// A sighting whose normal is within this cosine of the held one is the same gap (10°).
const REFINE_COS: f64 = 0.985;
/// Speed backing out of a gap when neither driving on nor turning is clear, m/s.
const BACK_SPEED: f64 = 0.1;
/// Returns inside the body's swept zone that block a move (one may be range noise).
const HITS_TO_BLOCK: usize = 3;
/// Points across a gap checked for being seen open (the pair's ends excluded).
const GAP_SAMPLES: usize = 6;
/// A return within this angle of a point hides it, rad (1°, a radar's ray spacing).
const SEEN_WITHIN: f64 = 0.0175;

/// A gap between the followed boundary and its neighbour, in some frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    /// Middle of the narrowest pair of returns across the gap.
    pub mid: DVec2,
    /// Unit normal through the gap, pointing away from the robot (forward when it is in it).
    pub normal: DVec2,
    /// Width between the narrowest pair, m.
    pub width: f64,
}

impl Gap {
    /// This robot-frame gap in the frame the robot's `pose` is given in (the world).
    pub fn in_frame(&self, pose: &Pose) -> Gap {
        let r = DVec2::from_angle(pose.yaw);
        Gap {
            mid: pose.xy() + r.rotate(self.mid),
            normal: r.rotate(self.normal),
            width: self.width,
        }
    }
}

/// The gap on the followed side among robot-frame `points` (see the module docs): `side` is
/// +1 with the boundary on the left, −1 on the right; returns beyond `look` are ignored, the
/// followed boundary must come within `near`, and the gap's width must lie in
/// `[min_width, max_width)`.
pub fn find_gap(
    points: &[DVec2],
    side: f64,
    look: f64,
    near: f64,
    min_width: f64,
    max_width: f64,
) -> Option<Gap> {
    // Mirror so the boundary is on the right; angles then run from behind it forward. The
    // segments are made of every return, near or far: cutting them at the look radius would
    // open gaps that are not there (a concave corner just beyond it).
    let flip = DVec2::new(1.0, -side.signum());
    let mut q: Vec<(f64, DVec2)> = points
        .iter()
        .map(|p| {
            let m = *p * flip;
            (m.y.atan2(m.x), m)
        })
        .collect();
    q.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut starts = vec![0];
    for i in 1..q.len() {
        if (q[i].1 - q[i - 1].1).length() > min_width {
            starts.push(i);
        }
    }
    starts.push(q.len());
    let nearest = (0..q.len())
        .filter(|&i| q[i].0 <= 0.0)
        .min_by(|&i, &j| q[i].1.length().total_cmp(&q[j].1.length()))?;
    if q[nearest].1.length() > near {
        return None;
    }
    let seg = starts
        .windows(2)
        .position(|w| w[0] <= nearest && nearest < w[1])?;
    let segment = |k: usize| &q[starts[k]..starts[k + 1]];
    // The neighbour is the next segment round that comes within the look radius; those
    // beyond it are seen through the gap.
    let next =
        (seg + 1..starts.len() - 1).find(|&k| segment(k).iter().any(|x| x.1.length() <= look))?;
    // The narrowest pair lies within the look radius (its middle must).
    let within = |s: &[(f64, DVec2)]| -> Vec<DVec2> {
        s.iter()
            .map(|x| x.1)
            .filter(|p| p.length() <= look + max_width)
            .collect()
    };
    let a = within(segment(seg));
    let b = within(segment(next));
    let (mut best, mut pair) = (f64::INFINITY, (DVec2::ZERO, DVec2::ZERO));
    for pa in &a {
        for pb in &b {
            let d = (*pa - *pb).length_squared();
            if d < best {
                best = d;
                pair = (*pa, *pb);
            }
        }
    }
    let width = best.sqrt();
    if !(min_width..max_width).contains(&width) {
        return None;
    }
    // The gap must be seen open: no return short of points across it. A jump in range
    // between two neighbouring returns is also where a near object hides a far one (the
    // spheres of a hedge seen end-on), and hidden space is no way through.
    for k in 1..GAP_SAMPLES {
        let c = pair.0 + (pair.1 - pair.0) * (k as f64 / GAP_SAMPLES as f64);
        let (dir, dist) = (c.y.atan2(c.x), c.length());
        if q.iter()
            .any(|(a, p)| wrap_angle(a - dir).abs() < SEEN_WITHIN && p.length() < dist)
        {
            return None;
        }
    }
    let mid = (pair.0 + pair.1) / 2.0;
    let across = (pair.1 - pair.0) / width;
    let mut normal = across.perp();
    // Away from the robot; for a gap beside it (a corridor), forward.
    if normal.dot(mid + DVec2::new(0.3, 0.0)) < 0.0 {
        normal = -normal;
    }
    // Only gaps within the look radius, ahead or on the followed side, passed the way that
    // keeps the followed boundary on its side (not back through a gap just passed).
    let angle = mid.y.atan2(mid.x);
    if mid.length() > look
        || mid.x < -0.3
        || !(-2.3..=1.6).contains(&angle)
        || normal.perp_dot(pair.0 - mid) > 0.0
    {
        return None;
    }
    Some(Gap {
        mid: mid * flip,
        normal: normal * flip,
        width,
    })
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Approach,
    Align,
    Pass,
}

/// Driving through one gap (see the module docs).
#[derive(Clone, Debug)]
pub struct Passage {
    gap: Gap,
    phase: Phase,
    time: f64,
}

/// What a passage step asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassStep {
    /// Drive at `v` m/s turning at `omega` rad/s.
    Drive(f64, f64),
    /// Through the gap.
    Done,
    /// The body's clearance does not allow the move: give the gap up.
    Blocked,
}

impl Passage {
    /// A passage through the world-frame `gap`.
    pub fn new(gap: Gap) -> Self {
        Self {
            gap,
            phase: Phase::Approach,
            time: 0.0,
        }
    }

    /// The world-frame gap being passed.
    pub fn gap(&self) -> &Gap {
        &self.gap
    }

    /// Takes a newer sighting of the same gap (world frame), keeping its direction, until the
    /// robot has lined up with it: from then on the line through the gap stays put (the
    /// narrowest pair across a thick doorway may come from either of its ends).
    pub fn refine(&mut self, seen: &Gap) {
        let same = self.phase == Phase::Approach
            && (seen.mid - self.gap.mid).length() < 0.3
            && seen.normal.dot(self.gap.normal).abs() > REFINE_COS;
        if same {
            let normal = if seen.normal.dot(self.gap.normal) < 0.0 {
                -seen.normal
            } else {
                seen.normal
            };
            self.gap = Gap { normal, ..*seen };
        }
    }

    /// The next move from the believed `pose` with the latest robot-frame returns `points`,
    /// for a body of `length` × `width` m.
    pub fn step(
        &mut self,
        pose: &Pose,
        points: &[DVec2],
        length: f64,
        width: f64,
        dt: f64,
    ) -> PassStep {
        self.time += dt;
        if self.time > PASS_TIMEOUT {
            return PassStep::Blocked;
        }
        let g = &self.gap;
        let p = pose.xy();
        let t = (p - g.mid).dot(g.normal);
        let e = (p - g.mid).dot(g.normal.perp());
        let heading_to = |target: DVec2| wrap_angle((target - p).to_angle() - pose.yaw);
        let toward_normal = wrap_angle(g.normal.to_angle() - pose.yaw);
        let approach = length / 2.0 + APPROACH_OFFSET;
        if self.phase == Phase::Approach
            && t < -0.5 * approach
            && e.abs() < AT_APPROACH / 2.0
            && toward_normal.abs() < 0.2
        {
            self.phase = Phase::Pass;
        }
        let (v, omega) = match self.phase {
            Phase::Approach => {
                let a = g.mid - g.normal * approach;
                if (a - p).length() < AT_APPROACH {
                    self.phase = Phase::Align;
                    (0.0, 0.0)
                } else {
                    let err = heading_to(a);
                    if err.abs() > 0.35 {
                        (0.0, (K_HEADING * err).clamp(-PASS_TURN, PASS_TURN))
                    } else {
                        let v = (a - p).length().min(APPROACH_SPEED) * err.cos();
                        (v, (K_HEADING * err).clamp(-PASS_TURN, PASS_TURN))
                    }
                }
            }
            Phase::Align => {
                if toward_normal.abs() < ALIGNED {
                    self.phase = Phase::Pass;
                    (0.0, 0.0)
                } else {
                    (
                        0.0,
                        (K_HEADING * toward_normal).clamp(-PASS_TURN, PASS_TURN),
                    )
                }
            }
            Phase::Pass => {
                if t > length / 2.0 + 0.3 {
                    return PassStep::Done;
                }
                let err = heading_to(g.mid + g.normal * (t + LOOK_AHEAD));
                (
                    PASS_SPEED * err.cos().max(0.0),
                    (K_HEADING * err).clamp(-PASS_TURN, PASS_TURN),
                )
            }
        };
        // The body's clearance: ahead (0.15 m and more), behind, and for turning on the
        // spot. A real edge gives many returns, a noisy range a stray one: it takes
        // [`HITS_TO_BLOCK`] of them to block.
        let half = (length / 2.0, width / 2.0 + BODY_MARGIN);
        let clear = |inside: &dyn Fn(&DVec2) -> bool| {
            points.iter().filter(|q| inside(q)).count() < HITS_TO_BLOCK
        };
        let ahead_clear =
            clear(&|q| q.x <= half.0 + 0.15 && q.x >= -half.0 - BODY_MARGIN && q.y.abs() <= half.1);
        let behind_clear =
            clear(&|q| q.x >= -half.0 - 0.1 && q.x <= half.0 + BODY_MARGIN && q.y.abs() <= half.1);
        let turn_radius = 0.5 * length.hypot(width) + BODY_MARGIN;
        let turn_clear = clear(&|q| q.length() <= turn_radius);
        if v > 0.0 && !ahead_clear || v == 0.0 && omega != 0.0 && !turn_clear {
            // Straighten up on the spot if that is clear, else back out along the way in.
            if v > 0.0 && turn_clear && omega != 0.0 {
                return PassStep::Drive(0.0, omega);
            }
            if self.phase == Phase::Pass && behind_clear {
                return PassStep::Drive(-BACK_SPEED, 0.0);
            }
            return PassStep::Blocked;
        }
        PassStep::Drive(v, omega)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Returns every 1° seen from the origin of the robot frame of walls given as segments.
    fn scan(walls: &[(DVec2, DVec2)]) -> Vec<DVec2> {
        (0..360)
            .filter_map(|i| {
                let u = DVec2::from_angle((i as f64 - 180.0).to_radians());
                walls
                    .iter()
                    .filter_map(|&(a, b)| {
                        let d = b - a;
                        let den = u.perp_dot(d);
                        if den.abs() < 1e-12 {
                            return None;
                        }
                        let t = a.perp_dot(d) / den;
                        let s = a.perp_dot(u) / den;
                        (t > 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
                    })
                    .min_by(f64::total_cmp)
                    .map(|t| u * t)
            })
            .collect()
    }

    /// A wall along x at y = −1 (on the right) with a doorway of `w` m from x = 1.
    fn doorway(w: f64) -> Vec<(DVec2, DVec2)> {
        vec![
            (DVec2::new(-5.0, -1.0), DVec2::new(1.0, -1.0)),
            (DVec2::new(1.0 + w, -1.0), DVec2::new(8.0, -1.0)),
        ]
    }

    #[test]
    fn a_doorway_on_the_followed_side_is_found_and_oriented_through() {
        let pts = scan(&doorway(0.8));
        let g = find_gap(&pts, -1.0, 3.0, 1.5, 0.71, 3.0).expect("gap");
        assert!((g.width - 0.8).abs() < 0.05, "{g:?}");
        assert!((g.mid - DVec2::new(1.4, -1.0)).length() < 0.05, "{g:?}");
        assert!((g.normal - DVec2::new(0.0, -1.0)).length() < 1e-9, "{g:?}");
        // On the other side it is not the followed boundary's gap.
        assert_eq!(find_gap(&pts, 1.0, 3.0, 1.5, 0.71, 3.0), None);
        // Narrower than the robot can turn in, or wider than the follower's circle: none.
        assert_eq!(
            find_gap(&scan(&doorway(0.6)), -1.0, 3.0, 1.5, 0.71, 3.0),
            None
        );
        assert_eq!(find_gap(&pts, -1.0, 3.0, 1.5, 0.71, 0.75), None);
        // A straight wall has no gap.
        let wall = [(DVec2::new(-5.0, -1.0), DVec2::new(8.0, -1.0))];
        assert_eq!(find_gap(&scan(&wall), -1.0, 3.0, 1.5, 0.71, 3.0), None);
    }

    #[test]
    fn space_hidden_behind_a_nearer_return_is_no_gap() {
        // The followed wall steps back by 1 m where it ends: beyond its end the robot sees
        // the farther wall only past the shadow, and the jump between them hides no way.
        let walls = [
            (DVec2::new(-5.0, -1.0), DVec2::new(1.0, -1.0)),
            (DVec2::new(1.0, -2.0), DVec2::new(8.0, -2.0)),
        ];
        assert_eq!(find_gap(&scan(&walls), -1.0, 3.0, 1.5, 0.71, 3.0), None);
        // With a post 0.85 m past the end instead, seen through the open space, there is one.
        let post = [walls[0], (DVec2::new(1.85, -1.0), DVec2::new(1.85, -1.3))];
        let g = find_gap(&scan(&post), -1.0, 3.0, 1.5, 0.71, 3.0).expect("gap");
        assert!((g.width - 0.85).abs() < 0.05, "{g:?}");
    }

    #[test]
    fn a_passage_goes_through_a_doorway_without_touching_it() {
        // The robot follows the wall on its right, 0.9 m off, 1 m before the doorway.
        let walls = doorway(0.8);
        let (length, width) = (0.508, 0.497);
        let mut pose = Pose::default();
        let pts = scan(&walls);
        let g = find_gap(&pts, -1.0, 3.0, 1.5, 0.71, 3.0).expect("gap");
        let mut pass = Passage::new(g.in_frame(&pose));
        let dt = 0.05;
        let mut steps = 0;
        loop {
            // Returns in the robot frame from the current pose.
            let r = DVec2::from_angle(-pose.yaw);
            let local: Vec<(DVec2, DVec2)> = walls
                .iter()
                .map(|&(a, b)| (r.rotate(a - pose.xy()), r.rotate(b - pose.xy())))
                .collect();
            match pass.step(&pose, &scan(&local), length, width, dt) {
                PassStep::Drive(v, w) => {
                    pose.yaw += w * dt;
                    pose.x += v * dt * pose.yaw.cos();
                    pose.y += v * dt * pose.yaw.sin();
                }
                PassStep::Done => break,
                PassStep::Blocked => panic!("blocked at {pose:?}"),
            }
            // No point of the walls (every centimetre) inside the body.
            let r = DVec2::from_angle(-pose.yaw);
            for (a, b) in &walls {
                for i in 0..=((b - a).length() * 100.0) as usize {
                    let w = r.rotate(*a + (*b - *a).normalize() * (i as f64 / 100.0) - pose.xy());
                    assert!(
                        w.x.abs() > length / 2.0 || w.y.abs() > width / 2.0,
                        "wall point {w} inside the body at {pose:?}"
                    );
                }
            }
            steps += 1;
            assert!(steps < 2000, "no progress: {pose:?}");
        }
        assert!(pose.y < -1.4, "{pose:?}");
        assert!((pose.x - 1.4).abs() < 0.1, "{pose:?}");
    }
}
