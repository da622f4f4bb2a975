//! The per-scan ray query (DESIGN §11): candidate lists for rays that all leave one point.
//!
//! A scan without side beams casts hundreds of rays from one origin. Rather than walk the grid
//! once per ray, the scan computes once, for every part within range, the sector of bearings
//! it covers seen from the origin and a lower bound of its distance, and files it in azimuth
//! sectors, nearest first. A ray then tests the parts of its sector in that order: when the
//! next part's lower bound lies beyond an interval already found, that interval is final, just
//! as the grid walk's cell exit makes it final ([`super::OrderedIntervals`]). In a room of a
//! few dozen parts a laser ray tests one or two parts and walks no cells.

use std::f64::consts::{PI, TAU};

use glam::{DVec2, DVec3};

use super::shape::Shape;
use super::{Part, World};

/// Angular margin added to every part's span, radians: far above the rounding of a bearing,
/// so that a ray on a sector boundary still finds every part it can meet.
const SPAN_PAD: f64 = 1e-7;
/// Grid entries allowed per part while counting the parts in range: a part meets a few cells.
const PART_REPEATS: usize = 8;

/// Candidate parts per azimuth sector, for rays from one origin ([`World::fan`]).
#[derive(Clone, Debug, Default)]
pub struct Fan {
    origin: DVec3,
    /// Sectors per radian.
    per_radian: f64,
    sectors: usize,
    /// Candidates of sector `s` are `items[starts[s]..starts[s + 1]]`: (lower bound of the
    /// ray parameter where it can be met, part), nearest first.
    starts: Vec<u32>,
    items: Vec<(f64, u32)>,
    /// Scratch: (lower bound, first sector, last sector unwrapped, part), nearest first.
    spans: Vec<(f64, i64, i64, u32)>,
    /// Scratch: the parts in range.
    ids: Vec<u32>,
}

impl Fan {
    /// The origin every ray of this fan must start from.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The candidates, nearest first, of a ray whose direction has bearing `heading` (radians,
    /// any turn).
    pub(crate) fn candidates(&self, heading: f64) -> &[(f64, u32)] {
        let s = sector_of(heading, self.per_radian, self.sectors);
        &self.items[self.starts[s] as usize..self.starts[s + 1] as usize]
    }
}

/// The sector of bearing `a` (`sectors` is a power of two); the same formula files the
/// parts' spans.
fn sector_of(a: f64, per_radian: f64, sectors: usize) -> usize {
    sector_index(super::floor_i64(a * per_radian), sectors)
}

/// Sector `s` of the unwrapped sector numbers, `sectors` a power of two.
fn sector_index(s: i64, sectors: usize) -> usize {
    (s & (sectors as i64 - 1)) as usize
}

/// The smallest arc `(from, to)` of bearings, radians, that holds every point of `corners`
/// seen from `o`; `None` when no arc under half a turn does (`o` inside or on their hull).
fn covering_arc(o: DVec2, corners: &[DVec2]) -> Option<(f64, f64)> {
    let base = corners[0] - o;
    let b0 = base.y.atan2(base.x);
    // Bearings relative to the first corner, in (-π, π]; the arc is their min..max when it is
    // under half a turn.
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for c in &corners[1..] {
        let v = *c - o;
        let rel = (v.y.atan2(v.x) - b0 + PI).rem_euclid(TAU) - PI;
        lo = lo.min(rel);
        hi = hi.max(rel);
    }
    (hi - lo < PI - 1e-6).then_some((b0 + lo, b0 + hi))
}

impl World {
    /// Fills `fan` with the candidates of rays from `origin` up to `t_max`, in about `sectors`
    /// azimuth sectors (the next power of two); `false` (and `fan` unusable) when more than
    /// `max_parts` parts lie in range, where the grid walk costs less than building the lists.
    pub fn fan(
        &self,
        origin: DVec3,
        t_max: f64,
        sectors: usize,
        max_parts: usize,
        fan: &mut Fan,
    ) -> bool {
        let sectors = sectors.clamp(1, 1 << 20).next_power_of_two();
        fan.origin = origin;
        fan.sectors = sectors;
        fan.per_radian = sectors as f64 / TAU;
        fan.spans.clear();
        let o = origin.truncate();
        if !(o.is_finite() && t_max >= 0.0) {
            return false;
        }
        let reach = DVec2::splat(t_max.min(1e12));
        // One pass over the cells in range. In a large world it stops early: a part is listed
        // once per cell it meets, so this many entries mean too many parts.
        let limit = if self.parts.len() > max_parts {
            max_parts.saturating_mul(PART_REPEATS).saturating_add(1)
        } else {
            usize::MAX
        };
        fan.ids.clear();
        fan.ids
            .extend(self.grid.in_rect(o - reach, o + reach).take(limit));
        if fan.ids.len() >= limit {
            return false;
        }
        fan.ids.sort_unstable();
        fan.ids.dedup();
        if fan.ids.len() > max_parts {
            return false;
        }
        let pad = self.grid.pad();
        for &p in &fan.ids {
            let (lo, hi) = self.part_rects[p as usize];
            let (lo, hi) = (lo - pad, hi + pad);
            // The ray's ground track reaches distance ρ from the origin at t ≥ ρ.
            let lower = (lo - o).max(o - hi).max(DVec2::ZERO).length();
            if lower > t_max {
                continue;
            }
            let Part {
                object, segment, ..
            } = self.parts[p as usize];
            let arc = match &self.objects[object as usize].shape {
                Shape::Sphere { center, radius } | Shape::Cylinder { center, radius, .. } => {
                    let v = center.truncate() - o;
                    let (d, r) = (v.length(), radius + pad);
                    (d > r).then(|| {
                        let (b, half) = (v.y.atan2(v.x), (r / d).asin());
                        (b - half, b + half)
                    })
                }
                Shape::Box(b) => covering_arc(o, &b.corners(pad)),
                Shape::Wall { segments, .. } => {
                    covering_arc(o, &segments[segment as usize].corners(pad))
                }
                Shape::Prism { .. } | Shape::Mesh(_) => {
                    covering_arc(o, &[lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)])
                }
            };
            let (first, last) = match arc {
                Some((a, b)) => (
                    ((a - SPAN_PAD) * fan.per_radian).floor() as i64,
                    ((b + SPAN_PAD) * fan.per_radian).floor() as i64,
                ),
                None => (0, sectors as i64 - 1),
            };
            let last = last.min(first + sectors as i64 - 1);
            fan.spans.push((lower, first, last, p));
        }
        fan.spans
            .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.3.cmp(&b.3)));
        // Counting sort into the sectors keeps each sector's list nearest first.
        fan.starts.clear();
        fan.starts.resize(sectors + 1, 0);
        for &(_, first, last, _) in &fan.spans {
            for s in first..=last {
                fan.starts[sector_index(s, sectors) + 1] += 1;
            }
        }
        for s in 0..sectors {
            fan.starts[s + 1] += fan.starts[s];
        }
        fan.items.clear();
        fan.items.resize(fan.starts[sectors] as usize, (0.0, 0));
        let mut cursor = fan.starts[..sectors].to_vec();
        for &(lower, first, last, p) in &fan.spans {
            for s in first..=last {
                let s = sector_index(s, sectors);
                fan.items[cursor[s] as usize] = (lower, p);
                cursor[s] += 1;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covering_arc_of_a_square_seen_from_outside_and_inside() {
        let sq = [
            DVec2::new(1.0, -1.0),
            DVec2::new(3.0, -1.0),
            DVec2::new(3.0, 1.0),
            DVec2::new(1.0, 1.0),
        ];
        let (a, b) = covering_arc(DVec2::ZERO, &sq).unwrap();
        assert!(
            (a + FRAC_PI_4).abs() < 1e-12 && (b - FRAC_PI_4).abs() < 1e-12,
            "{a} {b}"
        );
        // Across the ±π seam: the same square behind the origin.
        let behind: Vec<DVec2> = sq.iter().map(|c| -*c).collect();
        let (a, b) = covering_arc(DVec2::ZERO, &behind).unwrap();
        assert!((b - a - FRAC_PI_2).abs() < 1e-12, "{a} {b}");
        assert!(covering_arc(DVec2::new(2.0, 0.0), &sq).is_none());
    }

    #[test]
    fn a_fan_is_refused_only_when_more_parts_than_allowed_are_in_range() {
        let w = crate::world::forest::forest(400, 60.0, 3);
        let o = DVec3::new(0.0, 0.0, 0.4);
        let mut fan = Fan::default();
        // The whole forest is within 100 m: 400 parts.
        assert!(!w.fan(o, 100.0, 64, 399, &mut fan));
        assert!(w.fan(o, 100.0, 64, 400, &mut fan));
        // Within 3 m of the clearing's centre only a few spheres can be.
        assert!(w.fan(o, 3.0, 64, 20, &mut fan));
    }

    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
}
