//! An MCAP recording with Foxglove's protobuf schemas, so a run opens in Foxglove or Lichtblick.
//!
//! Frames are REP-105's, as in the rosbag2 recording (see [`super::frames`]): `map → odom →
//! base_link → <sensor>`. Times are UNIX times from [`crate::stamp::EPOCH_NS`] at simulation
//! time 0. Channels:
//! * `/world` (`foxglove.SceneUpdate`, once at t = 0): every object, coloured by material,
//!   see-through for penetrable ones, in `map`.
//! * `/tf` (`foxglove.FrameTransform`): `map → odom` (the odometry's drift) and `odom →
//!   base_link` (the odometry) every step, at every scan taken between steps and at the end.
//! * `/tf_static` (`foxglove.FrameTransform`, at t = 0): `base_link → <sensor>`, the mounts.
//! * `/<robot>/body` (`foxglove.SceneUpdate`, once): the vehicle's box, locked to `base_link`.
//! * `/<robot>/pose` (`foxglove.PoseInFrame`, frame `map`) and `/<robot>/odometry` (frame
//!   `odom`): the true pose and the odometry, every step and at the end.
//! * `/<robot>/scan/<sensor>` (`foxglove.LaserScan`, every scan): in the sensor's frame (scans
//!   inside a step are taken on the arc: `/tf` has their time). A sensor with several planes
//!   logs the one closest to horizontal. No intensities (the echoes carry powers).
//! * `/<robot>/echoes/<sensor>` (`foxglove.PointCloud`, every scan of a sensor with a
//!   multi-echo return mode): every echo of the scan in the sensor's frame, fields `x`, `y`,
//!   `z`, `power_db` (float32), `kind` (0 surface, 1 volume) and `bounces` (uint8).
//! * `/<robot>/radar/<sensor>/image` (`foxglove.CompressedImage`, PNG, every rotation of an
//!   imaging radar, stamped at its first row): the polar power image in the Oxford layout,
//!   in the sensor's frame.
//! * `/<robot>/radar/<sensor>/points` (`foxglove.PointCloud`, with each image): its
//!   k-strongest detections in `map` (each from the pose of its own row), fields
//!   `x`, `y`, `z` (float32) and `power` (uint8, the image's value).
//! * `/<robot>/path` (`foxglove.PosesInFrame`, once at the end): the driven path in `map`.
//! * `/<robot>/map/<name>` (`foxglove.Grid`, frame `map`, every [`super::GRID_PERIOD`] s,
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
    PosesInFrame, Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp,
    TriangleListPrimitive, Vector2, Vector3, line_primitive, packed_element_field::NumericType,
};

use super::RecordError;
use super::frames::{self, BASE_LINK, MAP, ODOM, PointFieldSpec};
use super::radar_images::SweepImage;
use crate::map::CellClass;
use crate::map::Grid;
use crate::map::export::known_extent;
use crate::pose::Pose;
use crate::sensor::ReturnMode;
use crate::setup::Robot;
use crate::sim::{ScanEvent, Step};
use crate::stamp::unix_ns;
use crate::world::{Shape, World};

/// Topic of the static world.
pub const WORLD_TOPIC: &str = "/world";
/// Topic of the transforms.
pub const TF_TOPIC: &str = "/tf";
/// Topic of the fixed transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";

/// Writes one run to an MCAP file.
pub struct McapLog<W: Write + Seek> {
    out: mcap::Writer<W>,
    robot: String,
    tf: u16,
    pose: u16,
    odometry: u16,
    /// Per sensor, the scan channel and the plane it carries.
    scans: Vec<(u16, usize)>,
    /// Per sensor, the echo channel of a multi-echo sensor.
    echoes: Vec<Option<u16>>,
    /// Per sensor, the image and detection channels of an imaging radar.
    radar: Vec<Option<(u16, u16)>>,
    sensor_frames: Vec<String>,
    path: u16,
    /// Stamp of the last `/tf`, so that no stamp is logged twice.
    last_tf: Option<u64>,
    maps: Vec<u16>,
    sequence: u32,
    buf: Vec<u8>,
}

fn stamp_ns(ns: u64) -> Option<Timestamp> {
    let (sec, nsec) = crate::stamp::split(ns);
    Some(Timestamp::new(u32::try_from(sec).unwrap_or(u32::MAX), nsec))
}

fn stamp(t: f64) -> Option<Timestamp> {
    stamp_ns(unix_ns(t))
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

fn transform(ns: u64, parent: &str, child: &str, pose: &Pose) -> FrameTransform {
    FrameTransform {
        timestamp: stamp_ns(ns),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: vec3(pose.x, pose.y, pose.z),
        rotation: yaw_quat(pose.yaw),
    }
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

fn field(name: &str, offset: u32, kind: NumericType) -> PackedElementField {
    PackedElementField {
        name: name.into(),
        offset,
        r#type: kind as i32,
    }
}

fn fields(spec: &[PointFieldSpec]) -> Vec<PackedElementField> {
    spec.iter()
        .map(|&(name, offset, kind)| {
            field(
                name,
                offset,
                match kind {
                    frames::FieldType::F32 => NumericType::Float32,
                    frames::FieldType::U8 => NumericType::Uint8,
                },
            )
        })
        .collect()
}

/// An MCAP error as a recording error (the I/O cause kept for the recorder to name the file).
pub(crate) fn mcap_err(e: mcap::McapError) -> RecordError {
    match e {
        // Keep the OS error (disk full, permission): the recorder names the file.
        mcap::McapError::Io(io) => RecordError::McapIo(io),
        other => RecordError::Mcap(other.to_string()),
    }
}

/// A recording error of the MCAP writer with message `m`.
pub(crate) fn mcap_msg(m: &str) -> RecordError {
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
        let tf_static = channel(TF_STATIC_TOPIC, FrameTransform::get_schema())?;
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
            scans.push((id, s.config.horizontal_plane()));
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
            sensor_frames: robot
                .sensors
                .iter()
                .map(|s| frames::sensor_frame(&s.name))
                .collect(),
            path,
            last_tf: None,
            maps: Vec::new(),
            sequence: 0,
            buf: Vec::new(),
        };
        log.write(world_ch, 0.0, &world_scene(world))?;
        log.write(body, 0.0, &body_scene(robot))?;
        for (s, frame) in robot.sensors.iter().zip(log.sensor_frames.clone()) {
            let msg = transform(unix_ns(0.0), BASE_LINK, &frame, &s.mount);
            log.write(tf_static, 0.0, &msg)?;
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
            log_time: unix_ns(t),
            publish_time: unix_ns(t),
        };
        self.out
            .write_to_known_channel(&header, &self.buf)
            .map_err(mcap_err)
    }

    /// `/tf` at time `t` from the true and the odometry pose, unless `/tf` has that stamp.
    fn tf(&mut self, t: f64, truth: &Pose, odometry: &Pose) -> Result<(), RecordError> {
        let ns = unix_ns(t);
        if self.last_tf.is_some_and(|last| last >= ns) {
            return Ok(());
        }
        self.last_tf = Some(ns);
        let drift = frames::map_to_odom(truth, odometry);
        self.write(self.tf, t, &transform(ns, MAP, ODOM, &drift))?;
        self.write(self.tf, t, &transform(ns, ODOM, BASE_LINK, odometry))
    }

    /// Logs a step (or the final state): the transforms, the true pose and the odometry.
    pub fn step(&mut self, step: &Step) -> Result<(), RecordError> {
        let t = step.time;
        self.tf(t, &step.truth, &step.odometry)?;
        for (ch, frame, pose) in [
            (self.pose, MAP, &step.truth),
            (self.odometry, ODOM, &step.odometry),
        ] {
            let msg = PoseInFrame {
                timestamp: stamp(t),
                frame_id: frame.into(),
                pose: Some(fg_pose(pose)),
            };
            self.write(ch, t, &msg)?;
        }
        Ok(())
    }

    /// Logs a scan: its transforms (if taken between steps), the scan and its echoes.
    pub fn scan(&mut self, event: &ScanEvent<'_>) -> Result<(), RecordError> {
        let (sensor, scan) = (event.sensor, event.scan);
        self.tf(scan.stamp, &event.truth, &event.odometry)?;
        let (ch, plane) = self.scans[sensor];
        let rows = plane * scan.azimuths..(plane + 1) * scan.azimuths;
        let frame = self.sensor_frames[sensor].clone();
        let msg = LaserScan {
            timestamp: stamp(scan.stamp),
            frame_id: frame.clone(),
            pose: Some(fg_pose(&Pose::default())),
            start_angle: scan.angle_min,
            end_angle: scan.angle_min + (scan.azimuths.max(1) - 1) as f64 * scan.angle_increment,
            ranges: scan
                .ranges
                .get(rows)
                .unwrap_or_default()
                .iter()
                .map(|&r| f64::from(r))
                .collect(),
            intensities: Vec::new(),
        };
        self.write(ch, scan.stamp, &msg)?;
        let Some(ch) = self.echoes.get(sensor).copied().flatten() else {
            return Ok(());
        };
        let (data, _) = frames::echo_points(scan);
        let msg = PointCloud {
            timestamp: stamp(scan.stamp),
            frame_id: frame,
            pose: Some(fg_pose(&Pose::default())),
            point_stride: frames::ECHO_STRIDE,
            fields: fields(frames::ECHO_FIELDS),
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
            crate::stamp::sim_time(u64::try_from(us).unwrap_or(0).saturating_mul(1000))
        });
        let msg = CompressedImage {
            timestamp: stamp(t),
            frame_id: self.sensor_frames[sweep.sensor].clone(),
            data: png.to_vec().into(),
            format: "png".into(),
        };
        self.write(image_ch, t, &msg)?;
        let data = frames::detection_points(sweep.detections.iter().map(|(d, p)| (d.power, p)));
        let msg = PointCloud {
            timestamp: stamp(t),
            frame_id: MAP.into(),
            pose: Some(fg_pose(&Pose::default())),
            point_stride: frames::DETECTION_STRIDE,
            fields: fields(frames::DETECTION_FIELDS),
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
            frame_id: MAP.into(),
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
            frame_id: MAP.into(),
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
                frame_id: MAP.into(),
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
                Shape::Mesh(m) => e.triangles.push(TriangleListPrimitive {
                    pose: Some(fg_pose(&Pose::default())),
                    points: (m.vertices().iter())
                        .map(|v| Point3 {
                            x: v.x,
                            y: v.y,
                            z: v.z,
                        })
                        .collect(),
                    color: c,
                    indices: m.triangles().iter().flatten().copied().collect(),
                    ..Default::default()
                }),
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
            frame_id: BASE_LINK.into(),
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
