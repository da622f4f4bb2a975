//! Coverage of a map against distance travelled: how exploration strategies are scored
//! (DESIGN §6).

use std::sync::Arc;

use serde::Serialize;

use super::grid::Grid;
use super::mapper::Mapper;
use super::truth::Truth;
use crate::pose::Pose;
use crate::vehicle::VehicleSpec;
use crate::world::World;

/// One coverage sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CoverageSample {
    /// Simulation time, s.
    pub time: f64,
    /// True distance driven so far, m.
    pub distance: f64,
    /// Share of the free area in sight that the map shows sensor-clear (`None`: none).
    pub free: Option<f64>,
    /// Share of the hidden area that the map shows sensor-clear (`None`: none).
    pub hidden: Option<f64>,
}

/// Samples a map's coverage every `period` seconds of a run.
#[derive(Clone, Debug)]
pub struct CoverageTrack {
    truth: Arc<Truth>,
    period: f64,
    next: f64,
    distance: f64,
    last: Option<Pose>,
    samples: Vec<CoverageSample>,
}

impl CoverageTrack {
    /// A track scored against `truth`, sampled every `period` seconds.
    pub fn new(truth: Arc<Truth>, period: f64) -> Self {
        Self {
            truth,
            period,
            next: 0.0,
            distance: 0.0,
            last: None,
            samples: Vec::new(),
        }
    }

    /// Moves the robot to `truth` at `time`, sampling `grid` when a period is due.
    pub fn step(&mut self, time: f64, truth: &Pose, grid: &Grid) {
        if let Some(l) = self.last {
            self.distance += (truth.xy() - l.xy()).length();
        }
        self.last = Some(*truth);
        if time + 1e-9 >= self.next {
            self.sample(time, grid);
            while self.next <= time + 1e-9 {
                self.next += self.period;
            }
        }
    }

    /// Takes a sample now (the end of a run).
    pub fn sample(&mut self, time: f64, grid: &Grid) {
        let (free, hidden) = self.truth.coverage(grid);
        let sample = CoverageSample {
            time,
            distance: self.distance,
            free,
            hidden,
        };
        if self.samples.last().is_some_and(|l| l.time == time) {
            self.samples.pop();
        }
        self.samples.push(sample);
    }

    /// The samples so far, in time order.
    pub fn samples(&self) -> &[CoverageSample] {
        &self.samples
    }
}

/// Makes every mapper of `maps` sample its coverage every `period` seconds, against the
/// truth of `world` for `vehicle` starting at `start`; maps of the same resolution and scan
/// plane share one truth raster.
pub fn track_coverage(
    world: &World,
    vehicle: &VehicleSpec,
    start: &Pose,
    maps: &mut [Mapper],
    period: f64,
) {
    let mut truths: Vec<Arc<Truth>> = Vec::new();
    for m in maps {
        let (res, z) = (m.config().resolution, m.plane_z());
        let truth = match truths
            .iter()
            .find(|t| t.resolution() == res && t.plane_z() == z)
        {
            Some(t) => Arc::clone(t),
            None => {
                let t = Arc::new(Truth::of_world(world, res, z, vehicle, start));
                truths.push(Arc::clone(&t));
                t
            }
        };
        m.track_coverage(truth, period);
    }
}
