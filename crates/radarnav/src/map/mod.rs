//! Occupancy-grid mapping that tells "seen through" from "passable" (DESIGN §5).
//!
//! * [`walk`]: the exact cell walk of a ray (Amanatides & Woo).
//! * [`union`]: the cells a whole scan's rays cross, in chains of neighbouring rays.
//! * [`grid`]: the growing two-layer log-odds grid (`sensed`, `passable`) and the cell
//!   classes of the thesis' figure 15.
//! * [`mapper`]: a simulation observer that inserts a robot's scans at the true or the
//!   odometry pose.
//! * [`truth`]: the ground-truth raster of a world and the map scores (hidden-area coverage,
//!   precision and recall). Only scoring reads the world; the mapper never does.
//! * [`export`]: PNG in the thesis' palette, ROS `map_server` PGM + YAML, NumPy `.npy`.

pub mod coverage;
pub mod export;
pub mod grid;
pub mod mapper;
pub mod truth;
pub mod union;
pub mod walk;

pub use coverage::{CoverageSample, CoverageTrack, track_coverage};
pub use grid::{CellClass, Grid, Occupancy};
pub use mapper::{MapConfig, Mapper, PoseSource};
pub use truth::{MapScores, Truth, score_maps};
pub use walk::{CellIndex, CellWalk, cell_of};

use thiserror::Error;

/// A map that cannot be built or written.
#[derive(Debug, Error)]
pub enum MapError {
    /// A map names a sensor the robot does not have.
    #[error("robot `{robot}` has no sensor `{sensor}` (it has: {known})")]
    UnknownSensor {
        /// The missing sensor.
        sensor: String,
        /// The robot.
        robot: String,
        /// Its sensors.
        known: String,
    },
    /// A bad setting.
    #[error("map: {0}")]
    Config(String),
    /// A file could not be written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Cause.
        cause: std::io::Error,
    },
    /// The PNG could not be drawn.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
}
