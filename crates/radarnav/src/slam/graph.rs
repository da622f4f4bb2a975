//! The localiser's pose graph: keyframe poses joined by the registrations between them (each
//! keyframe to the one before, and loop closures to old ones), solved by Levenberg–Marquardt
//! in `factrs` (a maintained factor-graph crate: sparse Cholesky from `faer`), the first
//! keyframe held by a prior.

use crate::pose::Pose;

/// A measured relative pose `from⁻¹ ∘ to` and its standard deviations (m, rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// Earlier keyframe.
    pub from: usize,
    /// Later keyframe.
    pub to: usize,
    /// `to` in `from`'s frame.
    pub relative: Pose,
    /// Standard deviation of the position, m.
    pub sigma_xy: f64,
    /// Standard deviation of the heading, rad.
    pub sigma_yaw: f64,
}

/// Keyframe poses and the edges between them.
#[derive(Clone, Debug, Default)]
pub struct PoseGraph {
    /// Each keyframe's current estimate.
    pub nodes: Vec<Pose>,
    /// Every edge.
    pub edges: Vec<Edge>,
}

impl PoseGraph {
    /// Solves the graph from the current estimates; returns the new poses (`None` if the
    /// solver failed, or was not built in: feature `pose-graph`).
    #[cfg(feature = "pose-graph")]
    pub fn solve(&self) -> Option<Vec<Pose>> {
        use factrs::{
            assign_symbols,
            core::{BetweenResidual, Graph, LevenMarquardt, PriorResidual, SE2, Values},
            fac,
            traits::Optimizer,
        };
        assign_symbols!(K: SE2);
        let se2 = |p: &Pose| SE2::new(p.yaw, p.x, p.y);
        let key = |i: usize| K(i as u32);
        let mut values = Values::new();
        for (i, p) in self.nodes.iter().enumerate() {
            values.insert(key(i), se2(p));
        }
        let mut graph = Graph::new();
        let first = self.nodes.first()?;
        graph.add_factor(fac![
            PriorResidual::new(se2(first)),
            key(0),
            (1e-6, 1e-6) as std
        ]);
        for e in &self.edges {
            let residual = BetweenResidual::new(se2(&e.relative));
            // factrs splits an SE(2) tangent as (rotation, translation).
            graph.add_factor(fac![
                residual,
                (key(e.from), key(e.to)),
                (e.sigma_yaw, e.sigma_xy) as std
            ]);
        }
        let mut solver: LevenMarquardt = LevenMarquardt::new_default(graph);
        let solved = solver.optimize(values).ok()?;
        (0..self.nodes.len())
            .map(|i| {
                let p: &SE2 = solved.get(key(i))?;
                Some(Pose::new(
                    p.x(),
                    p.y(),
                    0.0,
                    crate::pose::wrap_angle(p.theta()),
                ))
            })
            .collect()
    }

    /// Without the solver: `None`.
    #[cfg(not(feature = "pose-graph"))]
    pub fn solve(&self) -> Option<Vec<Pose>> {
        None
    }
}

#[cfg(all(test, feature = "pose-graph"))]
mod tests {
    use super::*;

    #[test]
    fn a_loop_closure_spreads_the_drift_over_the_loop() {
        // A square of 4 m sides driven in 1 m steps, its odometry turning 2° too much per
        // step; the closure says the last keyframe is the first.
        let step = Pose::new(1.0, 0.0, 0.0, 0.0);
        let corner = Pose::new(1.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let mut g = PoseGraph::default();
        let mut p = Pose::default();
        g.nodes.push(p);
        for k in 1..=16 {
            let true_step = if k % 4 == 0 { corner } else { step };
            let drifted = Pose {
                yaw: true_step.yaw + 2f64.to_radians(),
                ..true_step
            };
            p = p.compose(&drifted);
            g.nodes.push(p);
            g.edges.push(Edge {
                from: k - 1,
                to: k,
                relative: true_step,
                sigma_xy: 0.05,
                sigma_yaw: 0.01,
            });
        }
        g.edges.push(Edge {
            from: 0,
            to: 16,
            relative: Pose::new(0.0, 0.0, 0.0, 0.0),
            sigma_xy: 0.01,
            sigma_yaw: 0.005,
        });
        let before = g.nodes[16].xy().length();
        assert!(before > 1.0, "{before}");
        let solved = g.solve().expect("solved");
        // The edges agree with the square: every keyframe lands on it.
        for (k, q) in solved.iter().enumerate() {
            let side = (k / 4) % 4;
            let along = (k % 4) as f64;
            let want = [
                (along, 0.0),
                (4.0, along),
                (4.0 - along, 4.0),
                (0.0, 4.0 - along),
            ][side];
            assert!(
                (q.x - want.0).abs() < 1e-3 && (q.y - want.1).abs() < 1e-3,
                "{k}: {q:?}"
            );
        }
    }
}
