//! The domain values a run is made of (DESIGN §9): simulation settings, robots with their
//! mounted sensors, and the scenario that holds them beside a world and a mission.
//!
//! [`crate::scenario`] builds these from TOML files; code builds them directly, and
//! [`crate::sim`] runs on them without knowing where they came from:
//!
//! ```
//! use radarnav::setup::{Robot, Scenario};
//! use glam::DVec3;
//! use radarnav::world::{MaterialTable, Object, Shape, World};
//! use radarnav::{Pose, sensor::preset, vehicle::vehicle};
//!
//! let materials = MaterialTable::default();
//! let wall = Object {
//!     name: Some("wall".into()),
//!     shape: Shape::cuboid(DVec3::new(4.0, 0.0, 1.0), DVec3::new(0.2, 6.0, 2.0), 0.0).unwrap(),
//!     material: materials.id("concrete").unwrap(),
//! };
//! let world = World::new(materials, vec![wall]);
//! let robot = Robot::new("p3at", vehicle("p3at").unwrap(), Pose::new(0.0, 0.0, 0.0, 0.0))
//!     .with_sensor("radar", preset("radar_thesis").unwrap(), Pose::new(0.0, 0.0, 0.4, 0.0));
//! let scenario = Scenario::new("empty", world).with_robot(robot);
//! assert_eq!(scenario.robot(None).unwrap().sensors.len(), 1);
//! ```

use crate::mission::{Mission, MissionKind};
use crate::pose::Pose;
use crate::sensor::SensorConfig;
use crate::slam::SlamConfig;
use crate::vehicle::{OdometryNoise, VehicleSpec};
use crate::world::World;

/// Timing and seed of a scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSettings {
    /// Step, s.
    pub dt: f64,
    /// Run length, s.
    pub duration: f64,
    /// RNG seed.
    pub seed: u64,
}

/// A sensor on a robot.
#[derive(Clone, Debug, PartialEq)]
pub struct MountedSensor {
    /// Unique on its robot.
    pub name: String,
    /// Parameters.
    pub config: SensorConfig,
    /// Pose relative to the robot (z above the ground).
    pub mount: Pose,
}

/// A robot of the scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    /// Unique name.
    pub name: String,
    /// Vehicle preset.
    pub vehicle: &'static VehicleSpec,
    /// Start pose on the ground (z = 0).
    pub start: Pose,
    /// Its sensors.
    pub sensors: Vec<MountedSensor>,
    /// Its odometry's noise.
    pub odometry: OdometryNoise,
    /// Its localiser (`None`: it runs none, and `slam` poses fall back to the odometry).
    pub slam: Option<SlamConfig>,
}

impl Robot {
    /// The sensor called `name`.
    pub fn sensor(&self, name: &str) -> Option<&MountedSensor> {
        self.sensors.iter().find(|s| s.name == name)
    }

    /// The preset sensor `preset`, named after it and mounted where the robot's first sensor
    /// is (0.4 m over the robot's origin if it has none); `None` for an unknown preset.
    pub fn with_preset_mount(&self, preset: &str) -> Option<MountedSensor> {
        Some(MountedSensor {
            name: preset.to_owned(),
            config: crate::sensor::preset(preset)?,
            mount: self
                .sensors
                .first()
                .map_or(Pose::new(0.0, 0.0, 0.4, 0.0), |m| m.mount),
        })
    }
}

/// A loaded scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name: the built-in's name or the file stem.
    pub name: String,
    /// One line saying what it is for.
    pub description: String,
    /// Simulation settings.
    pub sim: SimSettings,
    /// Objects and materials.
    pub world: World,
    /// Robots.
    pub robots: Vec<Robot>,
    /// What a run does (`None`: the robot stands still while its sensors run).
    pub mission: Option<Mission>,
}

impl Default for SimSettings {
    /// 50 ms steps, a minute's run, seed 0: the defaults of a scenario file's `[sim]`.
    fn default() -> Self {
        Self {
            dt: 0.05,
            duration: 60.0,
            seed: 0,
        }
    }
}

impl MountedSensor {
    /// The sensor `name` with parameters `config`, mounted at `mount` on its robot.
    pub fn new(name: impl Into<String>, config: SensorConfig, mount: Pose) -> Self {
        Self {
            name: name.into(),
            config,
            mount,
        }
    }
}

impl Robot {
    /// A robot without sensors or localiser, with the default odometry noise.
    pub fn new(name: impl Into<String>, vehicle: &'static VehicleSpec, start: Pose) -> Self {
        Self {
            name: name.into(),
            vehicle,
            start,
            sensors: Vec::new(),
            odometry: OdometryNoise::default(),
            slam: None,
        }
    }

    /// The robot with one more sensor.
    pub fn with_sensor(
        mut self,
        name: impl Into<String>,
        config: SensorConfig,
        mount: Pose,
    ) -> Self {
        self.sensors.push(MountedSensor::new(name, config, mount));
        self
    }

    /// The robot with a localiser on its sensor `sensor` (default settings); `None` if it has
    /// no such sensor.
    pub fn with_slam(mut self, sensor: &str) -> Option<Self> {
        let i = self.sensors.iter().position(|s| s.name == sensor)?;
        self.slam = Some(SlamConfig::for_sensor(i));
        Some(self)
    }
}

impl Scenario {
    /// A scenario of `world` without robots or mission, with the default settings.
    pub fn new(name: impl Into<String>, world: World) -> Self {
        Self {
            name: name.into(),
            description: String::new(),
            sim: SimSettings::default(),
            world,
            robots: Vec::new(),
            mission: None,
        }
    }

    /// The scenario with one more robot.
    pub fn with_robot(mut self, robot: Robot) -> Self {
        self.robots.push(robot);
        self
    }

    /// The scenario with `mission` (add the robots first). A Bug or exploration mission's bumper radar is switched
    /// to first echoes, as a scenario file's is ([`bumpers_on_first_echoes`]).
    pub fn with_mission(mut self, mission: Mission) -> Self {
        bumpers_on_first_echoes(&mission, &mut self.robots);
        self.mission = Some(mission);
        self
    }

    /// The scenario with these settings.
    pub fn with_settings(mut self, sim: SimSettings) -> Self {
        self.sim = sim;
        self
    }

    /// The robot called `name`, or the first robot when `name` is `None`.
    pub fn robot(&self, name: Option<&str>) -> Option<&Robot> {
        match name {
            Some(n) => self.robots.iter().find(|r| r.name == n),
            None => self.robots.first(),
        }
    }
}

/// A Bug or exploration mission's bumpers read first echoes (DESIGN §6): its bumper radar,
/// if it is in the thesis' return mode, is switched to `all` (range = first echo, every echo
/// beside it for the maps), so foliage it sees through is an obstacle to it.
pub fn bumpers_on_first_echoes(mission: &Mission, robots: &mut [Robot]) {
    let bumpers = match &mission.kind {
        MissionKind::Bug(b) => &b.bumpers,
        MissionKind::Explore(e) => &e.bumpers,
        _ => return,
    };
    let robot = match &mission.robot {
        Some(n) => robots.iter_mut().find(|r| &r.name == n),
        None => robots.first_mut(),
    };
    if let Some(r) = robot
        && let Some(i) = bumpers.sensor_index(r.sensors.iter().map(|s| s.name.as_str()))
    {
        crate::nav::read_first_echoes(&mut r.sensors[i].config);
    }
}
