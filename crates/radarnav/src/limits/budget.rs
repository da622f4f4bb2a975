//! Size estimates made before a run allocates or writes anything (DESIGN §12): the cells of
//! its maps, the memory they take, and the bytes its recording writes. A run over a limit is
//! refused with the estimate, the limit and the flag that raises it.
//!
//! The estimates are upper bounds from the output formats (see [`crate::record`]); they are
//! checked against real recordings in the tests.

use glam::DVec2;
use thiserror::Error;

use crate::sensor::ReturnMode;
use crate::setup::Robot;
use crate::world::World;

/// Most cells of one map (DESIGN §12).
pub const MAX_MAP_CELLS: u64 = 100_000_000;
/// Default of `--max-memory`, bytes.
pub const DEFAULT_MAX_MEMORY: u64 = 4_000_000_000;
/// Default of `--max-output`, bytes.
pub const DEFAULT_MAX_OUTPUT: u64 = 10_000_000_000;

/// Memory of a map cell while a run builds and scores it: three grid layers (8 + 4 bytes),
/// the truth raster and its working layers (6 bytes), the figure and the MCAP message of its
/// known part (5 bytes), with room for one copy while the grid grows.
const MAP_BYTES_PER_CELL: u64 = 2 * 12 + 6 + 5;

/// What a run may use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Memory, bytes.
    pub memory: u64,
    /// Output, bytes.
    pub output: u64,
}

impl Default for Budget {
    fn default() -> Self {
        Self {
            memory: DEFAULT_MAX_MEMORY,
            output: DEFAULT_MAX_OUTPUT,
        }
    }
}

impl Budget {
    /// From the command line's `--max-memory` and `--max-output`, in GB.
    pub fn from_gb(memory: Option<f64>, output: Option<f64>) -> Self {
        let d = Self::default();
        Self {
            memory: memory.map_or(d.memory, |g| (g * 1e9) as u64),
            output: output.map_or(d.output, |g| (g * 1e9) as u64),
        }
    }
}

/// A run refused before it starts.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum BudgetError {
    /// A map would have too many cells.
    #[error(
        "map `{map}` would have {cells:.3e} cells at {resolution} m over {width:.0} x {height:.0} m, more than the limit of {:.0e}",
        MAX_MAP_CELLS as f64
    )]
    Cells {
        /// The map.
        map: String,
        /// Estimated cells.
        cells: f64,
        /// Cell size, m.
        resolution: f64,
        /// Region, m.
        width: f64,
        /// Region, m.
        height: f64,
    },
    /// The run would need too much memory.
    #[error("{what} would need about {} of memory, more than the limit of {} (raise it with --max-memory)", gb(*need), gb(*limit as f64))]
    Memory {
        /// What needs it.
        what: String,
        /// Estimated bytes.
        need: f64,
        /// The limit, bytes.
        limit: u64,
    },
    /// The run would write too much.
    #[error("{what} would write about {}, more than the limit of {} (raise it with --max-output, shorten it with --duration or record less with --no-mcap)", gb(*need), gb(*limit as f64))]
    Output {
        /// What writes it.
        what: String,
        /// Estimated bytes.
        need: f64,
        /// The limit, bytes.
        limit: u64,
    },
}

fn gb(b: f64) -> String {
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else {
        format!("{:.1} MB", b / 1e6)
    }
}

/// The rectangle a map of `robot` may cover: the world's bounds and the robot's start, grown
/// by how far its sensors mark cells (the shorter of `range_max` and `max_range`, or
/// `max_free_range` for rays with no return) plus the largest mount offset and the body.
/// A robot inside the world cannot mark a cell outside it.
pub fn map_region(
    world: &World,
    robot: &Robot,
    max_free_range: f64,
    max_range: f64,
) -> (DVec2, DVec2) {
    let start = robot.start.xy();
    let (lo, hi) = world.bounds().map_or((start, start), |(lo, hi)| {
        (lo.truncate().min(start), hi.truncate().max(start))
    });
    let sensing = robot
        .sensors
        .iter()
        .map(|s| s.config.range_max.min(max_range).max(max_free_range) + s.mount.xy().length())
        .fold(max_free_range, f64::max);
    let body = robot.vehicle.length.hypot(robot.vehicle.width);
    let reach = DVec2::splat(sensing + body);
    (lo - reach, hi + reach)
}

/// Cells of a map of `resolution` over `region` (f64: it may be far beyond `u64`).
pub fn cells_over(region: (DVec2, DVec2), resolution: f64) -> f64 {
    let size = region.1 - region.0;
    (size.x / resolution + 1.0).ceil() * (size.y / resolution + 1.0).ceil()
}

impl Budget {
    /// Checks the maps of a run: each at most [`MAX_MAP_CELLS`], all together within the
    /// memory limit.
    pub fn check_maps<'a>(
        &self,
        maps: impl IntoIterator<Item = &'a str>,
        region: (DVec2, DVec2),
        resolution: f64,
    ) -> Result<f64, BudgetError> {
        let cells = cells_over(region, resolution);
        let size = region.1 - region.0;
        let mut total = 0.0;
        for map in maps {
            if cells > MAX_MAP_CELLS as f64 {
                return Err(BudgetError::Cells {
                    map: map.to_owned(),
                    cells,
                    resolution,
                    width: size.x,
                    height: size.y,
                });
            }
            total += cells;
        }
        let need = total * MAP_BYTES_PER_CELL as f64;
        self.check_memory(&format!("the maps ({total:.3e} cells)"), need)?;
        Ok(total)
    }

    /// Checks memory the run holds: its maps (see [`Budget::check_maps`]) or its paths
    /// ([`path_memory`]).
    pub fn check_memory(&self, what: &str, need: f64) -> Result<(), BudgetError> {
        refuse_over(need, self.memory, |limit| BudgetError::Memory {
            what: what.to_owned(),
            need,
            limit,
        })
    }

    /// Checks the recording's estimated size ([`run_output`]).
    pub fn check_output(&self, what: &str, need: f64) -> Result<(), BudgetError> {
        refuse_over(need, self.output, |limit| BudgetError::Output {
            what: what.to_owned(),
            need,
            limit,
        })
    }
}

/// `error(limit)` when `need` is over `limit`.
fn refuse_over(
    need: f64,
    limit: u64,
    error: impl FnOnce(u64) -> BudgetError,
) -> Result<(), BudgetError> {
    if need > limit as f64 {
        Err(error(limit))
    } else {
        Ok(())
    }
}

/// Bytes of the driven paths a run keeps for its figures and the MCAP path: the true and the
/// odometry path, a pose (32 bytes) per centimetre or more, at the vehicle's top speed; and
/// the localiser's, if the robot runs one: its keyframes (a return's point and a joining
/// surface per ray, 48 bytes, every keyframe distance at top speed) and its likelihood levels
/// (4 bytes a cell), which cover at most the returns (all on the world's objects) and the
/// start, with the margin they grow by, up to [`crate::slam::likelihood::MAX_CELLS`] each.
pub fn path_memory(world: &World, robot: &Robot, duration: f64) -> f64 {
    let paths = 2.0 * 32.0 * (duration * robot.vehicle.max_speed / 0.01 + 2.0);
    let slam = robot.slam.map_or(0.0, |c| {
        let rays = robot.sensors.get(c.sensor).map_or(0.0, |s| {
            (s.config.azimuth_count() * s.config.elevations.len()) as f64
        });
        let keyframes = duration * robot.vehicle.max_speed / c.keyframe_distance + 1.0;
        let (lo, hi) = map_region(world, robot, 0.0, 0.0);
        let reach = c.max_range.min(50.0) + 2.0 + crate::slam::likelihood::GROW_MARGIN;
        let side = (hi - lo) + DVec2::splat(2.0 * reach);
        let levels: f64 = (0..c.levels)
            .map(|l| {
                let res = c.resolution * f64::from(1u32 << l.min(30));
                (side.x / res * side.y / res).min(crate::slam::likelihood::MAX_CELLS as f64)
            })
            .sum();
        48.0 * rays * keyframes + 4.0 * levels
    });
    paths + slam
}

/// What a recording holds, for [`run_output`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recording {
    /// Step, s.
    pub dt: f64,
    /// Length, s.
    pub duration: f64,
    /// `run.mcap` is written.
    pub mcap: bool,
    /// The rosbag2 recording is written.
    pub ros2_bag: bool,
    /// The scan logs are written.
    pub scans: bool,
    /// Cells of all maps together (logged to the MCAP every [`crate::record::GRID_PERIOD`]).
    pub map_cells: f64,
}

/// Bytes a recording of `robot` writes at most: per step a trajectory row, four MCAP
/// messages and the bag's clock, transforms and odometry; per scan its scan-log record and
/// its MCAP and bag messages (with echoes in `all` mode); per rotation of an imaging radar
/// its PNG and the bag's raw image; the maps' MCAP and bag messages and files.
pub fn run_output(robot: &Robot, r: &Recording) -> f64 {
    const STEP_BYTES: f64 = 4.0 * 160.0;
    const BAG_STEP_BYTES: f64 = 1100.0;
    let steps = (r.duration / r.dt).ceil() + 2.0;
    let mcap = f64::from(u8::from(r.mcap));
    let bag = f64::from(u8::from(r.ros2_bag));
    // A row of trajectory.csv, and a line of truth.tum, odometry.tum and slam.tum.
    const TUM_LINE_BYTES: f64 = 100.0;
    let tum_files = if robot.slam.is_some() { 3.0 } else { 2.0 };
    let mut bytes =
        steps * (120.0 + tum_files * TUM_LINE_BYTES + mcap * STEP_BYTES + bag * BAG_STEP_BYTES);
    for s in &robot.sensors {
        let c = &s.config;
        let rays = (c.azimuth_count() * c.elevations.len()) as f64;
        let scans = (r.duration * c.rate_hz).ceil() + 1.0;
        let echoes = if c.signal.return_mode == ReturnMode::All {
            c.signal.max_echoes as f64
        } else {
            0.0
        };
        let log = if r.scans {
            48.0 + rays * (8.0 + 1.0 + 16.0 * echoes)
        } else {
            0.0
        };
        let per_scan = log
            + mcap * (500.0 + c.azimuth_count() as f64 * 18.0 + rays * 18.0 * echoes)
            + bag * (600.0 + c.azimuth_count() as f64 * 4.0 + rays * 18.0 * echoes);
        bytes += scans * per_scan;
        if let (Some(_), Some(bin)) = (&c.signal.image, c.range_bin) {
            // One PNG (raw size bound) per rotation, in the files and the MCAP; raw in the bag.
            let image = c.azimuth_count() as f64 * (c.range_max / bin + 11.0);
            bytes += (scans / c.azimuth_count().max(1) as f64).ceil() * image * (1.0 + mcap + bag);
        }
    }
    // MCAP: maps of 5 bytes a cell, at most GRID_BYTES_PER_PERIOD a period (or one whole map
    // a period when one is larger, and once at the end); files: PGM, NPY (8 bytes) and PNG.
    let periods = (r.duration / crate::record::GRID_PERIOD).ceil() + 1.0;
    let grid_messages = (5.0 * r.map_cells + crate::record::GRID_BYTES_PER_PERIOD as f64)
        * periods.min(2.0)
        + crate::record::GRID_BYTES_PER_PERIOD as f64 * periods;
    // The bag's maps are whole, a byte a cell: the Foxglove messages' bound holds for them.
    bytes + (mcap + bag) * grid_messages + 10.0 * r.map_cells
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;

    #[test]
    fn a_fine_map_of_a_room_is_refused_with_its_size() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let robot = s.robot(None).unwrap();
        let region = map_region(&s.world, robot, 10.0, 50.0);
        let b = Budget::default();
        assert!(b.check_maps(["radar"], region, 0.05).is_ok());
        let e = b.check_maps(["radar"], region, 1e-3).unwrap_err();
        assert!(matches!(e, BudgetError::Cells { .. }), "{e}");
        assert!(e.to_string().contains("more than the limit of 1e8"), "{e}");
        let small = Budget::from_gb(Some(0.01), None);
        let e = small
            .check_maps(["radar", "laser"], region, 0.05)
            .unwrap_err();
        assert!(e.to_string().contains("--max-memory"), "{e}");
    }

    #[test]
    fn the_paths_of_a_very_long_run_are_refused_before_they_fill_memory() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let robot = s.robot(None).unwrap();
        let b = Budget::default();
        assert!(
            b.check_memory("paths", path_memory(&s.world, robot, 3600.0))
                .is_ok()
        );
        let e = b
            .check_memory("paths", path_memory(&s.world, robot, 1e6))
            .unwrap_err();
        assert!(e.to_string().contains("--max-memory"), "{e}");
    }

    #[test]
    fn a_long_fine_stepped_run_is_refused_before_it_writes() {
        let s = Scenario::builtin("foliage-wall").unwrap();
        let robot = s.robot(None).unwrap();
        let rec = |dt, duration| Recording {
            dt,
            duration,
            mcap: true,
            ros2_bag: false,
            scans: true,
            map_cells: 0.0,
        };
        let b = Budget::default();
        assert!(
            b.check_output("run", run_output(robot, &rec(0.05, 600.0)))
                .is_ok()
        );
        let e = b
            .check_output("run", run_output(robot, &rec(1e-4, 1e6)))
            .unwrap_err();
        assert!(e.to_string().contains("--max-output"), "{e}");
    }
}
