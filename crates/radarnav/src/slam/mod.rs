//! Localisation without ground truth (DESIGN §10): each scan of one sensor is registered
//! against the map built from the scans before it, with the odometry as the motion prior.
//!
//! The method is Hector SLAM's (Kohlbrecher et al. 2011), as Cartographer's local SLAM refines
//! its matches: the scan's returns (a radar's first echoes, whether a solid stopped the ray or
//! its budget ran out in foliage; a laser's ranges) are moved by a candidate pose onto a
//! smoothed likelihood grid ([`likelihood`]), and Gauss–Newton finds the pose where they lie
//! on the most likely cells, coarse level first. The odometry's motion since the last scan
//! predicts the pose and stays in the cost as a weak prior, so a scan with nothing to hold on
//! to (a corridor's length, an empty field) leaves the odometry in charge of that direction.
//! A match that moves the prediction further than the odometry could have erred is refused.
//! The scan then goes into the map at the registered pose once the robot has moved far enough
//! from where the last one went in (a keyframe), so the map is not smeared by every scan.
//!
//! Between registrations the estimate follows the odometry: `estimate = anchor_slam ∘
//! anchor_odometry⁻¹ ∘ odometry`, so every consumer (a controller at 10 Hz, a mapper placing a
//! laser scan taken between two radar scans) gets a pose at any time.
//!
//! The keyframes form a pose graph ([`graph`]): each joined to the one before by the
//! registrations, and (with `loop_closure`) to an old keyframe whose submap the current scan
//! matches after a search wider than tracking's basin. A closure that disagrees with the
//! estimate has the graph solved and the map rebuilt from the keyframes at their new poses.

pub mod graph;
pub mod likelihood;

use glam::{DMat3, DVec2, DVec3};
use serde::Serialize;

use crate::pose::{Pose, wrap_angle};
use crate::sensor::{HitKind, Scan};
use graph::{Edge, PoseGraph};
use likelihood::Level;

/// How the localiser works.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SlamConfig {
    /// Index of the registered sensor in the robot's sensors.
    pub sensor: usize,
    /// Cell size of the finest likelihood level, m.
    pub resolution: f64,
    /// Likelihood levels, each twice as coarse as the one before.
    pub levels: usize,
    /// Returns farther than this are not used, m.
    pub max_range: f64,
    /// A scan goes into the map after the robot moved this far since the last one, m...
    pub keyframe_distance: f64,
    /// ...or turned this much, rad.
    pub keyframe_angle: f64,
    /// Whether keyframes are registered against old ones to close loops (default off; with
    /// feature `pose-graph`; without it the edges are kept but never solved).
    pub loop_closure: bool,
}

impl SlamConfig {
    /// The defaults for sensor `sensor`: Hector's 5 cm over three levels, keyframes every
    /// 0.5 m or 15° (inserting every scan thickens the map with each one's small error: on
    /// the foliage-wall loop, keyframes every 0.1 m put the radar map's obstacle precision
    /// 6 points below the true-pose map's, every 0.5 m 1–2 points).
    pub fn for_sensor(sensor: usize) -> Self {
        Self {
            sensor,
            resolution: 0.05,
            levels: 3,
            max_range: 30.0,
            keyframe_distance: 0.5,
            keyframe_angle: 15f64.to_radians(),
            // Off by default: in a long corridor, closures against keyframes further along it
            // match as well (the nav trials' l-corridor: 3 of 28 laser runs over the path
            // bound with them, none of 4 tried without); see `degenerate`.
            loop_closure: false,
        }
    }
}

/// Gauss–Newton iterations per level at most.
const ITERATIONS: usize = 8;
/// Scale of the Cauchy loss on a return's residual `1 - M`: returns whose likelihood is below
/// about 0.9 count less and less. The thesis radar's returns from inside foliage lie where its
/// budget ran out, which moves with the viewpoint; with plain least squares they drag the
/// pose by centimetres (7 cm RMS on the foliage-wall lap of the tests, 2.7 cm with this).
const ROBUST_SCALE: f64 = 0.1;
/// Times a step that raises the cost is halved before the level is left.
const HALVINGS: usize = 3;
/// Standard deviations of the odometry prior on one registration: position, m, and heading,
/// rad. Wide: the scan decides wherever it can.
const PRIOR_SIGMA: (f64, f64) = (0.25, 0.1);
/// Largest correction of the prediction a match may make, m and rad: beyond what the odometry
/// can err between two scans, a match is a wrong one.
const MAX_CORRECTION: (f64, f64) = (0.5, 0.25);
/// Fewest returns a scan needs to be registered.
const MIN_POINTS: usize = 12;
/// Returns closer together than this fraction of the finest cell are merged (a laser's
/// 1080 returns on a near wall are a few dozen distinct cells).
const POINT_SPACING: f64 = 1.0;
/// Neighbouring returns up to this many beam steps apart (at the farther one's range) are
/// taken as one surface.
const JOIN_STEPS: f64 = 2.5;
/// Scan planes steeper than this are not registered: the localiser is planar, m/m.
const MAX_ELEVATION_SIN: f64 = 0.09;

/// Standard deviations of a registration between two keyframes: m and rad.
const EDGE_SIGMA: (f64, f64) = (0.03, 0.01);
/// Standard deviations of an edge across a refused scan, m and rad: the odometry's error over
/// a keyframe's distance, generously (a wheel slip included).
const ODOMETRY_EDGE_SIGMA: (f64, f64) = (0.5, 0.1);
/// A loop closure is looked for every this many keyframes (about 4 m)...
const LOOP_EVERY: usize = 8;
/// ...against keyframes at least this many older (about 15 m of path)...
const LOOP_GAP: usize = 30;
/// ...and at most this far from it, m.
const LOOP_RADIUS: f64 = 4.0;
/// Keyframes either side of the old one that make its submap.
const SUBMAP_KEYFRAMES: usize = 3;
/// Search window of a loop closure around the current estimate: m either way, rad either way.
const LOOP_WINDOW: (f64, f64) = (0.8, 0.14);
/// Heading step of the search, rad (2°; the coarse level's Gauss–Newton takes it from there,
/// as it takes the coarse cell).
const LOOP_ANGLE_STEP: f64 = 0.035;
/// Mean likelihood of the returns on the old submap that a loop closure needs.
const LOOP_MIN_SCORE: f64 = 0.75;
/// A loop closure's returns must constrain the position in its weakest direction at least this
/// fraction as much as in its strongest (the eigenvalues of the normal matrix's position block).
const LOOP_MIN_CONSTRAINT: f64 = 0.2;
/// A loop closure further than this from the estimate (m, rad) makes the graph be solved.
const SOLVE_BEYOND: (f64, f64) = (0.05, 0.01);

/// A scan put into the map, in the robot frame: its returns that join no neighbour, and the
/// surfaces joining the others.
#[derive(Clone, Debug)]
struct Keyframe {
    points: Vec<DVec2>,
    segments: Vec<(DVec2, DVec2)>,
}

/// The localiser's counters, for `summary.json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SlamStats {
    /// Scans registered.
    pub registered: u64,
    /// Scans whose match was refused (too few returns, or a correction too large).
    pub refused: u64,
    /// Scans put into the map.
    pub keyframes: u64,
    /// Keyframes registered against an old part of the map for a loop closure.
    pub loop_searches: u64,
    /// Loop closures accepted (edges added to the pose graph).
    pub loop_closures: u64,
    /// Times the pose graph was solved (and the map rebuilt).
    pub graph_solves: u64,
    /// Mean likelihood of the registered scans' returns at their final poses.
    pub mean_score: f64,
}

/// Registers one sensor's scans into a pose estimate (see the module doc).
#[derive(Clone, Debug)]
pub struct Localiser {
    config: SlamConfig,
    /// The registered sensor's mount on the robot.
    mount: Pose,
    levels: Vec<Level>,
    /// The last registered pose and the odometry at its time.
    anchor: (Pose, Pose),
    /// Where the last keyframe went in; `None` before the first.
    last_keyframe: Option<Pose>,
    /// Every keyframe's returns (robot frame), in the graph's node order.
    keyframes: Vec<Keyframe>,
    /// The keyframes' poses and the registrations between them.
    graph: PoseGraph,
    /// Keyframes since the last loop closure.
    since_closure: usize,
    /// Whether a scan since the last keyframe went unregistered (the odometry alone moved
    /// the estimate).
    unregistered: bool,
    /// The current scan's returns in the robot frame.
    points: Vec<DVec2>,
    /// Neighbouring returns of the current scan, joined (robot frame).
    segments: Vec<(DVec2, DVec2)>,
    stats: SlamStats,
    score_sum: f64,
}

impl Localiser {
    /// A localiser for a robot starting at `start` (where its odometry starts too), its sensor
    /// mounted at `mount`.
    pub fn new(config: SlamConfig, mount: Pose, start: Pose) -> Self {
        let mut me = Self {
            config,
            mount,
            levels: Vec::new(),
            anchor: (start, start),
            last_keyframe: None,
            keyframes: Vec::new(),
            graph: PoseGraph::default(),
            since_closure: 0,
            unregistered: false,
            points: Vec::new(),
            segments: Vec::new(),
            stats: SlamStats::default(),
            score_sum: 0.0,
        };
        me.levels = me.new_levels(start.xy());
        me
    }

    /// The settings.
    pub fn config(&self) -> &SlamConfig {
        &self.config
    }

    /// The estimated robot pose for an odometry reading taken since the last registration.
    pub fn estimate(&self, odometry: &Pose) -> Pose {
        let moved = self.anchor.1.inverse().compose(odometry);
        let p = self.anchor.0.compose(&moved);
        Pose { z: 0.0, ..p }
    }

    /// What the localiser did so far.
    pub fn stats(&self) -> SlamStats {
        SlamStats {
            mean_score: if self.stats.registered > 0 {
                self.score_sum / self.stats.registered as f64
            } else {
                0.0
            },
            ..self.stats
        }
    }

    /// Registers `scan` (of the configured sensor), taken where the odometry says `odometry`;
    /// returns the estimated robot pose at the scan's time.
    pub fn register(&mut self, scan: &Scan, odometry: &Pose) -> Pose {
        let predicted = self.estimate(odometry);
        self.collect_points(scan);
        let pose = if self.points.len() < MIN_POINTS {
            self.stats.refused += 1;
            self.unregistered = true;
            predicted
        } else if self.last_keyframe.is_none() {
            // The first scan makes the map: the start pose is the frame.
            predicted
        } else {
            let (pose, score) = self.match_scan(&self.levels, &predicted);
            let d = pose.xy() - predicted.xy();
            if d.length() > MAX_CORRECTION.0
                || wrap_angle(pose.yaw - predicted.yaw).abs() > MAX_CORRECTION.1
            {
                self.stats.refused += 1;
                self.unregistered = true;
                predicted
            } else {
                self.stats.registered += 1;
                self.score_sum += score;
                pose
            }
        };
        self.anchor = (pose, *odometry);
        let due = self.last_keyframe.is_none_or(|k| {
            (pose.xy() - k.xy()).length() >= self.config.keyframe_distance
                || wrap_angle(pose.yaw - k.yaw).abs() >= self.config.keyframe_angle
        });
        if due && self.points.len() >= MIN_POINTS {
            self.add_keyframe(pose);
        }
        // A loop closure may have moved the estimate since.
        self.anchor.0
    }

    /// The scan's usable returns in the robot frame, thinned to about one per finest cell.
    fn collect_points(&mut self, scan: &Scan) {
        self.points.clear();
        self.segments.clear();
        let spacing = self.config.resolution * POINT_SPACING;
        let mut last: Option<DVec2> = None;
        // The previous ray's return, if it had one: (point, range).
        let mut previous: Option<(DVec2, f64)> = None;
        let step = scan.angle_increment.abs();
        for i in 0..scan.len() {
            let r = f64::from(scan.ranges[i]);
            if scan.hits[i] == HitKind::None || !r.is_finite() || r > self.config.max_range {
                previous = None;
                continue;
            }
            let (az, el) = scan.angles(i);
            if el.sin().abs() > MAX_ELEVATION_SIN || i % scan.azimuths == 0 {
                previous = None;
            }
            if el.sin().abs() > MAX_ELEVATION_SIN {
                continue;
            }
            // The reading in the sensor frame (a side beam's origin is offset to its left).
            let (s, c) = az.sin_cos();
            let lateral = scan.beams[i].side() * scan.side_beam_offset;
            let reach = r * el.cos();
            let sensor = Pose::new(-s * lateral + c * reach, c * lateral + s * reach, 0.0, 0.0);
            let p = self.mount.compose(&sensor).xy();
            // Neighbouring returns on one surface are joined for the map: a wall 10 m away
            // is a return every 17 cm at 1°, and a line of dots would hold a scan by its gaps.
            // Returns farther apart than a few beam steps are across a depth jump.
            if let Some((q, rq)) = previous {
                let gap = (p - q).length();
                if gap <= JOIN_STEPS * step * r.max(rq) + self.config.resolution {
                    self.segments.push((q, p));
                }
            }
            previous = Some((p, r));
            if last.is_some_and(|q| (p - q).length() < spacing) {
                continue;
            }
            last = Some(p);
            self.points.push(p);
        }
    }

    /// Puts a keyframe's returns, and the surfaces joining neighbours, into every level at
    /// `pose`.
    fn insert(levels: &mut [Level], keyframe: &Keyframe, pose: &Pose) {
        let (s, c) = pose.yaw.sin_cos();
        let world = |p: DVec2| DVec2::new(pose.x + c * p.x - s * p.y, pose.y + s * p.x + c * p.y);
        for level in levels {
            for p in &keyframe.points {
                level.insert(world(*p), world(*p));
            }
            for &(a, b) in &keyframe.segments {
                level.insert(world(a), world(b));
            }
        }
    }

    /// Empty levels around `centre`.
    fn new_levels(&self, centre: DVec2) -> Vec<Level> {
        let half = self.config.max_range.min(50.0) + 2.0;
        (0..self.config.levels.max(1))
            .map(|l| Level::new(self.config.resolution * f64::from(1u32 << l), centre, half))
            .collect()
    }

    /// Adds the current scan as keyframe `pose` to the map and the graph, and looks for a
    /// loop closure.
    fn add_keyframe(&mut self, pose: Pose) {
        // A return that ends a joined surface is in the map with it already.
        let ends: std::collections::HashSet<[u64; 2]> = (self.segments.iter())
            .flat_map(|(a, b)| [a, b].map(|p| [p.x.to_bits(), p.y.to_bits()]))
            .collect();
        let keyframe = Keyframe {
            points: (self.points.iter().copied())
                .filter(|p| !ends.contains(&[p.x.to_bits(), p.y.to_bits()]))
                .collect(),
            segments: self.segments.clone(),
        };
        Self::insert(&mut self.levels, &keyframe, &pose);
        self.keyframes.push(keyframe);
        let i = self.graph.nodes.len();
        self.graph.nodes.push(pose);
        if i > 0 {
            // Since the last keyframe only the odometry may have moved the estimate (a scan
            // refused): the edge is as uncertain as the odometry.
            let (sigma_xy, sigma_yaw) = if self.unregistered {
                ODOMETRY_EDGE_SIGMA
            } else {
                EDGE_SIGMA
            };
            self.graph.edges.push(Edge {
                from: i - 1,
                to: i,
                relative: self.graph.nodes[i - 1].inverse().compose(&pose),
                sigma_xy,
                sigma_yaw,
            });
        }
        self.unregistered = false;
        self.last_keyframe = Some(pose);
        self.stats.keyframes += 1;
        self.since_closure += 1;
        if self.config.loop_closure && self.since_closure >= LOOP_EVERY {
            self.close_loop(i);
        }
    }

    /// Registers keyframe `i` against the submap of the nearest keyframe at least
    /// [`LOOP_GAP`] keyframes older within [`LOOP_RADIUS`]: a search over a window wider than
    /// tracking's basin (the drift since the robot was last here), then Gauss–Newton. An
    /// accepted match becomes an edge; if it disagrees with the estimate, the graph is solved,
    /// the keyframes move and the map is rebuilt from them.
    fn close_loop(&mut self, i: usize) {
        let Some(newest_old) = i.checked_sub(LOOP_GAP) else {
            return;
        };
        let here = self.graph.nodes[i];
        let Some(j) = (0..=newest_old)
            .map(|j| (j, (self.graph.nodes[j].xy() - here.xy()).length()))
            .filter(|&(_, d)| d <= LOOP_RADIUS)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(j, _)| j)
        else {
            return;
        };
        self.stats.loop_searches += 1;
        let mut submap = self.new_levels(self.graph.nodes[j].xy());
        for k in j.saturating_sub(SUBMAP_KEYFRAMES)..=(j + SUBMAP_KEYFRAMES).min(newest_old) {
            Self::insert(&mut submap, &self.keyframes[k], &self.graph.nodes[k]);
        }
        // The current keyframe's returns are still in `points`.
        let coarse = submap.last().expect("levels");
        let step = coarse.resolution();
        let reach = (LOOP_WINDOW.0 / step).round() as i32;
        let turns = (LOOP_WINDOW.1 / LOOP_ANGLE_STEP).round() as i32;
        let mut best = (f64::NEG_INFINITY, here);
        for a in -turns..=turns {
            for dx in -reach..=reach {
                for dy in -reach..=reach {
                    let p = Pose::new(
                        here.x + f64::from(dx) * step,
                        here.y + f64::from(dy) * step,
                        0.0,
                        here.yaw + f64::from(a) * LOOP_ANGLE_STEP,
                    );
                    let s = self.score(coarse, &p, Level::nearest);
                    if s > best.0 {
                        best = (s, p);
                    }
                }
            }
        }
        let (matched, score) = self.match_scan(&submap, &best.1);
        if score < LOOP_MIN_SCORE || self.degenerate(&submap[0], &matched) {
            return;
        }
        self.since_closure = 0;
        self.stats.loop_closures += 1;
        self.graph.edges.push(Edge {
            from: j,
            to: i,
            relative: self.graph.nodes[j].inverse().compose(&matched),
            sigma_xy: EDGE_SIGMA.0,
            sigma_yaw: EDGE_SIGMA.1,
        });
        let off = (matched.xy() - here.xy()).length();
        if off < SOLVE_BEYOND.0 && wrap_angle(matched.yaw - here.yaw).abs() < SOLVE_BEYOND.1 {
            return;
        }
        let Some(solved) = self.graph.solve() else {
            return;
        };
        self.stats.graph_solves += 1;
        // The latest keyframe's correction carries the anchor and the last keyframe along.
        let correction = solved[i].compose(&here.inverse());
        self.anchor.0 = correction.compose(&self.anchor.0);
        self.last_keyframe = Some(solved[i]);
        self.graph.nodes = solved;
        let mut levels = self.new_levels(self.graph.nodes[0].xy());
        for (k, p) in self.keyframes.iter().zip(&self.graph.nodes) {
            Self::insert(&mut levels, k, p);
        }
        self.levels = levels;
    }

    /// Gauss–Newton from `predicted`, coarse level to fine; the pose and the mean likelihood
    /// of the returns there. A step is taken only where it lowers the cost (halved until it
    /// does, up to [`HALVINGS`] times): on the likelihood's peaks the residuals do not reach 0
    /// (the interpolated peak is below 1) while their gradients do, so plain Gauss–Newton
    /// would leap away from the optimum it sits on.
    fn match_scan(&self, levels: &[Level], predicted: &Pose) -> (Pose, f64) {
        let info = DVec3::new(
            PRIOR_SIGMA.0.powi(-2),
            PRIOR_SIGMA.0.powi(-2),
            PRIOR_SIGMA.1.powi(-2),
        );
        let mut xi = DVec3::new(predicted.x, predicted.y, predicted.yaw);
        for level in levels.iter().rev() {
            let mut here = self.normal_equations(level, xi, predicted, info);
            for _ in 0..ITERATIONS {
                let (_, h, g) = here;
                if h.determinant().abs() < 1e-12 {
                    break;
                }
                let step = -(h.inverse() * g);
                let mut scale = 1.0;
                let mut taken = None;
                for _ in 0..=HALVINGS {
                    let next = xi + step * scale;
                    let there = self.normal_equations(level, next, predicted, info);
                    if there.0 < here.0 {
                        taken = Some((next, there));
                        break;
                    }
                    scale *= 0.5;
                }
                let Some((next, there)) = taken else {
                    break;
                };
                (xi, here) = (next, there);
                if (step * scale).truncate().length() < 1e-4 && (step.z * scale).abs() < 1e-4 {
                    break;
                }
            }
        }
        let pose = Pose::new(xi.x, xi.y, 0.0, wrap_angle(xi.z));
        let score = self.score(&levels[0], &pose, |l, w| l.sample(w).value);
        (pose, score)
    }

    /// Whether the current returns at `pose` on `level` pin the position down in one direction
    /// only (a corridor's walls: any shift along it matches as well). Tracking has the odometry
    /// for that direction; a loop closure has nothing, and one along a corridor is as likely
    /// to be a place further on as this one.
    fn degenerate(&self, level: &Level, pose: &Pose) -> bool {
        let xi = DVec3::new(pose.x, pose.y, pose.yaw);
        let (_, h, _) = self.normal_equations(level, xi, pose, DVec3::ZERO);
        // The eigenvalues of the position block.
        let (a, b, c) = (h.x_axis.x, h.y_axis.x, h.y_axis.y);
        let mean = (a + c) / 2.0;
        let spread = (((a - c) / 2.0).powi(2) + b * b).sqrt();
        let (low, high) = (mean - spread, mean + spread);
        !(high > 0.0 && low >= LOOP_MIN_CONSTRAINT * high)
    }

    /// The mean of `read` over the current returns moved by `pose` onto `level`.
    fn score(&self, level: &Level, pose: &Pose, read: impl Fn(&Level, DVec2) -> f64) -> f64 {
        let (s, c) = pose.yaw.sin_cos();
        let sum: f64 = (self.points.iter())
            .map(|p| {
                read(
                    level,
                    DVec2::new(pose.x + c * p.x - s * p.y, pose.y + s * p.x + c * p.y),
                )
            })
            .sum();
        sum / self.points.len().max(1) as f64
    }

    /// The cost `Σ ρ(1 - M) + prior` (ρ the Cauchy loss) at pose `xi` (x, y, yaw) on `level`, and the Gauss–Newton
    /// normal equations there, reweighted: `H = Σ w J Jᵀ + P`, `g = Σ w J r + P (xi - predicted)`.
    fn normal_equations(
        &self,
        level: &Level,
        xi: DVec3,
        predicted: &Pose,
        info: DVec3,
    ) -> (f64, DMat3, DVec3) {
        let (s, c) = xi.z.sin_cos();
        let dev = DVec3::new(
            xi.x - predicted.x,
            xi.y - predicted.y,
            wrap_angle(xi.z - predicted.yaw),
        );
        let mut h = DMat3::from_diagonal(info);
        let mut g = info * dev;
        let mut cost = dev.dot(info * dev);
        for p in &self.points {
            let w = DVec2::new(xi.x + c * p.x - s * p.y, xi.y + s * p.x + c * p.y);
            let m = level.sample(w);
            let r = 1.0 - m.value;
            // d(residual)/d(x, y, yaw).
            let j = -DVec3::new(
                m.gradient.x,
                m.gradient.y,
                m.gradient.x * (-s * p.x - c * p.y) + m.gradient.y * (c * p.x - s * p.y),
            );
            // Cauchy weights: a return far off every surface (one that went deeper into
            // foliage than from the last viewpoint) barely pulls.
            let c2 = ROBUST_SCALE * ROBUST_SCALE;
            let w = 1.0 / (1.0 + r * r / c2);
            h += outer(j) * w;
            g += j * (w * r);
            cost += c2 * (r * r / c2).ln_1p();
        }
        (cost, h, g)
    }
}

/// `j jᵀ`.
fn outer(j: DVec3) -> DMat3 {
    DMat3::from_cols(j * j.x, j * j.y, j * j.z)
}

#[cfg(test)]
mod tests;
