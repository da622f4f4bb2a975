//! radarnav: a robot-simulation workbench for navigation with a scanning radar that sees
//! through foliage, smoke and dust where a laser scanner cannot.
//!
//! The library holds everything; the `radarnav` binary is a thin command-line layer over it.
//! Modules: [`world`] (shapes, materials, ray intervals), [`scenario`] (TOML files and the
//! built-in scenarios), [`sensor`] (radar, laser and ground-truth scans), [`render`] (figures), [`demo`] (the thesis experiment).

#![warn(missing_docs)]

pub mod demo;
pub mod pose;
pub mod render;
pub mod scenario;
pub mod sensor;
pub mod world;

pub use pose::Pose;
pub use scenario::{Scenario, ScenarioError};
pub use sensor::{Scan, SensorConfig};
pub use world::World;
