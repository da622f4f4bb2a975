//! An MCAP recording with Foxglove's protobuf schemas, so a run opens in Foxglove or Lichtblick.
//!
//! Channels (times are simulation time from 0):
//! * `/world` (`foxglove.SceneUpdate`, once at t = 0): every object, coloured by material,
//!   see-through for penetrable ones.
//! * `/tf` (`foxglove.FrameTransform`): `world → <robot>/base_link` every step (true pose),
//!   `<robot>/base_link → <robot>/<sensor>` once at t = 0 (the mounts).
//! * `/<robot>/body` (`foxglove.SceneUpdate`, once): the vehicle's box, locked to `base_link`.
//! * `/<robot>/pose` and `/<robot>/odometry` (`foxglove.PoseInFrame`, frame `world`, every step).
//! * `/<robot>/scan/<sensor>` (`foxglove.LaserScan`, every scan): frame `world`, with the
//!   sensor's exact pose at the scan's time (scans inside a step are taken on the arc);
//!   intensities code how each ray ended: 0 no return, 1 budget ran out, 2 solid. A sensor with
//!   several planes logs the one closest to horizontal.
//! * `/<robot>/echoes/<sensor>` (`foxglove.PointCloud`, every scan of a sensor with a
//!   multi-echo return mode): every echo of the scan in the frame `world`, fields `x`, `y`,
//!   `z`, `power_db` (float32), `kind` (0 surface, 1 volume) and `bounces` (uint8).
//! * `/<robot>/radar/<sensor>/image` (`foxglove.CompressedImage`, PNG, every rotation of an
//!   imaging radar, stamped at its first row): the polar power image in the Oxford layout,
//!   frame `<robot>/<sensor>`.
//! * `/<robot>/radar/<sensor>/points` (`foxglove.PointCloud`, with each image): its
//!   k-strongest detections in the frame `world` (each from the pose of its own row), fields
//!   `x`, `y`, `z` (float32) and `power` (uint8, the image's value).
//! * `/<robot>/path` (`foxglove.PosesInFrame`, once at the end): the driven path.
//! * `/<robot>/map/<name>` (`foxglove.Grid`, frame `world`, every [`super::GRID_PERIOD`] s,
//!   or every few periods while the maps exceed [`super::GRID_BYTES_PER_PERIOD`], and at the
//!   end): each occupancy map, cropped to its known cells. Fields `red`, `green`,
//!   `blue`, `alpha` (the thesis' palette; unknown cells half transparent) and `class`
//!   (0 unknown, 1 sensor-clear, 2 seen through but impassable, 3 obstacle), all `uint8`.

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use foxglove::Encode;
use foxglove::schemas::{
    Color, CompressedImage, CubePrimitive, CylinderPrimitive, FrameTransform, Grid as FgGrid,
    LaserScan, LinePrimitive, PackedElementField, Point3, PointCloud, Pose as FgPose, PoseInFrame,
    PosesInFrame, Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, Vector2,
    Vector3, line_primitive, packed_element_field::NumericType,
};

use super::RecordError;
use super::radar_images::SweepImage;
use crate::map::CellClass;
use crate::map::Grid;
use crate::map::export::known_extent;
use crate::pose::Pose;
use crate::scenario::Robot;
use crate::sensor::{EchoKind, HitKind, ReturnMode, Scan};
use crate::sim::Step;
use crate::world::{Shape, World};

/// Topic of the static world.
pub const WORLD_TOPIC: &str = "/world";
/// Topic of the transforms.
pub const TF_TOPIC: &str = "/tf";

/// Writes one run to an MCAP file.
pub struct McapLog<W: Write + Seek> {
    out: mcap::Writer<W>,
    robot: String,
    tf: u16,
    pose: u16,
    odometry: u16,
    scans: Vec<(u16, usize)>,
    /// Per sensor, the echo channel of a multi-echo sensor.
    echoes: Vec<Option<u16>>,
    /// Per sensor, the image and detection channels of an imaging radar.
    radar: Vec<Option<(u16, u16)>>,
    sensor_names: Vec<String>,
    path: u16,
    maps: Vec<u16>,
    sequence: u32,
    buf: Vec<u8>,
}

fn ns(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

fn stamp(t: f64) -> Option<Timestamp> {
    let n = ns(t);
    Some(Timestamp::new(
        u32::try_from(n / 1_000_000_000).unwrap_or(u32::MAX),
        (n % 1_000_000_000) as u32,
    ))
}

fn vec3(x: f64, y: f64, z: f64) -> Option<Vector3> {
    Some(Vector3 { x, y, z })
}

fn yaw_quat(yaw: f64) -> Option<Quaternion> {
    let (s, c) = (yaw / 2.0).sin_cos();
    Some(Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    })
}

fn fg_pose(p: &Pose) -> FgPose {
    FgPose {
        position: vec3(p.x, p.y, p.z),
        orientation: yaw_quat(p.yaw),
    }
}

fn color(rgb: [u8; 3], a: f64) -> Option<Color> {
    Some(Color {
        r: f64::from(rgb[0]) / 255.0,
        g: f64::from(rgb[1]) / 255.0,
        b: f64::from(rgb[2]) / 255.0,
        a,
    })
}

/// Bytes per point of the echo clouds.
const ECHO_STRIDE: u32 = 18;

fn field(name: &str, offset: u32, kind: NumericType) -> PackedElementField {
    PackedElementField {
        name: name.into(),
        offset,
        r#type: kind as i32,
    }
}

fn mcap_err(e: mcap::McapError) -> RecordError {
    match e {
        // Keep the OS error (disk full, permission): the recorder names the file.
        mcap::McapError::Io(io) => RecordError::McapIo(io),
        other => RecordError::Mcap(other.to_string()),
    }
}

fn mcap_msg(m: &str) -> RecordError {
    RecordError::Mcap(m.to_owned())
}

impl<W: Write + Seek> McapLog<W> {
    /// Starts a recording of `robot` in `world` and writes the static messages.
    pub fn new(out: W, world: &World, robot: &Robot) -> Result<Self, RecordError> {
        let opts = mcap::WriteOptions::new()
            .compression(None)
            .profile("")
            .library(concat!("radarnav ", env!("CARGO_PKG_VERSION")));
        let mut out = opts.create(out).map_err(mcap_err)?;
        let name = robot.name.clone();
        let mut channel = |topic: &str, schema: Option<foxglove::Schema>| {
            let schema = schema.ok_or_else(|| mcap_msg("schema missing"))?;
            let id = out
                .add_schema(&schema.name, &schema.encoding, &schema.data)
                .map_err(mcap_err)?;
            out.add_channel(id, topic, "protobuf", &BTreeMap::new())
                .map_err(mcap_err)
        };
        let world_ch = channel(WORLD_TOPIC, SceneUpdate::get_schema())?;
        let tf = channel(TF_TOPIC, FrameTransform::get_schema())?;
        let body = channel(&format!("/{name}/body"), SceneUpdate::get_schema())?;
        let pose = channel(&format!("/{name}/pose"), PoseInFrame::get_schema())?;
        let odometry = channel(&format!("/{name}/odometry"), PoseInFrame::get_schema())?;
        let mut scans = Vec::new();
        let mut echoes = Vec::new();
        let mut radar = Vec::new();
        for s in &robot.sensors {
            let id = channel(&format!("/{name}/scan/{}", s.name), LaserScan::get_schema())?;
            let signal = &s.config.signal;
            echoes.push(if signal.return_mode == ReturnMode::Thesis {
                None
            } else {
                Some(channel(
                    &format!("/{name}/echoes/{}", s.name),
                    PointCloud::get_schema(),
                )?)
            });
            radar.push(if signal.image.is_some() && s.config.range_bin.is_some() {
                let prefix = format!("/{name}/radar/{}", s.name);
                Some((
                    channel(&format!("{prefix}/image"), CompressedImage::get_schema())?,
                    channel(&format!("{prefix}/points"), PointCloud::get_schema())?,
                ))
            } else {
                None
            });
            let plane = s
                .config
                .elevations
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .map_or(0, |(i, _)| i);
            scans.push((id, plane));
        }
        let path = channel(&format!("/{name}/path"), PosesInFrame::get_schema())?;
        let mut log = Self {
            out,
            robot: name,
            tf,
            pose,
            odometry,
            scans,
            echoes,
            radar,
            sensor_names: robot.sensors.iter().map(|s| s.name.clone()).collect(),
            path,
            maps: Vec::new(),
            sequence: 0,
            buf: Vec::new(),
        };
        log.write(world_ch, 0.0, &world_scene(world))?;
        log.write(body, 0.0, &body_scene(robot))?;
        for s in &robot.sensors {
            let m = &s.mount;
            let msg = FrameTransform {
                timestamp: stamp(0.0),
                parent_frame_id: format!("{}/base_link", log.robot),
                child_frame_id: format!("{}/{}", log.robot, s.name),
                translation: vec3(m.x, m.y, m.z),
                rotation: yaw_quat(m.yaw),
            };
            log.write(tf, 0.0, &msg)?;
        }
        Ok(log)
    }

    fn write<T: Encode>(&mut self, channel: u16, t: f64, msg: &T) -> Result<(), RecordError> {
        self.buf.clear();
        msg.encode(&mut self.buf)
            .map_err(|_| mcap_msg("protobuf encoding failed"))?;
        self.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: ns(t),
            publish_time: ns(t),
        };
        self.out
            .write_to_known_channel(&header, &self.buf)
            .map_err(mcap_err)
    }

    /// Logs a step: the transform, the true pose and the odometry.
    pub fn step(&mut self, step: &Step) -> Result<(), RecordError> {
        let t = step.time;
        let p = step.truth;
        let tf = FrameTransform {
            timestamp: stamp(t),
            parent_frame_id: "world".into(),
            child_frame_id: format!("{}/base_link", self.robot),
            translation: vec3(p.x, p.y, p.z),
            rotation: yaw_quat(p.yaw),
        };
        self.write(self.tf, t, &tf)?;
        for (ch, pose) in [(self.pose, &step.truth), (self.odometry, &step.odometry)] {
            let msg = PoseInFrame {
                timestamp: stamp(t),
                frame_id: "world".into(),
                pose: Some(fg_pose(pose)),
            };
            self.write(ch, t, &msg)?;
        }
        Ok(())
    }

    /// Logs a scan of sensor `sensor`.
    pub fn scan(&mut self, sensor: usize, scan: &Scan) -> Result<(), RecordError> {
        let (ch, plane) = self.scans[sensor];
        let rows = plane * scan.azimuths..(plane + 1) * scan.azimuths;
        let msg = LaserScan {
            timestamp: stamp(scan.stamp),
            frame_id: "world".into(),
            pose: Some(fg_pose(&scan.pose)),
            start_angle: scan.angle_min,
            end_angle: scan.angle_min + (scan.azimuths.max(1) - 1) as f64 * scan.angle_increment,
            ranges: scan.ranges[rows.clone()]
                .iter()
                .map(|&r| f64::from(r))
                .collect(),
            intensities: scan.hits[rows]
                .iter()
                .map(|h| match h {
                    HitKind::None => 0.0,
                    HitKind::Exhausted => 1.0,
                    HitKind::Solid => 2.0,
                })
                .collect(),
        };
        self.write(ch, scan.stamp, &msg)?;
        let Some(ch) = self.echoes.get(sensor).copied().flatten() else {
            return Ok(());
        };
        let mut data = Vec::with_capacity(scan.echoes.len() * ECHO_STRIDE as usize);
        for i in 0..scan.len() {
            let (az, el) = scan.angles(i);
            let ray = crate::sensor::beam_ray(&scan.pose, az, el.sin_cos(), 0.0);
            for e in scan.echoes_of(i) {
                let p = ray.at(e.range);
                for v in [p.x, p.y, p.z, e.power_db] {
                    data.extend_from_slice(&(v as f32).to_le_bytes());
                }
                data.push(match e.kind {
                    EchoKind::Surface => 0,
                    EchoKind::Volume => 1,
                });
                data.push(e.bounces);
            }
        }
        let msg = PointCloud {
            timestamp: stamp(scan.stamp),
            frame_id: "world".into(),
            pose: Some(fg_pose(&Pose::default())),
            point_stride: ECHO_STRIDE,
            fields: vec![
                field("x", 0, NumericType::Float32),
                field("y", 4, NumericType::Float32),
                field("z", 8, NumericType::Float32),
                field("power_db", 12, NumericType::Float32),
                field("kind", 16, NumericType::Uint8),
                field("bounces", 17, NumericType::Uint8),
            ],
            data: data.into(),
        };
        self.write(ch, scan.stamp, &msg)
    }

    /// Logs a finished rotation of an imaging radar: its PNG (`png`, the file written to
    /// disk) and its detections.
    pub fn radar_image(&mut self, sweep: &SweepImage, png: &[u8]) -> Result<(), RecordError> {
        let Some((image_ch, points_ch)) = self.radar.get(sweep.sensor).copied().flatten() else {
            return Ok(());
        };
        let t = sweep.image.timestamps_us.first().map_or(0.0, |&us| {
            (us - crate::sensor::image::IMAGE_EPOCH_US) as f64 * 1e-6
        });
        let msg = CompressedImage {
            timestamp: stamp(t),
            frame_id: format!("{}/{}", self.robot, self.sensor_names[sweep.sensor]),
            data: png.to_vec().into(),
            format: "png".into(),
        };
        self.write(image_ch, t, &msg)?;
        let mut data = Vec::with_capacity(sweep.detections.len() * 13);
        for (d, p) in &sweep.detections {
            for v in [p.x, p.y, p.z] {
                data.extend_from_slice(&(v as f32).to_le_bytes());
            }
            data.push(d.power);
        }
        let msg = PointCloud {
            timestamp: stamp(t),
            frame_id: "world".into(),
            pose: Some(fg_pose(&Pose::default())),
            point_stride: 13,
            fields: vec![
                field("x", 0, NumericType::Float32),
                field("y", 4, NumericType::Float32),
                field("z", 8, NumericType::Float32),
                field("power", 12, NumericType::Uint8),
            ],
            data: data.into(),
        };
        self.write(points_ch, t, &msg)
    }

    /// Adds a channel for the map `name`; returns its index for [`McapLog::grid`].
    pub fn add_map(&mut self, name: &str) -> Result<usize, RecordError> {
        let schema = FgGrid::get_schema().ok_or_else(|| mcap_msg("schema missing"))?;
        let id = self
            .out
            .add_schema(&schema.name, &schema.encoding, &schema.data)
            .map_err(mcap_err)?;
        let topic = format!("/{}/map/{name}", self.robot);
        let ch = self
            .out
            .add_channel(id, &topic, "protobuf", &BTreeMap::new())
            .map_err(mcap_err)?;
        self.maps.push(ch);
        Ok(self.maps.len() - 1)
    }

    /// Logs map `map` (an index from [`McapLog::add_map`]) as it is at time `t`; nothing while
    /// the map is empty. Returns the bytes of cell data logged.
    pub fn grid(&mut self, map: usize, t: f64, grid: &Grid) -> Result<usize, RecordError> {
        let Some(((c0, c1), (r0, r1))) = known_extent(grid, 0) else {
            return Ok(0);
        };
        let (w, h) = (c1 - c0 + 1, r1 - r0 + 1);
        let mut data = Vec::with_capacity(w * h * 5);
        for r in r0..=r1 {
            for c in c0..=c1 {
                let class = grid.class_at(r * grid.width() + c);
                let [red, green, blue] = class.rgb();
                let alpha = if class == CellClass::Unknown {
                    100
                } else {
                    255
                };
                data.extend([red, green, blue, alpha, class as u8]);
            }
        }
        let res = grid.resolution();
        let o = grid.origin() + glam::DVec2::new(c0 as f64, r0 as f64) * res;
        let msg = FgGrid {
            timestamp: stamp(t),
            frame_id: "world".into(),
            pose: Some(fg_pose(&Pose::new(o.x, o.y, 0.0, 0.0))),
            column_count: w as u32,
            cell_size: Some(Vector2 { x: res, y: res }),
            row_stride: (w * 5) as u32,
            cell_stride: 5,
            fields: ["red", "green", "blue", "alpha", "class"]
                .iter()
                .zip(0..)
                .map(|(n, k)| field(n, k, NumericType::Uint8))
                .collect(),
            data: data.into(),
        };
        let ch = self.maps[map];
        self.write(ch, t, &msg)?;
        Ok(w * h * 5)
    }

    /// Logs the driven `path` and closes the file; returns the sink.
    pub fn finish(mut self, end_time: f64, path: &[Pose]) -> Result<W, RecordError> {
        let msg = PosesInFrame {
            timestamp: stamp(end_time),
            frame_id: "world".into(),
            poses: path.iter().map(fg_pose).collect(),
        };
        self.write(self.path, end_time, &msg)?;
        self.out.finish().map_err(mcap_err)?;
        Ok(self.out.into_inner())
    }
}

fn world_scene(world: &World) -> SceneUpdate {
    let entities = world
        .objects()
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let m = world.materials().get(o.material);
            let alpha = if m.traversable {
                0.25
            } else if m.radar_penetrable() {
                0.6
            } else {
                1.0
            };
            let c = color(m.color, alpha);
            let mut e = SceneEntity {
                timestamp: stamp(0.0),
                frame_id: "world".into(),
                id: o.name.clone().unwrap_or_else(|| format!("object-{i}")),
                metadata: vec![foxglove::schemas::KeyValuePair {
                    key: "material".into(),
                    value: m.name.clone(),
                }],
                ..Default::default()
            };
            let cube = |b: &crate::world::OrientedBox| CubePrimitive {
                pose: Some(fg_pose(&Pose::new(
                    b.center.x, b.center.y, b.center.z, b.yaw,
                ))),
                size: vec3(2.0 * b.half.x, 2.0 * b.half.y, 2.0 * b.half.z),
                color: c,
            };
            match &o.shape {
                Shape::Sphere { center, radius } => e.spheres.push(SpherePrimitive {
                    pose: Some(fg_pose(&Pose::new(center.x, center.y, center.z, 0.0))),
                    size: vec3(2.0 * radius, 2.0 * radius, 2.0 * radius),
                    color: c,
                }),
                Shape::Box(b) => e.cubes.push(cube(b)),
                Shape::Cylinder {
                    center,
                    radius,
                    half_height,
                } => e.cylinders.push(CylinderPrimitive {
                    pose: Some(fg_pose(&Pose::new(center.x, center.y, center.z, 0.0))),
                    size: vec3(2.0 * radius, 2.0 * radius, 2.0 * half_height),
                    bottom_scale: 1.0,
                    top_scale: 1.0,
                    color: c,
                }),
                Shape::Wall { segments, .. } => e.cubes.extend(segments.iter().map(cube)),
                Shape::Prism {
                    polygon,
                    z_min,
                    z_max,
                } => {
                    // Outline: bottom ring, top ring and the vertical edges, as a line list.
                    let n = polygon.len();
                    let mut points = Vec::with_capacity(6 * n);
                    for i in 0..n {
                        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
                        for (p, q) in [
                            (a, b, *z_min, *z_min),
                            (a, b, *z_max, *z_max),
                            (a, a, *z_min, *z_max),
                        ]
                        .map(|(p, q, z0, z1)| (p.extend(z0), q.extend(z1)))
                        {
                            points.push(Point3 {
                                x: p.x,
                                y: p.y,
                                z: p.z,
                            });
                            points.push(Point3 {
                                x: q.x,
                                y: q.y,
                                z: q.z,
                            });
                        }
                    }
                    e.lines.push(LinePrimitive {
                        r#type: line_primitive::Type::LineList as i32,
                        pose: Some(fg_pose(&Pose::default())),
                        thickness: 0.03,
                        points,
                        color: c,
                        ..Default::default()
                    });
                }
            }
            e
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

fn body_scene(robot: &Robot) -> SceneUpdate {
    let v = robot.vehicle;
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: stamp(0.0),
            frame_id: format!("{}/base_link", robot.name),
            id: robot.name.clone(),
            frame_locked: true,
            cubes: vec![CubePrimitive {
                pose: Some(fg_pose(&Pose::new(0.0, 0.0, v.height / 2.0, 0.0))),
                size: vec3(v.length, v.width, v.height),
                color: color([30, 60, 200], 0.9),
            }],
            ..Default::default()
        }],
    }
}
