//! Scenario files (TOML, DESIGN §2) and the built-in scenarios.
//!
//! ```toml
//! description = "what it is for"
//! [sim]
//! seed = 1
//! [[material]]
//! name = "wet_hedge"
//! base = "foliage_dense"
//! radar_attenuation_db_per_m = 7.0
//! [[object]]
//! name = "bush"
//! material = "wet_hedge"
//! sphere = { center = [3.0, 1.0], radius = 0.8 }   # [x, y] rests it on the ground
//! [[robot]]
//! name = "p3at"
//! start = { x = 0.0, y = 0.0, yaw_deg = 0.0 }
//! [[robot.sensor]]
//! name = "radar"
//! preset = "radar_thesis"
//! mount = { z = 0.4 }
//! ```

mod builtin;
pub mod mesh_file;
pub mod spec;

use crate::setup::bumpers_on_first_echoes;
/// The values this module builds, defined in [`crate::setup`] so the simulation needs no TOML.
pub use crate::setup::{MountedSensor, Robot, Scenario, SimSettings};
pub use builtin::{BUILTIN_SCENARIOS, NAV_SUITE, builtin_source};

use glam::{DVec2, DVec3};
use std::ops::Range;
use thiserror::Error;
use toml::Spanned;

use crate::map::PoseSource;
use crate::mission::{
    DEFAULT_CONTROLLER_HZ, Mission, MissionKind, TeleopSource, TeleopStep, WaypointMission,
};
use crate::nav::{
    BugAlgorithm, BugMission, BumperConfig, BumperRule, ExploreMission, Side, Strategy,
};
use crate::pose::Pose;
use crate::sensor::{SensorKind, preset};
use crate::vehicle::{DriveCommand, OdometryNoise, VEHICLES, vehicle};
use crate::world::{
    DB_PER_UNIT_EXTINCTION, DEFAULT_SPECULAR_LOBE_DEG, Material, MaterialTable, Object, Shape,
    World,
};
use spec::{Center, MissionSpec, ObjectSpec, ScenarioSpec, SensorSpec, Xy};

/// A scenario file that could not be used: where, which key, and what is wrong.
#[derive(Debug, Error, PartialEq)]
#[error("{file}:{line}:{column}: {}{message}", key.as_ref().map(|k| format!("`{k}`: ")).unwrap_or_default())]
pub struct ScenarioError {
    /// File name as given by the caller.
    pub file: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column (in characters).
    pub column: usize,
    /// The key at fault, when one is.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}

struct Ctx<'a> {
    src: &'a str,
    file: &'a str,
    /// Where files the scenario names (meshes) are looked for: beside it.
    dir: &'a std::path::Path,
}

impl Ctx<'_> {
    fn err(
        &self,
        span: Range<usize>,
        key: Option<&str>,
        message: impl Into<String>,
    ) -> ScenarioError {
        let start = span.start.min(self.src.len());
        let before = &self.src[..start];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        ScenarioError {
            file: self.file.to_owned(),
            line,
            column,
            key: key.map(str::to_owned).or_else(|| key_at(self.src, &span)),
            message: message.into(),
        }
    }
}

/// The key a span points at: the span itself when it is a bare key, else the key written
/// before `=` on the span's line.
fn key_at(src: &str, span: &Range<usize>) -> Option<String> {
    let is_key = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    let text = src.get(span.clone())?;
    if !text.is_empty() && text.chars().all(is_key) && !text.chars().all(|c| c.is_ascii_digit()) {
        let after = src[span.end..].trim_start();
        if after.starts_with('=') {
            return Some(text.to_owned());
        }
    }
    let line_start = src[..span.start].rfind('\n').map_or(0, |i| i + 1);
    let head = src[line_start..span.start]
        .trim_end()
        .strip_suffix('=')?
        .trim_end();
    let key: String = head.chars().rev().take_while(|&c| is_key(c)).collect();
    (!key.is_empty()).then(|| key.chars().rev().collect())
}

impl Scenario {
    /// Parses and checks a scenario. `file` names it in error messages, and files it names
    /// (meshes) are looked for beside it.
    pub fn from_toml(src: &str, file: &str, name: &str) -> Result<Scenario, ScenarioError> {
        let dir = std::path::Path::new(file)
            .parent()
            .unwrap_or(std::path::Path::new(""));
        let ctx = Ctx { src, file, dir };
        let spec: ScenarioSpec = toml::from_str(src).map_err(|e| {
            ctx.err(
                e.span().unwrap_or(0..0),
                None,
                e.message().trim_end().to_owned(),
            )
        })?;
        let materials = build_materials(&ctx, &spec)?;
        let mut objects = Vec::with_capacity(spec.objects.len());
        for o in &spec.objects {
            objects.extend(build_object(&ctx, &materials, o)?);
        }
        let mut robots: Vec<Robot> = Vec::new();
        for r in &spec.robots {
            let robot = build_robot(&ctx, r)?;
            if robots.iter().any(|x| x.name == robot.name) {
                return Err(ctx.err(
                    r.span(),
                    Some("name"),
                    format!("robot name `{}` is used twice", robot.name),
                ));
            }
            robots.push(robot);
        }
        let mission = spec
            .mission
            .as_ref()
            .map(|m| build_mission(&ctx, m, &robots))
            .transpose()?;
        if let Some(m) = &mission {
            bumpers_on_first_echoes(m, &mut robots);
        }
        Ok(Scenario {
            name: name.to_owned(),
            description: spec.description,
            sim: SimSettings {
                dt: spec.sim.dt.0,
                duration: spec.sim.duration.0,
                seed: spec.sim.seed,
            },
            world: World::new(materials, objects),
            robots,
            mission,
        })
    }

    /// A built-in scenario by name.
    pub fn builtin(name: &str) -> Option<Scenario> {
        let src = builtin_source(name)?;
        // The built-ins are tested to parse, so an error here is a bug in this crate.
        Some(
            Self::from_toml(src, &format!("scenarios/{name}.toml"), name)
                .unwrap_or_else(|e| panic!("built-in scenario is invalid: {e}")),
        )
    }
}

/// A scenario that could not be loaded by [`load`].
#[derive(Debug, Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("reading scenario file {path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        cause: std::io::Error,
    },
    /// The file is not a valid scenario.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// Neither a file nor a built-in.
    #[error("`{name}` is neither a file nor a built-in scenario ({known})")]
    Unknown {
        /// What was asked for.
        name: String,
        /// The built-ins, comma-separated.
        known: String,
    },
}

/// A scenario by file path (an existing file, or any name ending in `.toml`) or built-in name:
/// what every front end (CLI, Python) means by a scenario argument.
pub fn load(name_or_path: &str) -> Result<Scenario, LoadError> {
    let path = std::path::Path::new(name_or_path);
    if path.is_file() || name_or_path.ends_with(".toml") {
        let src = crate::limits::read_text(path).map_err(|e| LoadError::Io {
            path: name_or_path.to_owned(),
            cause: e,
        })?;
        let name = path.file_stem().map_or_else(
            || name_or_path.to_owned(),
            |s| s.to_string_lossy().into_owned(),
        );
        return Ok(Scenario::from_toml(&src, name_or_path, &name)?);
    }
    Scenario::builtin(name_or_path).ok_or_else(|| LoadError::Unknown {
        name: name_or_path.to_owned(),
        known: BUILTIN_SCENARIOS
            .iter()
            .chain(NAV_SUITE)
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
    })
}

fn build_materials(ctx: &Ctx, spec: &ScenarioSpec) -> Result<MaterialTable, ScenarioError> {
    let mut table = MaterialTable::default();
    let mut seen: Vec<&str> = Vec::new();
    for m in &spec.materials {
        let span = m.span();
        let m = m.get_ref();
        if seen.contains(&m.name.as_str()) {
            return Err(ctx.err(
                span,
                Some("name"),
                format!("material `{}` is defined twice", m.name),
            ));
        }
        if MaterialTable::default().id(&m.name).is_some() {
            return Err(ctx.err(
                span,
                Some("name"),
                format!(
                    "`{0}` is a built-in material; give yours another name (with `base = \"{0}\"` to start from it)",
                    m.name
                ),
            ));
        }
        seen.push(&m.name);
        let base = match &m.base {
            Some(b) => {
                let id = table.id(b.get_ref()).ok_or_else(|| {
                    ctx.err(
                        b.span(),
                        Some("base"),
                        unknown_material(b.get_ref(), &table),
                    )
                })?;
                Some(table.get(id).clone())
            }
            None => None,
        };
        let radar = m
            .radar_attenuation_db_per_m
            .map(|v| v.0)
            .or(base.as_ref().map(|b| b.radar_attenuation_db_per_m))
            .ok_or_else(|| {
                ctx.err(span.clone(), None, "missing field `radar_attenuation_db_per_m` (or a `base` material to take it from)")
            })?;
        let color = match &m.color {
            Some(c) => parse_color(c.get_ref()).ok_or_else(|| {
                ctx.err(
                    c.span(),
                    Some("color"),
                    format!("expected \"#rrggbb\", found \"{}\"", c.get_ref()),
                )
            })?,
            None => base
                .as_ref()
                .map_or_else(|| hashed_color(&m.name), |b| b.color),
        };
        let laser_opaque = m
            .laser_opaque
            .or(base.as_ref().map(|b| b.laser_opaque))
            .unwrap_or(true);
        let extinction = m
            .laser_extinction_per_m
            .map(|v| v.0)
            .or(base.as_ref().map(|b| b.laser_extinction_per_m))
            .unwrap_or(0.0);
        let material = Material {
            name: m.name.clone(),
            radar_attenuation_db_per_m: radar,
            radar_reflectivity: m
                .radar_reflectivity
                .map(|v| v.0)
                .or(base.as_ref().map(|b| b.radar_reflectivity))
                .unwrap_or(0.5),
            specular: m
                .specular
                .or(base.as_ref().map(|b| b.specular))
                .unwrap_or(false),
            radar_backscatter_per_m: m
                .radar_backscatter_per_m
                .map(|v| v.0)
                .or(base.as_ref().map(|b| b.radar_backscatter_per_m))
                .unwrap_or(0.0),
            specular_lobe: m
                .specular_lobe_deg
                .map(|v| v.0.to_radians())
                .or(base.as_ref().map(|b| b.specular_lobe))
                .unwrap_or(DEFAULT_SPECULAR_LOBE_DEG.to_radians()),
            radar_diffuse: m
                .radar_diffuse
                .map(|v| v.0)
                .or(base.as_ref().map(|b| b.radar_diffuse))
                .unwrap_or(0.0),
            laser_opaque,
            // An opaque base stores an infinite laser attenuation; a variant made see-through
            // must not inherit it, or `laser_opaque = false` would change nothing.
            laser_attenuation_db_per_m: m
                .laser_attenuation_db_per_m
                .map(|v| v.0)
                .or(base
                    .as_ref()
                    .map(|b| b.laser_attenuation_db_per_m)
                    .filter(|a| a.is_finite() || laser_opaque))
                .unwrap_or(if laser_opaque {
                    f64::INFINITY
                } else {
                    DB_PER_UNIT_EXTINCTION * extinction
                }),
            laser_extinction_per_m: extinction,
            traversable: m
                .traversable
                .or(base.as_ref().map(|b| b.traversable))
                .unwrap_or(false),
            color,
        };
        table
            .insert(material)
            .ok_or_else(|| ctx.err(span, None, "too many materials (at most 65535)"))?;
    }
    Ok(table)
}

fn unknown_material(name: &str, table: &MaterialTable) -> String {
    format!(
        "unknown material `{name}`; known: {}",
        table.names().join(", ")
    )
}

fn parse_color(s: &str) -> Option<[u8; 3]> {
    let hex = s.strip_prefix('#')?;
    if hex.len() != 6 || !hex.is_ascii() {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?])
}

/// A stable colour for a user material without one (FNV-1a of the name).
fn hashed_color(name: &str) -> [u8; 3] {
    let h = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    [
        64 + (h & 0x7f) as u8,
        64 + ((h >> 8) & 0x7f) as u8,
        64 + ((h >> 16) & 0x7f) as u8,
    ]
}

fn center(c: &Center, rest_height: f64) -> DVec3 {
    DVec3::new(c.xy[0], c.xy[1], c.z.unwrap_or(rest_height))
}

fn xy(points: &[Xy]) -> Vec<DVec2> {
    points.iter().map(|p| DVec2::new(p[0].0, p[1].0)).collect()
}

/// The objects of one `[[object]]`: one, or one per named part of a mesh file.
fn build_object(
    ctx: &Ctx,
    materials: &MaterialTable,
    o: &Spanned<ObjectSpec>,
) -> Result<Vec<Object>, ScenarioError> {
    let span = o.span();
    let spec = o.get_ref();
    let material = materials.id(spec.material.get_ref()).ok_or_else(|| {
        ctx.err(
            spec.material.span(),
            Some("material"),
            unknown_material(spec.material.get_ref(), materials),
        )
    })?;
    let given = [
        spec.sphere.is_some(),
        spec.cuboid.is_some(),
        spec.cylinder.is_some(),
        spec.wall.is_some(),
        spec.prism.is_some(),
        spec.mesh.is_some(),
    ]
    .iter()
    .filter(|g| **g)
    .count();
    if given != 1 {
        return Err(ctx.err(
            span,
            None,
            format!("an object needs exactly one shape (sphere, box, cylinder, wall, prism or mesh), found {given}"),
        ));
    }
    if let Some(m) = &spec.mesh {
        return build_mesh(ctx, materials, spec, material, m);
    }
    let (shape, shape_span) = if let Some(s) = &spec.sphere {
        (
            Shape::sphere(center(&s.center, s.radius.0), s.radius.0),
            span.clone(),
        )
    } else if let Some(b) = &spec.cuboid {
        let size = DVec3::new(b.size[0].0, b.size[1].0, b.size[2].0);
        (
            Shape::cuboid(
                center(&b.center, size.z / 2.0),
                size,
                b.yaw_deg.0.to_radians(),
            ),
            span.clone(),
        )
    } else if let Some(c) = &spec.cylinder {
        (
            Shape::cylinder(center(&c.center, c.height.0 / 2.0), c.radius.0, c.height.0),
            span.clone(),
        )
    } else if let Some(w) = &spec.wall {
        let ws = w.get_ref();
        (
            Shape::wall(xy(&ws.points), ws.thickness.0, ws.height.0),
            w.span(),
        )
    } else if let Some(p) = &spec.prism {
        let ps = p.get_ref();
        (
            Shape::prism(xy(&ps.polygon), ps.z_min.0, ps.z_max.0),
            p.span(),
        )
    } else {
        unreachable!("exactly one shape was checked above")
    };
    let shape = shape.map_err(|e| ctx.err(shape_span, None, e.to_string()))?;
    Ok(vec![Object {
        name: spec.name.clone(),
        shape,
        material,
    }])
}

/// A `mesh` object: the file read and placed, one object per part (by the material names the
/// file gives its faces, through `materials`); an open part must be of a material no ray can
/// enter.
fn build_mesh(
    ctx: &Ctx,
    materials: &MaterialTable,
    spec: &ObjectSpec,
    material: crate::world::MaterialId,
    m: &Spanned<spec::MeshSpec>,
) -> Result<Vec<Object>, ScenarioError> {
    use crate::world::procedural::{BARK, Plant, grow};
    use mesh_file::{Placement, Up};
    let ms = m.get_ref();
    let (source, source_span) = match (&ms.file, &ms.generate) {
        (Some(f), None) => (f.get_ref().clone(), f.span()),
        (None, Some(g)) => (format!("generated {}", g.get_ref()), g.span()),
        _ => {
            return Err(ctx.err(
                m.span(),
                None,
                "a mesh needs exactly one of `file` (an OBJ or glTF file) or `generate` (\"tree\" or \"bush\")",
            ));
        }
    };
    let gltf = [".gltf", ".glb"]
        .iter()
        .any(|e| source.to_ascii_lowercase().ends_with(e));
    let up = match ms.up.as_ref().map(|u| (u.get_ref().as_str(), u.span())) {
        None if gltf => Up::Y,
        None => Up::Z,
        Some(("z", _)) => Up::Z,
        Some(("y", _)) => Up::Y,
        Some((other, span)) => {
            return Err(ctx.err(
                span,
                Some("up"),
                format!("expected \"z\" or \"y\", found `{other}`"),
            ));
        }
    };
    let placement = Placement {
        up,
        scale: ms.scale.0,
        yaw: ms.yaw_deg.0.to_radians(),
        center: ms.center.as_ref().map_or(DVec3::ZERO, |c| center(c, 0.0)),
    };
    let parts = match &ms.generate {
        Some(g) => {
            let plant = Plant::parse(g.get_ref()).ok_or_else(|| {
                ctx.err(
                    g.span(),
                    Some("generate"),
                    format!("expected \"tree\" or \"bush\", found `{}`", g.get_ref()),
                )
            })?;
            let height = ms.height.map_or(plant.default_height(), |h| h.0);
            placement.place(grow(plant, height, ms.seed.unwrap_or(1)))
        }
        None => mesh_file::load(&ctx.dir.join(&source), &placement)
            .map_err(|e| ctx.err(source_span.clone(), Some("file"), e))?,
    };
    for name in ms.materials.keys() {
        if !parts
            .iter()
            .any(|p| p.material.as_deref() == Some(name.as_str()))
        {
            let known: Vec<&str> = parts.iter().filter_map(|p| p.material.as_deref()).collect();
            return Err(ctx.err(
                ms.materials[name].span(),
                Some(name),
                format!(
                    "the file has no part `{name}`; its parts: {}",
                    if known.is_empty() {
                        "(none named)".to_owned()
                    } else {
                        known.join(", ")
                    }
                ),
            ));
        }
    }
    let mut out = Vec::with_capacity(parts.len());
    for part in parts {
        let (id, where_) = match part.material.as_ref().and_then(|n| ms.materials.get(n)) {
            Some(name) => {
                let id = materials.id(name.get_ref()).ok_or_else(|| {
                    ctx.err(
                        name.span(),
                        None,
                        unknown_material(name.get_ref(), materials),
                    )
                })?;
                (id, name.span())
            }
            // A generated plant's wood is wood unless said otherwise.
            None if ms.generate.is_some() && part.material.as_deref() == Some(BARK) => (
                materials.id("wood").unwrap_or(material),
                spec.material.span(),
            ),
            None => (material, spec.material.span()),
        };
        let label = part
            .material
            .clone()
            .unwrap_or_else(|| "(unnamed)".to_owned());
        let mesh =
            crate::world::mesh::TriMesh::new(part.vertices, part.triangles).map_err(|e| {
                ctx.err(
                    source_span.clone(),
                    None,
                    format!("{source}: part {label}: {e}"),
                )
            })?;
        let mat = materials.get(id);
        let enterable = [crate::world::Band::Radar, crate::world::Band::Laser]
            .iter()
            .any(|&b| !mat.attenuation_db_per_m(b).is_infinite());
        if enterable && !mesh.is_closed() {
            return Err(ctx.err(
                where_,
                None,
                format!(
                    "{source}: part {label} is not closed ({}), but material `{}` can be entered by a ray: a penetrable mesh must be closed (watertight)",
                    mesh.why_open(),
                    mat.name
                ),
            ));
        }
        let name = match (&spec.name, &part.material) {
            (Some(n), Some(p)) => Some(format!("{n}/{p}")),
            (n, _) => n.clone(),
        };
        // A file's closed part of shells far apart (a whole scene exported as one mesh) goes
        // into the world piece by piece, each found through the grid like any object; the
        // generated plants are kept whole, as they always were.
        let pieces = if ms.file.is_some() {
            mesh.into_apart()
        } else {
            vec![mesh]
        };
        for piece in pieces {
            out.push(Object {
                name: name.clone(),
                shape: Shape::Mesh(std::sync::Arc::new(piece)),
                material: id,
            });
        }
    }
    Ok(out)
}

fn build_robot(ctx: &Ctx, r: &Spanned<spec::RobotSpec>) -> Result<Robot, ScenarioError> {
    let spec = r.get_ref();
    let Some(vehicle) = vehicle(spec.vehicle.get_ref()) else {
        let known: Vec<&str> = VEHICLES.iter().map(|v| v.name).collect();
        return Err(ctx.err(
            spec.vehicle.span(),
            Some("vehicle"),
            format!(
                "unknown vehicle `{}`; known: {}",
                spec.vehicle.get_ref(),
                known.join(", ")
            ),
        ));
    };
    let mut sensors: Vec<MountedSensor> = Vec::new();
    for s in &spec.sensors {
        let sensor = build_sensor(ctx, s)?;
        if sensors.iter().any(|x| x.name == sensor.name) {
            return Err(ctx.err(
                s.span(),
                Some("name"),
                format!(
                    "sensor name `{}` is used twice on robot `{}`",
                    sensor.name, spec.name
                ),
            ));
        }
        sensors.push(sensor);
    }
    let o = &spec.odometry;
    let d = OdometryNoise::default();
    let odometry = OdometryNoise {
        speed_noise: o.speed_noise.map_or(d.speed_noise, |v| v.0),
        yaw_drift: o.yaw_drift_deg_s.map_or(d.yaw_drift, |v| v.0.to_radians()),
        yaw_noise: o.yaw_noise_deg_s.map_or(d.yaw_noise, |v| v.0.to_radians()),
    };
    if odometry.yaw_noise < 0.0 {
        return Err(ctx.err(
            r.span(),
            Some("yaw_noise_deg_s"),
            "a noise's standard deviation must be >= 0",
        ));
    }
    let slam = slam_config(ctx, spec, &sensors)?;
    Ok(Robot {
        name: spec.name.clone(),
        vehicle,
        odometry,
        slam,
        start: Pose::new(
            spec.start.x.0,
            spec.start.y.0,
            0.0,
            spec.start.yaw_deg.0.to_radians(),
        ),
        sensors,
    })
}

/// The robot's localiser: `[robot.slam]`, by default on its first radar, else its first
/// laser (none on a robot with neither, or with `enabled = false`).
fn slam_config(
    ctx: &Ctx,
    spec: &spec::RobotSpec,
    sensors: &[MountedSensor],
) -> Result<Option<crate::slam::SlamConfig>, ScenarioError> {
    let table = spec.slam.as_ref().map(|s| s.get_ref());
    if table.and_then(|t| t.enabled) == Some(false) {
        return Ok(None);
    }
    let index = match table.and_then(|t| t.sensor.as_ref()) {
        Some(name) => Some(
            sensors
                .iter()
                .position(|s| &s.name == name.get_ref())
                .ok_or_else(|| {
                    let known: Vec<&str> = sensors.iter().map(|s| s.name.as_str()).collect();
                    ctx.err(
                        name.span(),
                        Some("sensor"),
                        format!(
                            "robot `{}` has no sensor `{}`; it has: {}",
                            spec.name,
                            name.get_ref(),
                            known.join(", ")
                        ),
                    )
                })?,
        ),
        None => [SensorKind::Radar, SensorKind::Laser]
            .iter()
            .find_map(|k| sensors.iter().position(|s| s.config.kind == *k)),
    };
    Ok(index.map(|i| {
        let mut c = crate::slam::SlamConfig::for_sensor(i);
        if let Some(t) = table {
            c.resolution = t.resolution.map_or(c.resolution, |v| v.0);
            c.max_range = t.max_range.map_or(c.max_range, |v| v.0);
            c.loop_closure = t.loop_closure.unwrap_or(c.loop_closure);
        }
        c
    }))
}

fn build_sensor(ctx: &Ctx, s: &Spanned<SensorSpec>) -> Result<MountedSensor, ScenarioError> {
    let spec = s.get_ref();
    let mut c = preset(spec.preset.get_ref()).ok_or_else(|| {
        let known: Vec<&str> = crate::sensor::PRESETS.iter().map(|p| p.name).collect();
        ctx.err(
            spec.preset.span(),
            Some("preset"),
            format!(
                "unknown sensor preset `{}`; known: {}",
                spec.preset.get_ref(),
                known.join(", ")
            ),
        )
    })?;
    let set = |field: &mut f64, v: Option<f64>| {
        if let Some(v) = v {
            *field = v;
        }
    };
    set(&mut c.fov, spec.fov_deg.map(|v| v.0.to_radians()));
    set(
        &mut c.resolution,
        spec.resolution_deg.map(|v| v.0.to_radians()),
    );
    set(&mut c.range_min, spec.range_min.map(|v| v.0));
    set(&mut c.range_max, spec.range_max.map(|v| v.0));
    set(&mut c.rate_hz, spec.rate_hz.map(|v| v.0));
    set(&mut c.range_noise_std, spec.range_noise_std.map(|v| v.0));
    set(&mut c.range_noise_rel, spec.range_noise_rel.map(|v| v.0));
    set(&mut c.penetration_db, spec.penetration_db.map(|v| v.0));
    set(&mut c.side_beam_offset, spec.side_beam_offset.map(|v| v.0));
    if let Some(el) = &spec.elevations_deg {
        c.elevations = el.iter().map(|e| e.0.to_radians()).collect();
    }
    if let Some(b) = spec.range_bin {
        c.range_bin = Some(b.0);
    }
    let g = &mut c.signal;
    if let Some(m) = spec.return_mode {
        g.return_mode = m;
    }
    if let Some(l) = spec.range_law {
        g.range_law = l;
    }
    if let Some(sel) = spec.selection {
        g.selection = sel;
    }
    set(&mut g.dynamic_range_db, spec.dynamic_range_db.map(|v| v.0));
    set(
        &mut g.detection_threshold_db,
        spec.detection_threshold_db.map(|v| v.0),
    );
    set(
        &mut g.beamwidth_az,
        spec.beamwidth_az_deg.map(|v| v.0.to_radians()),
    );
    set(
        &mut g.beamwidth_el,
        spec.beamwidth_el_deg.map(|v| v.0.to_radians()),
    );
    if let Some(n) = spec.max_echoes {
        g.max_echoes = n as usize;
    }
    if let Some(n) = spec.max_bounces {
        g.max_bounces = n;
    }
    if let Some(n) = spec.beam_rays {
        g.beam_rays_az = n as usize;
    }
    if let Some(n) = spec.beam_rays_el {
        g.beam_rays_el = n as usize;
    }
    let image_keys = spec.bandwidth_hz.is_some()
        || spec.noise_floor_db.is_some()
        || spec.display_range_db.is_some()
        || spec.speckle.is_some();
    if image_keys && g.image.is_none() {
        return Err(ctx.err(
            s.span(),
            None,
            format!(
                "sensor `{}`: bandwidth_hz, noise_floor_db, display_range_db and speckle need a preset with a power image (navtech_cts350x, navtech_cir204h, fmcw_scanning)",
                spec.name
            ),
        ));
    }
    if let Some(im) = &mut g.image {
        set(&mut im.bandwidth_hz, spec.bandwidth_hz.map(|v| v.0));
        set(&mut im.noise_floor_db, spec.noise_floor_db.map(|v| v.0));
        set(&mut im.display_range_db, spec.display_range_db.map(|v| v.0));
        if let Some(sp) = spec.speckle {
            im.speckle = sp;
        }
    }
    if c.signal.return_mode != crate::sensor::ReturnMode::Thesis
        && c.kind != crate::sensor::SensorKind::Radar
    {
        return Err(ctx.err(
            s.span(),
            Some("return"),
            format!("sensor `{}`: echo return modes are for radars", spec.name),
        ));
    }
    c.validate().map_err(|msg| {
        let key = msg.split_whitespace().next().map(str::to_owned);
        ctx.err(
            s.span(),
            key.as_deref(),
            format!("sensor `{}`: {msg}", spec.name),
        )
    })?;
    let m = &spec.mount;
    Ok(MountedSensor {
        name: spec.name.clone(),
        config: c,
        mount: Pose::new(m.x.0, m.y.0, m.z.0, m.yaw_deg.0.to_radians()),
    })
}

fn build_mission(
    ctx: &Ctx,
    m: &Spanned<MissionSpec>,
    robots: &[Robot],
) -> Result<Mission, ScenarioError> {
    let span = m.span();
    let spec = m.get_ref();
    if let Some(r) = &spec.robot
        && !robots.iter().any(|x| &x.name == r.get_ref())
    {
        let known: Vec<&str> = robots.iter().map(|x| x.name.as_str()).collect();
        return Err(ctx.err(
            r.span(),
            Some("robot"),
            format!(
                "unknown robot `{}`; robots: {}",
                r.get_ref(),
                known.join(", ")
            ),
        ));
    }
    if robots.is_empty() {
        return Err(ctx.err(span, None, "a mission needs a `[[robot]]` to run it"));
    }
    let kind_name = match (&spec.kind, &spec.explore) {
        (Some(k), _) => k.get_ref().as_str(),
        (None, Some(_)) => "explore",
        (None, None) => {
            return Err(ctx.err(
                span,
                None,
                "a mission needs `type` (teleop, waypoints, bug1, bug2) or `explore`",
            ));
        }
    };
    let kind_span = spec.kind.as_ref().map_or(span.clone(), |k| k.span());
    // Keys that belong to another kind are mistakes worth reporting, not ignoring.
    let given = [
        ("commands", spec.commands.is_some()),
        ("file", spec.file.is_some()),
        ("points", spec.points.is_some()),
        ("loop", spec.repeat.is_some()),
        ("speed", spec.speed.is_some()),
        ("tolerance", spec.tolerance.is_some()),
        ("goal", spec.goal.is_some()),
        ("mline_tolerance", spec.mline_tolerance.is_some()),
        ("loop_tolerance", spec.loop_tolerance.is_some()),
        ("follow", spec.follow.is_some()),
        ("pose", spec.pose.is_some()),
        ("bumpers", spec.bumpers.is_some()),
        ("explore", spec.explore.is_some()),
    ];
    let allowed: &[&str] = match kind_name {
        "teleop" => &["commands", "file"],
        "waypoints" => &["points", "loop", "speed", "tolerance", "pose"],
        "bug1" | "bug2" => &[
            "speed",
            "tolerance",
            "goal",
            "mline_tolerance",
            "loop_tolerance",
            "follow",
            "pose",
            "bumpers",
        ],
        "explore" => &["speed", "follow", "pose", "bumpers", "explore"],
        _ => &[],
    };
    if !allowed.is_empty()
        && let Some((k, _)) = given.iter().find(|(k, g)| *g && !allowed.contains(k))
    {
        return Err(ctx.err(
            span.clone(),
            Some(k),
            format!("not a key of a `{kind_name}` mission"),
        ));
    }
    let kind = match kind_name {
        "teleop" => {
            let source = match (&spec.commands, &spec.file) {
                (Some(c), None) => {
                    if c.is_empty() {
                        return Err(ctx.err(span, Some("commands"), "no commands"));
                    }
                    TeleopSource::Steps(
                        c.iter()
                            .map(|s| teleop_step(ctx, s))
                            .collect::<Result<_, _>>()?,
                    )
                }
                (None, Some(f)) => TeleopSource::File(f.get_ref().clone()),
                _ => {
                    return Err(ctx.err(
                        span,
                        None,
                        "a teleop mission needs exactly one of `commands` or `file`",
                    ));
                }
            };
            MissionKind::Teleop(source)
        }
        "waypoints" => {
            let points = xy(spec.points.as_deref().unwrap_or_default());
            if points.is_empty() {
                return Err(ctx.err(
                    span,
                    Some("points"),
                    "a waypoints mission needs at least one point",
                ));
            }
            MissionKind::Waypoints(WaypointMission {
                points,
                speed: spec.speed.map_or(0.5, |v| v.0),
                tolerance: spec.tolerance.map_or(0.15, |v| v.0),
                repeat: spec.repeat.unwrap_or(false),
                pose: nav_pose(ctx, spec)?,
            })
        }
        "bug1" | "bug2" => {
            let nav = NavKeys::of(ctx, spec, robots, span.clone())?;
            let Some(goal) = &spec.goal else {
                return Err(ctx.err(span, Some("goal"), "a bug mission needs a `goal = [x, y]`"));
            };
            let algorithm = if kind_name == "bug1" {
                BugAlgorithm::Bug1
            } else {
                BugAlgorithm::Bug2
            };
            let d = BugMission::new(algorithm, DVec2::new(goal[0].0, goal[1].0));
            MissionKind::Bug(BugMission {
                tolerance: spec.tolerance.map_or(d.tolerance, |v| v.0),
                mline_tolerance: spec.mline_tolerance.map_or(d.mline_tolerance, |v| v.0),
                loop_tolerance: spec.loop_tolerance.map_or(d.loop_tolerance, |v| v.0),
                follow: nav.follow,
                speed: nav.speed,
                pose: nav.pose,
                bumpers: nav.bumpers,
                ..d
            })
        }
        "explore" => {
            let Some(e) = &spec.explore else {
                return Err(ctx.err(
                    span,
                    Some("explore"),
                    "an explore mission needs `explore = \"<strategy>\"`",
                ));
            };
            let strategy = Strategy::parse(e.get_ref()).ok_or_else(|| {
                ctx.err(
                    e.span(),
                    Some("explore"),
                    format!(
                        "unknown strategy `{}`; known: bounce, wall_follow, spiral, frontier",
                        e.get_ref()
                    ),
                )
            })?;
            let nav = NavKeys::of(ctx, spec, robots, span.clone())?;
            MissionKind::Explore(ExploreMission {
                strategy,
                speed: nav.speed,
                follow: nav.follow,
                pose: nav.pose,
                bumpers: nav.bumpers,
            })
        }
        other => {
            return Err(ctx.err(
                kind_span,
                Some("type"),
                format!(
                    "unknown mission type `{other}`; known: teleop, waypoints, bug1, bug2, explore"
                ),
            ));
        }
    };
    Ok(Mission {
        robot: spec.robot.as_ref().map(|r| r.get_ref().clone()),
        controller_hz: spec.controller_hz.map_or(DEFAULT_CONTROLLER_HZ, |v| v.0),
        kind,
    })
}

/// The keys Bug and exploration missions share.
struct NavKeys {
    speed: f64,
    follow: Side,
    pose: PoseSource,
    bumpers: BumperConfig,
}

impl NavKeys {
    fn of(
        ctx: &Ctx,
        spec: &MissionSpec,
        robots: &[Robot],
        span: Range<usize>,
    ) -> Result<Self, ScenarioError> {
        Ok(Self {
            speed: spec.speed.map_or(0.4, |v| v.0),
            follow: follow_side(ctx, spec)?,
            pose: nav_pose(ctx, spec)?,
            bumpers: bumper_config(ctx, spec, &robots[robot_index(spec, robots)], span)?,
        })
    }
}

/// Index of the robot the mission names (the first when it names none; names are checked).
fn robot_index(spec: &MissionSpec, robots: &[Robot]) -> usize {
    spec.robot
        .as_ref()
        .and_then(|r| robots.iter().position(|x| &x.name == r.get_ref()))
        .unwrap_or(0)
}

fn follow_side(ctx: &Ctx, spec: &MissionSpec) -> Result<Side, ScenarioError> {
    spec.follow.as_ref().map_or(Ok(Side::Left), |f| {
        Side::parse(f.get_ref()).ok_or_else(|| {
            ctx.err(
                f.span(),
                Some("follow"),
                format!("expected `left` or `right`, found `{}`", f.get_ref()),
            )
        })
    })
}

fn nav_pose(ctx: &Ctx, spec: &MissionSpec) -> Result<PoseSource, ScenarioError> {
    spec.pose.as_ref().map_or(Ok(PoseSource::Odometry), |f| {
        PoseSource::parse(f.get_ref()).ok_or_else(|| {
            ctx.err(
                f.span(),
                Some("pose"),
                format!(
                    "expected `odometry`, `slam` or `truth`, found `{}`",
                    f.get_ref()
                ),
            )
        })
    })
}

fn bumper_config(
    ctx: &Ctx,
    spec: &MissionSpec,
    robot: &Robot,
    mission_span: Range<usize>,
) -> Result<BumperConfig, ScenarioError> {
    let mut c = BumperConfig::default();
    let Some(b) = &spec.bumpers else {
        if robot.sensors.is_empty() {
            return Err(ctx.err(
                mission_span,
                Some("bumpers"),
                format!("robot `{}` has no sensor to feed the bumpers", robot.name),
            ));
        }
        return Ok(c);
    };
    let (bs, span) = (b.get_ref(), b.span());
    if let Some(k) = &bs.sectors {
        c.sectors = usize::try_from(*k.get_ref()).unwrap_or(0);
        if c.sectors != 4 && c.sectors != 8 {
            return Err(ctx.err(
                k.span(),
                Some("sectors"),
                format!("expected 4 or 8, found {}", k.get_ref()),
            ));
        }
    }
    c.safety = bs.safety.map(|v| v.0);
    if let Some(v) = bs.band {
        c.band = v.0;
    }
    if let Some(r) = &bs.rule {
        c.rule = BumperRule::parse(r.get_ref()).map_err(|m| ctx.err(r.span(), Some("rule"), m))?;
    }
    if let Some(n) = &bs.sensor {
        if !robot.sensors.iter().any(|s| &s.name == n.get_ref()) {
            let known: Vec<&str> = robot.sensors.iter().map(|s| s.name.as_str()).collect();
            return Err(ctx.err(
                n.span(),
                Some("sensor"),
                format!(
                    "robot `{}` has no sensor `{}`; sensors: {}",
                    robot.name,
                    n.get_ref(),
                    known.join(", ")
                ),
            ));
        }
        c.sensor = Some(n.get_ref().clone());
    } else if robot.sensors.is_empty() {
        return Err(ctx.err(
            span,
            Some("bumpers"),
            format!("robot `{}` has no sensor to feed the bumpers", robot.name),
        ));
    }
    Ok(c)
}

fn teleop_step(ctx: &Ctx, s: &Spanned<spec::TeleopStepSpec>) -> Result<TeleopStep, ScenarioError> {
    let t = s.get_ref();
    let twist = t.v.is_some() || t.omega_deg_s.is_some();
    let tracks = t.left.is_some() || t.right.is_some();
    let command = match (twist, tracks) {
        (true, false) | (false, false) => DriveCommand::twist(
            t.v.map_or(0.0, |v| v.0),
            t.omega_deg_s.map_or(0.0, |v| v.0.to_radians()),
        ),
        (false, true) => DriveCommand::Tracks {
            left: t.left.map_or(0.0, |v| v.0),
            right: t.right.map_or(0.0, |v| v.0),
        },
        (true, true) => {
            return Err(ctx.err(
                s.span(),
                None,
                "give `v`/`omega_deg_s` or `left`/`right`, not both",
            ));
        }
    };
    Ok(TeleopStep {
        duration: t.duration.0,
        command,
    })
}

#[cfg(test)]
mod tests;
