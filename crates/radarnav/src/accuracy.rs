//! How far an estimated trajectory is from the truth (DESIGN §10): the absolute trajectory
//! error (ATE) and the relative pose error (RPE) over segments of path, as `evo` (Grupp 2017)
//! computes them from the same TUM files, and the TUM trajectory format itself.
//!
//! Both trajectories are sampled at the same instants (every step of a run), so no time
//! association is needed.
//! * **ATE**: the RMSE of the position differences, without alignment (`evo_ape tum truth.tum
//!   odometry.tum`, translation part): odometry starts at the true pose, and aligning would
//!   hide the drift it is there to show.
//! * **RPE**: `evo_rpe --delta 10 --delta_unit m`, consecutive pairs (evo 1.38): pose indices
//!   are the first and then each where the *estimate's* path since the last one taken
//!   reaches 10 m; for each pair (i, j), E = (Qᵢ⁻¹Qⱼ)⁻¹(Pᵢ⁻¹Pⱼ), Q the
//!   truth and P the estimate; the RMSE of |E|'s translation (m) and of its rotation angle
//!   (degrees). Also given per metre of segment: translation as a percentage, rotation in
//!   degrees per metre.

use serde::Serialize;

use glam::DVec3;

use crate::pose::{Pose, wrap_angle};

/// Path length of the RPE's segments, m.
pub const RPE_SEGMENT: f64 = 10.0;

/// The relative pose error over segments of [`RPE_SEGMENT`] of path.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rpe {
    /// Pose pairs compared.
    pub segments: usize,
    /// RMSE of the translation error of a segment, m.
    pub translation_rmse_m: f64,
    /// RMSE of the rotation error of a segment, degrees.
    pub rotation_rmse_deg: f64,
    /// `translation_rmse_m` per metre of segment, %.
    pub translation_percent: f64,
    /// `rotation_rmse_deg` per metre of segment, degrees per metre.
    pub rotation_deg_per_m: f64,
}

/// The errors of one estimated trajectory against the truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Accuracy {
    /// Poses compared.
    pub poses: usize,
    /// Absolute trajectory error: RMSE of the position differences, m.
    pub ate_rmse_m: f64,
    /// Relative pose error; `None` before the estimate's path is 10 m long.
    pub rpe: Option<Rpe>,
}

impl Accuracy {
    /// The errors of `estimate` against `truth`, pose by pose (the same instants); `None` for
    /// no poses.
    pub fn of(truth: &[Pose], estimate: &[Pose]) -> Option<Self> {
        let mut meter = Meter::default();
        for (q, p) in truth.iter().zip(estimate) {
            meter.push(q, p);
        }
        meter.result()
    }
}

/// Takes the true and estimated poses of each instant in turn and keeps what the errors
/// need, in constant memory however long the run: [`Accuracy`] at any point.
#[derive(Clone, Debug, Default)]
pub struct Meter {
    poses: usize,
    /// Sum of squared position differences, m².
    ate_sum: f64,
    /// The estimate's last position, and its path since the last segment's start.
    last: Option<DVec3>,
    path: f64,
    /// The true and estimated poses where the current segment starts.
    segment_start: Option<(Pose, Pose)>,
    segments: usize,
    /// Sums of squared segment errors, m² and degrees².
    translation_sum: f64,
    rotation_sum: f64,
}

impl Meter {
    /// The poses of the next instant.
    pub fn push(&mut self, truth: &Pose, estimate: &Pose) {
        self.poses += 1;
        self.ate_sum += truth.position().distance_squared(estimate.position());
        let here = estimate.position();
        let Some(last) = self.last.replace(here) else {
            // The first pose starts the first segment.
            self.segment_start = Some((*truth, *estimate));
            return;
        };
        self.path += here.distance(last);
        if self.path < RPE_SEGMENT {
            return;
        }
        self.path = 0.0;
        if let Some((q0, p0)) = self.segment_start {
            let relative = |a: &Pose, b: &Pose| a.inverse().compose(b);
            let q = relative(&q0, truth);
            let p = relative(&p0, estimate);
            let e = relative(&q, &p);
            self.translation_sum += e.position().length_squared();
            self.rotation_sum += wrap_angle(e.yaw).abs().to_degrees().powi(2);
            self.segments += 1;
        }
        self.segment_start = Some((*truth, *estimate));
    }

    /// The errors so far; `None` before the first pose.
    pub fn result(&self) -> Option<Accuracy> {
        if self.poses == 0 {
            return None;
        }
        let rms = |sum: f64, n: usize| (sum / n as f64).sqrt();
        let rpe = (self.segments > 0).then(|| {
            let translation = rms(self.translation_sum, self.segments);
            let rotation = rms(self.rotation_sum, self.segments);
            Rpe {
                segments: self.segments,
                translation_rmse_m: translation,
                rotation_rmse_deg: rotation,
                translation_percent: 100.0 * translation / RPE_SEGMENT,
                rotation_deg_per_m: rotation / RPE_SEGMENT,
            }
        });
        Some(Accuracy {
            poses: self.poses,
            ate_rmse_m: rms(self.ate_sum, self.poses),
            rpe,
        })
    }
}

/// Writes one line of a TUM trajectory file: `t x y z qx qy qz qw`, the quaternion of a
/// rotation by the yaw about z. Enough digits that `evo` reads back the errors this module
/// computes (micrometres, nanoseconds).
pub fn write_tum_line(
    out: &mut impl std::io::Write,
    time: f64,
    pose: &Pose,
) -> std::io::Result<()> {
    let (s, c) = (0.5 * pose.yaw).sin_cos();
    writeln!(
        out,
        "{time:.9} {:.6} {:.6} {:.6} 0 0 {s:.9} {c:.9}",
        pose.x, pose.y, pose.z
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(n: usize, step: f64, yaw: f64) -> Vec<Pose> {
        (0..n)
            .map(|k| {
                let d = k as f64 * step;
                Pose::new(d * yaw.cos(), d * yaw.sin(), 0.0, yaw)
            })
            .collect()
    }

    #[test]
    fn the_truth_against_itself_has_no_error() {
        let t = straight(300, 0.125, 0.3);
        let a = Accuracy::of(&t, &t).expect("poses");
        assert_eq!(a.ate_rmse_m, 0.0);
        let rpe = a.rpe.expect("37.4 m of path: three segments");
        assert_eq!(rpe.segments, 3);
        assert!(rpe.translation_rmse_m < 1e-12 && rpe.rotation_rmse_deg < 1e-9);
    }

    #[test]
    fn a_constant_offset_is_the_ate_and_no_rpe() {
        let t = straight(500, 0.125, 0.0);
        let e: Vec<Pose> = t
            .iter()
            .map(|p| Pose::new(p.x + 0.3, p.y - 0.4, 0.0, p.yaw))
            .collect();
        let a = Accuracy::of(&t, &e).expect("poses");
        assert!((a.ate_rmse_m - 0.5).abs() < 1e-12, "{}", a.ate_rmse_m);
        let rpe = a.rpe.expect("segments");
        assert!(rpe.translation_rmse_m < 1e-9, "{rpe:?}");
    }

    /// An estimate whose speed reads 2 % high along a straight line: each segment of 10 m of
    /// the estimate's path is 10 / 1.02 m of true path, so its translation error is
    /// 10 − 10/1.02 m, and there is no rotation error.
    #[test]
    fn a_scale_error_gives_its_share_of_each_segment() {
        let t = straight(2601, 1.0 / 64.0, 0.7);
        let e: Vec<Pose> = t
            .iter()
            .map(|p| Pose::new(1.02 * p.x, 1.02 * p.y, 0.0, p.yaw))
            .collect();
        let rpe = Accuracy::of(&t, &e).and_then(|a| a.rpe).expect("segments");
        // Index steps of 1.02/64 m: a segment ends at the first index at or past 10 m of
        // path, 628 steps (10.009 m), so the true segment is 628/64 m.
        let expected = 628.0 / 64.0 * 0.02;
        assert!((rpe.translation_rmse_m - expected).abs() < 1e-9, "{rpe:?}");
        assert!(rpe.rotation_rmse_deg < 1e-9);
        assert!((rpe.translation_percent - 10.0 * expected).abs() < 1e-8);
    }

    /// A heading that drifts by a constant rate: over a segment the estimate turns by the
    /// drift × the segment's time more than the truth.
    #[test]
    fn a_heading_drift_is_the_rotation_error_per_segment() {
        let n = 2001;
        let t = straight(n, 1.0 / 64.0, 0.0);
        let e: Vec<Pose> = t
            .iter()
            .enumerate()
            .map(|(k, p)| Pose::new(p.x, p.y, 0.0, 1e-4 * k as f64))
            .collect();
        let rpe = Accuracy::of(&t, &e).and_then(|a| a.rpe).expect("segments");
        // Segments of 640 steps (10 m at 1/64 m, exactly): 1e-4 rad a step.
        let expected = (640.0f64 * 1e-4).to_degrees();
        assert!((rpe.rotation_rmse_deg - expected).abs() < 1e-9, "{rpe:?}");
        assert!((rpe.rotation_deg_per_m - expected / 10.0).abs() < 1e-10);
    }

    #[test]
    fn segments_start_where_evo_starts_them() {
        // 0.5 m a pose: segments from pose 0 to 20, 20 to 40, ... up to 100.
        let t = straight(101, 0.5, 0.0);
        let segments = |n: usize| {
            Accuracy::of(&t[..n], &t[..n])
                .and_then(|a| a.rpe)
                .map(|r| r.segments)
        };
        assert_eq!(segments(101), Some(5));
        assert_eq!(segments(100), Some(4));
        assert_eq!(segments(21), Some(1));
        assert_eq!(segments(20), None);
        assert!(Accuracy::of(&[], &[]).is_none());
    }

    #[test]
    fn a_tum_line_carries_the_yaw_as_a_unit_quaternion_about_z() {
        let mut line = Vec::new();
        write_tum_line(
            &mut line,
            1.5,
            &Pose::new(1.0, -2.0, 0.0, std::f64::consts::FRAC_PI_2),
        )
        .expect("to memory");
        assert_eq!(
            String::from_utf8(line).expect("text"),
            "1.500000000 1.000000 -2.000000 0.000000 0 0 0.707106781 0.707106781\n"
        );
    }
}
