//! The serde shape of a scenario file (DESIGN §2). Values are range-checked while they are
//! read, so a bad value is reported at its own line and column.

use serde::Deserialize;
use serde::de::{Deserializer, Error as _};
use toml::Spanned;

use crate::limits;

macro_rules! checked_f64 {
    ($(#[$doc:meta] $name:ident: $limit:path;)*) => {$(
        #[$doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $name(pub f64);

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let v = f64::deserialize(d)?;
                $limit.check(v).map(Self).map_err(D::Error::custom)
            }
        }
    )*};
}

checked_f64! {
    /// A coordinate, m.
    Coord: limits::COORD;
    /// A size, m.
    Size: limits::SIZE;
    /// A mesh file's scale.
    MeshScale: limits::MESH_SCALE;
    /// A heading, degrees.
    Yaw: limits::YAW;
    /// A sensor's offset on the robot, m.
    Mount: limits::MOUNT;
    /// A step, s.
    Dt: limits::DT;
    /// A run's length, s.
    Duration: limits::DURATION;
    /// A one-way attenuation, dB/m; `inf` for a solid.
    Attenuation: limits::ATTENUATION;
    /// A power fraction.
    Fraction: limits::REFLECTIVITY;
    /// A volume backscatter coefficient, 1/m.
    Backscatter: limits::BACKSCATTER;
    /// A laser extinction coefficient, 1/m.
    Extinction: limits::EXTINCTION;
    /// A lobe width in degrees.
    LobeDeg: limits::LOBE;
    /// A diffuse share of a specular echo.
    Diffuse: limits::DIFFUSE;
    /// Relative odometry speed noise.
    SpeedNoise: limits::SPEED_NOISE;
    /// The localiser's finest cell, m.
    SlamResolution: limits::SLAM_RESOLUTION;
    /// The localiser's farthest return, m.
    SlamRange: limits::SLAM_RANGE;
    /// Odometry yaw drift or noise, degrees/s.
    YawRate: limits::YAW_RATE_NOISE;
    /// Field of view, degrees.
    Fov: limits::FOV;
    /// Angular step, degrees.
    AngleStep: limits::RESOLUTION;
    /// A range, m.
    Range: limits::RANGE;
    /// A scan rate, Hz.
    Rate: limits::RATE;
    /// A scan plane, degrees.
    Elevation: limits::ELEVATION;
    /// Absolute range noise, m.
    RangeNoise: limits::RANGE_NOISE;
    /// Relative range noise.
    RangeNoiseRel: limits::RANGE_NOISE_REL;
    /// A penetration budget, dB.
    Penetration: limits::PENETRATION;
    /// A side-beam offset, m.
    SideBeam: limits::SIDE_BEAM;
    /// A range bin, m.
    RangeBin: limits::RANGE_BIN;
    /// A dynamic or display range, dB.
    DynamicRange: limits::DYNAMIC_RANGE;
    /// A threshold or noise floor, dB.
    Threshold: limits::THRESHOLD;
    /// A beam width, degrees.
    Beamwidth: limits::BEAMWIDTH;
    /// A chirp bandwidth, Hz.
    Bandwidth: limits::BANDWIDTH;
    /// A cruise speed, m/s.
    Speed: limits::SPEED;
    /// A tolerance, m.
    Tolerance: limits::TOLERANCE;
    /// A controller rate, Hz.
    ControllerHz: limits::CONTROLLER_HZ;
    /// A bumper distance, m.
    Bumper: limits::BUMPER;
    /// A teleop step's length, s.
    StepDuration: limits::TELEOP_DURATION;
    /// A teleop speed, m/s.
    TeleopSpeed: limits::TELEOP_SPEED;
    /// A teleop turn rate, degrees/s.
    TeleopTurn: limits::TELEOP_TURN;
}

/// A list whose length must be within `limit`: a longer one is refused where it is written.
fn bounded_vec<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
    limit: &limits::Limit,
) -> Result<Vec<T>, D::Error> {
    let v = Vec::<T>::deserialize(d)?;
    limit
        .check(v.len() as f64)
        .map_err(|m| D::Error::custom(format!("{}: {m}", limit.key)))?;
    Ok(v)
}

fn points<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Xy>, D::Error> {
    bounded_vec(d, &limits::POINTS)
}

fn steps<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<Xy>>, D::Error> {
    bounded_vec(d, &limits::STEPS).map(Some)
}

fn commands<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<Vec<Spanned<TeleopStepSpec>>>, D::Error> {
    bounded_vec(d, &limits::STEPS).map(Some)
}

fn objects<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Spanned<ObjectSpec>>, D::Error> {
    bounded_vec(d, &limits::OBJECTS)
}

fn elevations<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<Elevation>>, D::Error> {
    let v = Vec::<Elevation>::deserialize(d)?;
    if v.is_empty() || v.len() > 1024 {
        return Err(D::Error::custom(format!(
            "expected 1 to 1024 scan planes, found {}",
            v.len()
        )));
    }
    Ok(Some(v))
}

/// A point `[x, y]` (resting on the ground) or `[x, y, z]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Center {
    /// x, y.
    pub xy: [f64; 2],
    /// z when given.
    pub z: Option<f64>,
}

impl<'de> Deserialize<'de> for Center {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<Coord>::deserialize(d)?;
        match v.as_slice() {
            [x, y] => Ok(Self {
                xy: [x.0, y.0],
                z: None,
            }),
            [x, y, z] => Ok(Self {
                xy: [x.0, y.0],
                z: Some(z.0),
            }),
            _ => Err(D::Error::custom(format!(
                "expected [x, y] (resting on the ground) or [x, y, z], found {} numbers",
                v.len()
            ))),
        }
    }
}

/// A point in the xy plane.
pub type Xy = [Coord; 2];

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// One line saying what the scenario is for.
    #[serde(default)]
    pub description: String,
    /// Simulation settings.
    #[serde(default)]
    pub sim: SimSpec,
    /// User-defined materials.
    #[serde(default, rename = "material")]
    pub materials: Vec<Spanned<MaterialSpec>>,
    /// Objects.
    #[serde(default, rename = "object", deserialize_with = "objects")]
    pub objects: Vec<Spanned<ObjectSpec>>,
    /// Robots.
    #[serde(default, rename = "robot")]
    pub robots: Vec<Spanned<RobotSpec>>,
    /// What the robot does in a run.
    pub mission: Option<Spanned<MissionSpec>>,
}

/// `[mission]`: `type = "teleop"` (timed commands, inline or from a CSV file),
/// `type = "waypoints"` (go to each point in turn, steering on odometry), `type = "bug1"` or
/// `"bug2"` (reach `goal`), or `explore = "<strategy>"`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionSpec {
    /// `"teleop"`, `"waypoints"`, `"bug1"`, `"bug2"` or `"explore"` (optional with `explore`).
    #[serde(rename = "type")]
    pub kind: Option<Spanned<String>>,
    /// Exploration strategy: `bounce`, `wall_follow`, `spiral` or `frontier`.
    pub explore: Option<Spanned<String>>,
    /// bug: the goal, `[x, y]`.
    pub goal: Option<Xy>,
    /// bug2: distance to the m-line that counts as on it, m (default 0.1).
    pub mline_tolerance: Option<Tolerance>,
    /// bug: distance to a hit or leave point that counts as back at it, m (default 0.75).
    pub loop_tolerance: Option<Tolerance>,
    /// bug, explore: side the obstacle is kept on when following it, `left` or `right`.
    pub follow: Option<Spanned<String>>,
    /// bug, explore: the pose navigation believes, `odometry` (default) or `truth`.
    pub pose: Option<Spanned<String>>,
    /// bug, explore: the virtual bumpers.
    pub bumpers: Option<Spanned<BumperSpec>>,
    /// The robot that runs it (default: the first).
    pub robot: Option<Spanned<String>>,
    /// How often the controller is called, Hz (default 10).
    pub controller_hz: Option<ControllerHz>,
    /// teleop: the commands, in order.
    #[serde(default, deserialize_with = "commands")]
    pub commands: Option<Vec<Spanned<TeleopStepSpec>>>,
    /// teleop: a CSV file of commands, relative to the scenario file.
    pub file: Option<Spanned<String>>,
    /// waypoints: the points to visit, `[x, y]` each.
    #[serde(default, deserialize_with = "steps")]
    pub points: Option<Vec<Xy>>,
    /// waypoints, bug, explore: cruise speed, m/s (default 0.5 for waypoints, 0.4 otherwise).
    pub speed: Option<Speed>,
    /// waypoints, bug: distance at which a point counts as reached, m (default 0.15 for
    /// waypoints, 0.3 for a bug goal).
    pub tolerance: Option<Tolerance>,
    /// waypoints: start over after the last point (default false).
    #[serde(rename = "loop")]
    pub repeat: Option<bool>,
}

/// `[mission.bumpers]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BumperSpec {
    /// 4 or 8 (default 8).
    pub sectors: Option<Spanned<i64>>,
    /// Safety distance from the robot's centre, m (default 2.5 vehicle lengths).
    pub safety: Option<Bumper>,
    /// Pressed band beyond the safety distance, m (default 0.5).
    pub band: Option<Bumper>,
    /// `all` (default), `any` or `fraction:p`.
    pub rule: Option<Spanned<String>>,
    /// The sensor feeding the bumpers (default: the robot's first).
    pub sensor: Option<Spanned<String>>,
}

/// One timed teleop command: `duration` plus either `v`/`omega_deg_s` or `left`/`right`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeleopStepSpec {
    /// How long the command is held, s.
    pub duration: StepDuration,
    /// Forward speed, m/s.
    pub v: Option<TeleopSpeed>,
    /// Turn rate, degrees/s counter-clockwise.
    pub omega_deg_s: Option<TeleopTurn>,
    /// Left track speed, m/s.
    pub left: Option<TeleopSpeed>,
    /// Right track speed, m/s.
    pub right: Option<TeleopSpeed>,
}

/// `[sim]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimSpec {
    /// Step, seconds.
    #[serde(default = "default_dt")]
    pub dt: Dt,
    /// Length of a run, seconds.
    #[serde(default = "default_duration")]
    pub duration: Duration,
    /// Seed of the run's RNG.
    #[serde(default)]
    pub seed: u64,
}

fn default_dt() -> Dt {
    Dt(0.05)
}

fn default_duration() -> Duration {
    Duration(60.0)
}

impl Default for SimSpec {
    fn default() -> Self {
        Self {
            dt: default_dt(),
            duration: default_duration(),
            seed: 0,
        }
    }
}

/// `[[material]]`: a new material, or a variant of `base` with some fields changed.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Unique name, not a built-in's (derive from one with `base`).
    pub name: String,
    /// Material whose values the unset fields take.
    pub base: Option<Spanned<String>>,
    /// One-way dB/m; `inf` for a solid.
    pub radar_attenuation_db_per_m: Option<Attenuation>,
    /// Power fraction reflected at entry.
    pub radar_reflectivity: Option<Fraction>,
    /// Mirror-like to radar.
    pub specular: Option<bool>,
    /// Volume backscatter η, 1/m (0–10).
    pub radar_backscatter_per_m: Option<Backscatter>,
    /// Full width of a specular echo lobe, degrees (0.1–90).
    pub specular_lobe_deg: Option<LobeDeg>,
    /// Share of a specular echo scattered diffusely (0–1).
    pub radar_diffuse: Option<Diffuse>,
    /// Stops a laser at its surface.
    pub laser_opaque: Option<bool>,
    /// Laser dB/m when not opaque (default for an aerosol: 4.343 × its extinction).
    pub laser_attenuation_db_per_m: Option<Attenuation>,
    /// Aerosol extinction k to a laser, 1/m (0–100): returns from the particles (§7.6).
    pub laser_extinction_per_m: Option<Extinction>,
    /// A robot may drive through.
    pub traversable: Option<bool>,
    /// `"#rrggbb"` for figures.
    pub color: Option<Spanned<String>>,
}

/// `[[object]]`: a name, a material and exactly one shape table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// Optional name.
    pub name: Option<String>,
    /// Material name.
    pub material: Spanned<String>,
    /// `sphere = { center, radius }`.
    pub sphere: Option<SphereSpec>,
    /// `box = { center, size, yaw_deg }`.
    #[serde(rename = "box")]
    pub cuboid: Option<BoxSpec>,
    /// `cylinder = { center, radius, height }`.
    pub cylinder: Option<CylinderSpec>,
    /// `wall = { points, thickness, height }`.
    pub wall: Option<Spanned<WallSpec>>,
    /// `prism = { polygon, z_min, z_max }`.
    pub prism: Option<Spanned<PrismSpec>>,
    /// `mesh = { file, scale, yaw_deg, center, up, materials }`.
    pub mesh: Option<Spanned<MeshSpec>>,
}

/// Mesh fields: a `file`, or a plant to `generate`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// OBJ or glTF file, relative to the scenario file.
    pub file: Option<Spanned<String>>,
    /// A seeded plant instead of a file: `"tree"` or `"bush"` (parts `bark`, `leaves`).
    pub generate: Option<Spanned<String>>,
    /// Seed of a generated plant (default 1).
    pub seed: Option<u64>,
    /// Height of a generated plant, m (default: tree 5, bush 1.2).
    pub height: Option<Size>,
    /// File units to metres (default 1).
    #[serde(default = "unit_scale")]
    pub scale: MeshScale,
    /// Rotation about z, degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Yaw,
    /// Where the file's origin goes; `[x, y]` puts it on the ground (default the world's
    /// origin).
    pub center: Option<Center>,
    /// The file's up axis, `"z"` or `"y"` (default: `"y"` for glTF, `"z"` for OBJ).
    pub up: Option<Spanned<String>>,
    /// Material of each part by the name the file gives it (`leaves = "foliage_dense"`);
    /// parts not named here take the object's material.
    #[serde(default)]
    pub materials: std::collections::BTreeMap<String, Spanned<String>>,
}

fn unit_scale() -> MeshScale {
    MeshScale(1.0)
}

/// Sphere fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre; `[x, y]` rests it on the ground.
    pub center: Center,
    /// Radius, m.
    pub radius: Size,
}

/// Box fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Centre; `[x, y]` rests it on the ground.
    pub center: Center,
    /// Full size along its own axes, m.
    pub size: [Size; 3],
    /// Rotation about z, degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Yaw,
}

fn zero() -> Yaw {
    Yaw(0.0)
}

/// Cylinder fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSpec {
    /// Centre of the axis; `[x, y]` stands it on the ground.
    pub center: Center,
    /// Radius, m.
    pub radius: Size,
    /// Height, m.
    pub height: Size,
}

/// Wall fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Polyline of the wall's centre line.
    #[serde(deserialize_with = "points")]
    pub points: Vec<Xy>,
    /// Thickness, m.
    pub thickness: Size,
    /// Height, m.
    pub height: Size,
}

/// Prism fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrismSpec {
    /// Polygon in the xy plane.
    #[serde(deserialize_with = "points")]
    pub polygon: Vec<Xy>,
    /// Bottom, m (default 0).
    #[serde(default = "ground")]
    pub z_min: Coord,
    /// Top, m.
    pub z_max: Coord,
}

/// `[[robot]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Unique name.
    pub name: String,
    /// Vehicle preset.
    #[serde(default = "default_vehicle")]
    pub vehicle: Spanned<String>,
    /// Start pose.
    pub start: PlanarPose,
    /// `[[robot.sensor]]` entries.
    #[serde(default, rename = "sensor")]
    pub sensors: Vec<Spanned<SensorSpec>>,
    /// Odometry noise (defaults: [`crate::vehicle::OdometryNoise::default`]).
    #[serde(default)]
    pub odometry: OdometrySpec,
    /// The localiser (default: on the first radar, else the first laser).
    pub slam: Option<Spanned<SlamSpec>>,
}

/// `[robot.slam]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlamSpec {
    /// Whether the robot runs a localiser at all (default true).
    pub enabled: Option<bool>,
    /// The sensor it registers.
    pub sensor: Option<Spanned<String>>,
    /// Finest cell, m.
    pub resolution: Option<SlamResolution>,
    /// Farthest return used, m.
    pub max_range: Option<SlamRange>,
    /// Whether it closes loops (default false).
    pub loop_closure: Option<bool>,
}

/// `[robot.odometry]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometrySpec {
    /// Relative standard deviation of each track speed per step.
    pub speed_noise: Option<SpeedNoise>,
    /// Constant turn-rate error, degrees/s.
    pub yaw_drift_deg_s: Option<YawRate>,
    /// Turn-rate white noise, degrees/s.
    pub yaw_noise_deg_s: Option<YawRate>,
}

fn default_vehicle() -> Spanned<String> {
    Spanned::new(0..0, "p3at".to_owned())
}

/// `{ x, y, yaw_deg }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarPose {
    /// m.
    pub x: Coord,
    /// m.
    pub y: Coord,
    /// Degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Yaw,
}

/// `{ x, y, z, yaw_deg }` relative to the robot.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountSpec {
    /// m forward.
    #[serde(default = "no_offset")]
    pub x: Mount,
    /// m left.
    #[serde(default = "no_offset")]
    pub y: Mount,
    /// m above the ground.
    #[serde(default = "default_mount_z")]
    pub z: Mount,
    /// Degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Yaw,
}

/// Height of a sensor on top of a P3AT (0.277 m body) on a small post.
pub const DEFAULT_MOUNT_Z: f64 = 0.4;

fn default_mount_z() -> Mount {
    Mount(DEFAULT_MOUNT_Z)
}

fn no_offset() -> Mount {
    Mount(0.0)
}

fn ground() -> Coord {
    Coord(0.0)
}

impl Default for MountSpec {
    fn default() -> Self {
        Self {
            x: no_offset(),
            y: no_offset(),
            z: default_mount_z(),
            yaw_deg: zero(),
        }
    }
}

/// `[[robot.sensor]]`: a preset plus overrides.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Unique on the robot.
    pub name: String,
    /// A preset name (see `radarnav presets`).
    pub preset: Spanned<String>,
    /// Pose on the robot.
    #[serde(default)]
    pub mount: MountSpec,
    /// Override: field of view, degrees.
    pub fov_deg: Option<Fov>,
    /// Override: angular step, degrees.
    pub resolution_deg: Option<AngleStep>,
    /// Override, m.
    pub range_min: Option<Range>,
    /// Override, m.
    pub range_max: Option<Range>,
    /// Override, Hz.
    pub rate_hz: Option<Rate>,
    /// Override: scan planes, degrees.
    #[serde(default, deserialize_with = "elevations")]
    pub elevations_deg: Option<Vec<Elevation>>,
    /// Override, m.
    pub range_noise_std: Option<RangeNoise>,
    /// Override, fraction of range.
    pub range_noise_rel: Option<RangeNoiseRel>,
    /// Override, dB.
    pub penetration_db: Option<Penetration>,
    /// Override, m.
    pub side_beam_offset: Option<SideBeam>,
    /// Override: range bin of a binned radar, m.
    pub range_bin: Option<RangeBin>,
    /// Return mode: thesis, first, strongest, last, all (DESIGN §7.3).
    #[serde(rename = "return")]
    pub return_mode: Option<crate::sensor::ReturnMode>,
    /// Echo range law: r2, r4, flat.
    pub range_law: Option<crate::sensor::RangeLaw>,
    /// dB, 1–200.
    pub dynamic_range_db: Option<DynamicRange>,
    /// dB, −200–0.
    pub detection_threshold_db: Option<Threshold>,
    /// Echoes per azimuth in `all` mode, 1–64.
    pub max_echoes: Option<u32>,
    /// Specular bounces, 0–8.
    pub max_bounces: Option<u8>,
    /// Beam rays across azimuth (× `beam_rays_el` ≤ 64).
    pub beam_rays: Option<u32>,
    /// Beam rays across elevation.
    pub beam_rays_el: Option<u32>,
    /// −3 dB beam width in azimuth, degrees.
    pub beamwidth_az_deg: Option<Beamwidth>,
    /// −3 dB beam width in elevation, degrees.
    pub beamwidth_el_deg: Option<Beamwidth>,
    /// Beam ray selection: uniform, incidence_weighted, nearest, strongest.
    pub selection: Option<crate::sensor::Selection>,
    /// Power image: chirp bandwidth, Hz.
    pub bandwidth_hz: Option<Bandwidth>,
    /// Power image: mean noise power, dB.
    pub noise_floor_db: Option<Threshold>,
    /// Power image: dB above the noise floor shown as 255.
    pub display_range_db: Option<DynamicRange>,
    /// Power image: speckle on or off.
    pub speckle: Option<bool>,
}
