//! The serde shape of a scenario file (DESIGN §2). Values are range-checked while they are
//! read, so a bad value is reported at its own line and column.

use serde::Deserialize;
use serde::de::{Deserializer, Error as _};
use toml::Spanned;

macro_rules! checked_f64 {
    ($(#[$doc:meta] $name:ident: $ok:expr, $what:literal;)*) => {$(
        #[$doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $name(pub f64);

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let v = f64::deserialize(d)?;
                let ok: fn(f64) -> bool = $ok;
                if ok(v) {
                    Ok(Self(v))
                } else {
                    Err(D::Error::custom(format!("expected {}, found {v}", $what)))
                }
            }
        }
    )*};
}

checked_f64! {
    /// A finite number.
    Finite: f64::is_finite, "a finite number";
    /// A finite number > 0.
    Positive: |v| v.is_finite() && v > 0.0, "a finite number > 0";
    /// A number ≥ 0; `inf` allowed (a solid's attenuation).
    NonNegative: |v| v >= 0.0, "a number >= 0";
    /// A number in [0, 1].
    Fraction: |v| (0.0..=1.0).contains(&v), "a number from 0 to 1";
    /// A volume backscatter coefficient, 1/m.
    Backscatter: |v| (0.0..=10.0).contains(&v), "a number from 0 to 10 (1/m)";
    /// A laser extinction coefficient, 1/m.
    Extinction: |v| (0.0..=100.0).contains(&v), "a number from 0 to 100 (1/m)";
    /// A lobe width in degrees.
    LobeDeg: |v| (0.1..=90.0).contains(&v), "a number from 0.1 to 90 (degrees)";
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
        let v = Vec::<Finite>::deserialize(d)?;
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
pub type Xy = [Finite; 2];

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
    #[serde(default, rename = "object")]
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
    pub mline_tolerance: Option<Positive>,
    /// bug: distance to a hit or leave point that counts as back at it, m (default 0.75).
    pub loop_tolerance: Option<Positive>,
    /// bug, explore: side the obstacle is kept on when following it, `left` or `right`.
    pub follow: Option<Spanned<String>>,
    /// bug, explore: the pose navigation believes, `odometry` (default) or `truth`.
    pub pose: Option<Spanned<String>>,
    /// bug, explore: the virtual bumpers.
    pub bumpers: Option<Spanned<BumperSpec>>,
    /// The robot that runs it (default: the first).
    pub robot: Option<Spanned<String>>,
    /// How often the controller is called, Hz (default 10).
    pub controller_hz: Option<Positive>,
    /// teleop: the commands, in order.
    pub commands: Option<Vec<Spanned<TeleopStepSpec>>>,
    /// teleop: a CSV file of commands, relative to the scenario file.
    pub file: Option<Spanned<String>>,
    /// waypoints: the points to visit, `[x, y]` each.
    pub points: Option<Vec<Xy>>,
    /// waypoints, bug, explore: cruise speed, m/s (default 0.5 for waypoints, 0.4 otherwise).
    pub speed: Option<Positive>,
    /// waypoints, bug: distance at which a point counts as reached, m (default 0.15 for
    /// waypoints, 0.3 for a bug goal).
    pub tolerance: Option<Positive>,
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
    pub safety: Option<Positive>,
    /// Pressed band beyond the safety distance, m (default 0.5).
    pub band: Option<Positive>,
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
    pub duration: Positive,
    /// Forward speed, m/s.
    pub v: Option<Finite>,
    /// Turn rate, degrees/s counter-clockwise.
    pub omega_deg_s: Option<Finite>,
    /// Left track speed, m/s.
    pub left: Option<Finite>,
    /// Right track speed, m/s.
    pub right: Option<Finite>,
}

/// `[sim]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimSpec {
    /// Step, seconds.
    #[serde(default = "default_dt")]
    pub dt: Positive,
    /// Length of a run, seconds.
    #[serde(default = "default_duration")]
    pub duration: Positive,
    /// Seed of the run's RNG.
    #[serde(default)]
    pub seed: u64,
}

fn default_dt() -> Positive {
    Positive(0.05)
}

fn default_duration() -> Positive {
    Positive(60.0)
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
    /// Unique name; re-using a built-in's name replaces it.
    pub name: String,
    /// Material whose values the unset fields take.
    pub base: Option<Spanned<String>>,
    /// One-way dB/m; `inf` for a solid.
    pub radar_attenuation_db_per_m: Option<NonNegative>,
    /// Power fraction reflected at entry.
    pub radar_reflectivity: Option<Fraction>,
    /// Mirror-like to radar.
    pub specular: Option<bool>,
    /// Volume backscatter η, 1/m (0–10).
    pub radar_backscatter_per_m: Option<Backscatter>,
    /// Full width of a specular echo lobe, degrees (0.1–90).
    pub specular_lobe_deg: Option<LobeDeg>,
    /// Stops a laser at its surface.
    pub laser_opaque: Option<bool>,
    /// Laser dB/m when not opaque (default for an aerosol: 4.343 × its extinction).
    pub laser_attenuation_db_per_m: Option<NonNegative>,
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
}

/// Sphere fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre; `[x, y]` rests it on the ground.
    pub center: Center,
    /// Radius, m.
    pub radius: Positive,
}

/// Box fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Centre; `[x, y]` rests it on the ground.
    pub center: Center,
    /// Full size along its own axes, m.
    pub size: [Positive; 3],
    /// Rotation about z, degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Finite,
}

fn zero() -> Finite {
    Finite(0.0)
}

/// Cylinder fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSpec {
    /// Centre of the axis; `[x, y]` stands it on the ground.
    pub center: Center,
    /// Radius, m.
    pub radius: Positive,
    /// Height, m.
    pub height: Positive,
}

/// Wall fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Polyline of the wall's centre line.
    pub points: Vec<Xy>,
    /// Thickness, m.
    pub thickness: Positive,
    /// Height, m.
    pub height: Positive,
}

/// Prism fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PrismSpec {
    /// Polygon in the xy plane.
    pub polygon: Vec<Xy>,
    /// Bottom, m (default 0).
    #[serde(default = "zero")]
    pub z_min: Finite,
    /// Top, m.
    pub z_max: Finite,
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
}

/// `[robot.odometry]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometrySpec {
    /// Relative standard deviation of each track speed per step.
    pub speed_noise: Option<NonNegative>,
    /// Constant turn-rate error, degrees/s.
    pub yaw_drift_deg_s: Option<Finite>,
    /// Turn-rate white noise, degrees/s.
    pub yaw_noise_deg_s: Option<NonNegative>,
}

fn default_vehicle() -> Spanned<String> {
    Spanned::new(0..0, "p3at".to_owned())
}

/// `{ x, y, yaw_deg }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanarPose {
    /// m.
    pub x: Finite,
    /// m.
    pub y: Finite,
    /// Degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Finite,
}

/// `{ x, y, z, yaw_deg }` relative to the robot.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountSpec {
    /// m forward.
    #[serde(default = "zero")]
    pub x: Finite,
    /// m left.
    #[serde(default = "zero")]
    pub y: Finite,
    /// m above the ground.
    #[serde(default = "default_mount_z")]
    pub z: Finite,
    /// Degrees.
    #[serde(default = "zero")]
    pub yaw_deg: Finite,
}

/// Height of a sensor on top of a P3AT (0.277 m body) on a small post.
pub const DEFAULT_MOUNT_Z: f64 = 0.4;

fn default_mount_z() -> Finite {
    Finite(DEFAULT_MOUNT_Z)
}

impl Default for MountSpec {
    fn default() -> Self {
        Self {
            x: zero(),
            y: zero(),
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
    pub fov_deg: Option<Positive>,
    /// Override: angular step, degrees.
    pub resolution_deg: Option<Positive>,
    /// Override, m.
    pub range_min: Option<NonNegative>,
    /// Override, m.
    pub range_max: Option<Positive>,
    /// Override, Hz.
    pub rate_hz: Option<Positive>,
    /// Override: scan planes, degrees.
    pub elevations_deg: Option<Vec<Finite>>,
    /// Override, m.
    pub range_noise_std: Option<NonNegative>,
    /// Override, fraction of range.
    pub range_noise_rel: Option<NonNegative>,
    /// Override, dB.
    pub penetration_db: Option<Positive>,
    /// Override, m.
    pub side_beam_offset: Option<NonNegative>,
    /// Override: range bin of a binned radar, m.
    pub range_bin: Option<Positive>,
    /// Return mode: thesis, first, strongest, last, all (DESIGN §7.3).
    #[serde(rename = "return")]
    pub return_mode: Option<crate::sensor::ReturnMode>,
    /// Echo range law: r2, r4, flat.
    pub range_law: Option<crate::sensor::RangeLaw>,
    /// dB, 1–200.
    pub dynamic_range_db: Option<Finite>,
    /// dB, −200–0.
    pub detection_threshold_db: Option<Finite>,
    /// Echoes per azimuth in `all` mode, 1–64.
    pub max_echoes: Option<u32>,
    /// Specular bounces, 0–8.
    pub max_bounces: Option<u8>,
    /// Beam rays across azimuth (× `beam_rays_el` ≤ 64).
    pub beam_rays: Option<u32>,
    /// Beam rays across elevation.
    pub beam_rays_el: Option<u32>,
    /// −3 dB beam width in azimuth, degrees.
    pub beamwidth_az_deg: Option<NonNegative>,
    /// −3 dB beam width in elevation, degrees.
    pub beamwidth_el_deg: Option<NonNegative>,
    /// Beam ray selection: uniform, incidence_weighted, nearest, strongest.
    pub selection: Option<crate::sensor::Selection>,
    /// Power image: chirp bandwidth, Hz.
    pub bandwidth_hz: Option<Positive>,
    /// Power image: mean noise power, dB.
    pub noise_floor_db: Option<Finite>,
    /// Power image: dB above the noise floor shown as 255.
    pub display_range_db: Option<Positive>,
    /// Power image: speckle on or off.
    pub speckle: Option<bool>,
}
