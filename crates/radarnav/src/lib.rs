//! radarnav: a robot-simulation workbench for navigation with a scanning radar that sees
//! through foliage, smoke and dust where a laser scanner cannot.
//!
//! The library holds everything; the `radarnav` binary is a thin command-line layer over it.
//! Modules: [`accuracy`] (trajectory errors, TUM files), [`world`] (shapes, materials, ray intervals, collisions), [`setup`] (the domain values of a run: settings, robots, sensors, built in code or from files), [`scenario`] (TOML files and
//! the built-in scenarios), [`sensor`] (radar, laser and ground-truth scans), [`vehicle`] (the
//! P3AT, drive commands, kinematics, odometry), [`sim`] (the simulation loop), [`map`] (occupancy
//! grids that tell seen-through from passable), [`compare`] (exploration experiments), [`trials`]
//! (navigation trials), [`mission`] and [`nav`] (what drives the robot), [`usarsim`] (a server for
//! USARSim's clients), `ros2_node` (with the `ros2` feature: a live ROS 2 node), [`run`] (a recorded run, as `radarnav run` makes it), [`record`] (run
//! outputs: CSV, scan logs, MCAP, rosbag2), [`output`] (files written whole or not at all),
//! [`stamp`] (the epoch of every output's time stamps), [`limits`] (the valid range of every input
//! and the size estimates that bound a run), [`render`] (figures), [`demo`] (the thesis
//! experiment), [`peers`] (the scene and rays of the benchmark against Embree and Bullet), [`sweep`]
//! (scenario × parameter × seed runs in shards, merged into one table).

#![warn(missing_docs)]

pub mod accuracy;
pub mod batch;
pub mod compare;
pub mod demo;
pub mod limits;
pub mod map;
pub mod mission;
pub mod nav;
pub mod output;
pub mod peers;
pub mod pose;
pub mod record;
pub mod render;
#[cfg(feature = "ros2")]
pub mod ros2_node;
pub mod run;
pub mod scenario;
pub mod sensor;
pub mod setup;
pub mod sim;
pub mod slam;
pub mod stamp;
pub mod sweep;
pub mod trials;
pub mod usarsim;
pub mod vehicle;
pub mod world;

pub use pose::Pose;
pub use scenario::ScenarioError;
pub use sensor::{Scan, SensorConfig};
pub use setup::Scenario;
pub use world::World;
