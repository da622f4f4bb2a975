//! A rosbag2 recording (DESIGN §8): an MCAP file with profile `ros2`, `ros2msg` schemas and
//! CDR messages, next to a `metadata.yaml`, so `ros2 bag play`, `rosbags` and
//! `mcap-ros2-support` read it.
//!
//! Topics (frames as in [`super::frames`]; stamps from [`crate::stamp::EPOCH_NS`]):
//! * `/clock` (rosgraph_msgs/Clock): every step and at the end.
//! * `/tf` (tf2_msgs/TFMessage): `map → odom` and `odom → base_link` at every step, at every
//!   scan taken between steps (so a scan's stamp has its exact transform) and at the end.
//! * `/tf_static` (tf2_msgs/TFMessage, once, transient local): `base_link → <sensor>`.
//! * `/odom` (nav_msgs/Odometry): the odometry estimate in `odom`, the executed command as
//!   twist in `base_link`; every step and at the end.
//! * `/scan/<sensor>` (sensor_msgs/LaserScan): every scan in its sensor's frame (the plane
//!   nearest horizontal of a multi-plane sensor); +inf where nothing returned.
//! * `/echoes/<sensor>` (sensor_msgs/PointCloud2, multi-echo sensors): every echo of a scan in
//!   the sensor frame, fields as [`super::frames::ECHO_FIELDS`].
//! * `/radar/<sensor>/image` (sensor_msgs/Image, `mono8`): each rotation of an imaging radar
//!   in the Oxford layout (a row per azimuth: 8 bytes µs stamp, 2 bytes encoder, valid flag,
//!   then the power bins), stamped at its first row.
//! * `/radar/<sensor>/points` (sensor_msgs/PointCloud2): its detections in `map`.
//! * `/map/<name>` (nav_msgs/OccupancyGrid, `map`): each map as the Foxglove recording logs
//!   it (see [`super::GRID_PERIOD`]), whole; -1 unknown, 0 free, 100 impassable.

pub mod convert;
pub mod msg;

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use serde::Serialize;

use super::RecordError;
use super::frames;
use super::mcap_log::{mcap_err, mcap_msg};
use super::radar_images::SweepImage;
use crate::map::Grid;
use crate::pose::Pose;
use crate::sensor::ReturnMode;
use crate::setup::Robot;
use crate::sim::{ScanEvent, Step};
use crate::stamp::unix_ns;

/// The bag's directory inside the run's output directory.
pub const BAG_DIR: &str = "ros2_bag";
/// The MCAP file inside [`BAG_DIR`].
pub const BAG_FILE: &str = "ros2_bag_0.mcap";
/// rosbag2's metadata file inside [`BAG_DIR`].
pub const METADATA: &str = "metadata.yaml";

/// One topic of the bag.
struct Topic {
    channel: u16,
    name: String,
    type_name: &'static str,
    latched: bool,
    count: u64,
}

struct SensorTopics {
    frame: String,
    plane: usize,
    scan_time: f64,
    scan: usize,
    echoes: Option<usize>,
    radar: Option<(usize, usize)>,
}

/// Writes one run as a rosbag2 MCAP.
pub struct Ros2Bag<W: Write + Seek> {
    out: mcap::Writer<W>,
    topics: Vec<Topic>,
    clock: usize,
    tf: usize,
    odom: usize,
    sensors: Vec<SensorTopics>,
    maps: Vec<usize>,
    /// Stamp of the last `/tf`, so that no stamp is published twice (tf2 warns of that).
    last_tf: Option<u64>,
    first_ns: u64,
    last_ns: u64,
    sequence: u32,
}

/// QoS of a topic as rosbag2 stores it (`offered_qos_profiles`, metadata version 9).
#[derive(Serialize)]
struct Qos {
    history: &'static str,
    depth: u32,
    reliability: &'static str,
    durability: &'static str,
    deadline: Duration,
    lifespan: Duration,
    liveliness: &'static str,
    liveliness_lease_duration: Duration,
    avoid_ros_namespace_conventions: bool,
}

/// 0 s: the middleware's default.
#[derive(Serialize)]
struct Duration {
    sec: u32,
    nsec: u32,
}

fn qos(latched: bool) -> Vec<Qos> {
    let zero = || Duration { sec: 0, nsec: 0 };
    vec![Qos {
        history: "keep_last",
        depth: if latched { 1 } else { 10 },
        reliability: "reliable",
        durability: if latched {
            "transient_local"
        } else {
            "volatile"
        },
        deadline: zero(),
        lifespan: zero(),
        liveliness: "automatic",
        liveliness_lease_duration: zero(),
        avoid_ros_namespace_conventions: false,
    }]
}

/// JSON text (YAML is a superset of JSON, and rosbag2 reads its files with a YAML parser).
fn json<T: Serialize>(value: &T) -> Result<String, RecordError> {
    serde_json::to_string_pretty(value).map_err(|e| mcap_msg(&e.to_string()))
}

impl<W: Write + Seek> Ros2Bag<W> {
    /// Starts a bag of `robot`'s run and writes `/tf_static`.
    pub fn new(out: W, robot: &Robot) -> Result<Self, RecordError> {
        let opts = mcap::WriteOptions::new()
            .compression(None)
            .profile("ros2")
            .library(concat!("radarnav ", env!("CARGO_PKG_VERSION")));
        let out = opts.create(out).map_err(mcap_err)?;
        let mut bag = Self {
            out,
            topics: Vec::new(),
            clock: 0,
            tf: 0,
            odom: 0,
            sensors: Vec::new(),
            maps: Vec::new(),
            last_tf: None,
            first_ns: unix_ns(0.0),
            last_ns: unix_ns(0.0),
            sequence: 0,
        };
        bag.clock = bag.topic("/clock", "rosgraph_msgs/msg/Clock", false)?;
        bag.tf = bag.topic("/tf", "tf2_msgs/msg/TFMessage", false)?;
        let tf_static = bag.topic("/tf_static", "tf2_msgs/msg/TFMessage", true)?;
        bag.odom = bag.topic("/odom", "nav_msgs/msg/Odometry", false)?;
        for s in &robot.sensors {
            let name = frames::ros_name(&s.name);
            let scan = bag.topic(&format!("/scan/{name}"), "sensor_msgs/msg/LaserScan", false)?;
            let signal = &s.config.signal;
            let echoes = if signal.return_mode == ReturnMode::Thesis {
                None
            } else {
                Some(bag.topic(
                    &format!("/echoes/{name}"),
                    "sensor_msgs/msg/PointCloud2",
                    false,
                )?)
            };
            let radar = if signal.image.is_some() && s.config.range_bin.is_some() {
                Some((
                    bag.topic(
                        &format!("/radar/{name}/image"),
                        "sensor_msgs/msg/Image",
                        false,
                    )?,
                    bag.topic(
                        &format!("/radar/{name}/points"),
                        "sensor_msgs/msg/PointCloud2",
                        false,
                    )?,
                ))
            } else {
                None
            };
            bag.sensors.push(SensorTopics {
                frame: frames::sensor_frame(&s.name),
                plane: s.config.horizontal_plane(),
                scan_time: 1.0 / s.config.rate_hz,
                scan,
                echoes,
                radar,
            });
        }
        let t0 = unix_ns(0.0);
        let mounts = convert::tf_static(t0, robot);
        bag.write(tf_static, t0, &mounts)?;
        Ok(bag)
    }

    /// Adds a topic of type `type_name`; returns its index in `topics`.
    fn topic(
        &mut self,
        name: &str,
        type_name: &'static str,
        latched: bool,
    ) -> Result<usize, RecordError> {
        let definition = msg::definition(type_name)
            .ok_or_else(|| mcap_msg(&format!("no definition of {type_name}")))?;
        let schema = self
            .out
            .add_schema(type_name, "ros2msg", definition.as_bytes())
            .map_err(mcap_err)?;
        let metadata = BTreeMap::from([
            ("offered_qos_profiles".to_owned(), json(&qos(latched))?),
            ("topic_type_hash".to_owned(), String::new()),
        ]);
        let channel = self
            .out
            .add_channel(schema, name, "cdr", &metadata)
            .map_err(mcap_err)?;
        self.topics.push(Topic {
            channel,
            name: name.to_owned(),
            type_name,
            latched,
            count: 0,
        });
        Ok(self.topics.len() - 1)
    }

    fn write<T: Serialize>(
        &mut self,
        topic: usize,
        ns: u64,
        message: &T,
    ) -> Result<(), RecordError> {
        let data = msg::cdr(message).map_err(|e| mcap_msg(&format!("CDR: {e}")))?;
        self.sequence = self.sequence.wrapping_add(1);
        let t = &mut self.topics[topic];
        t.count += 1;
        let header = mcap::records::MessageHeader {
            channel_id: t.channel,
            sequence: self.sequence,
            log_time: ns,
            publish_time: ns,
        };
        self.first_ns = self.first_ns.min(ns);
        self.last_ns = self.last_ns.max(ns);
        self.out
            .write_to_known_channel(&header, &data)
            .map_err(mcap_err)
    }

    /// `/tf` at `ns` from the true and the odometry pose, unless `/tf` has that stamp.
    fn tf(&mut self, ns: u64, truth: &Pose, odometry: &Pose) -> Result<(), RecordError> {
        if self.last_tf.is_some_and(|last| last >= ns) {
            return Ok(());
        }
        self.last_tf = Some(ns);
        let msg = convert::tf(ns, truth, odometry);
        self.write(self.tf, ns, &msg)
    }

    /// Logs a step: `/clock`, `/tf`, `/odom`.
    pub fn step(&mut self, step: &Step) -> Result<(), RecordError> {
        let ns = unix_ns(step.time);
        self.write(self.clock, ns, &convert::clock(ns))?;
        self.tf(ns, &step.truth, &step.odometry)?;
        self.write(self.odom, ns, &convert::odometry(ns, step))
    }

    /// Logs a scan: its transform (if taken between steps), its LaserScan and its echoes.
    pub fn scan(&mut self, event: &ScanEvent<'_>) -> Result<(), RecordError> {
        let scan = event.scan;
        let ns = unix_ns(scan.stamp);
        self.tf(ns, &event.truth, &event.odometry)?;
        let topics = &self.sensors[event.sensor];
        let msg = convert::laser_scan(scan, &topics.frame, topics.plane, topics.scan_time);
        let echoes = topics
            .echoes
            .map(|t| (t, convert::echoes(scan, &topics.frame)));
        self.write(topics.scan, ns, &msg)?;
        if let Some((topic, msg)) = echoes {
            self.write(topic, ns, &msg)?;
        }
        Ok(())
    }

    /// Logs a finished rotation of an imaging radar and its detections.
    pub fn radar_image(&mut self, sweep: &SweepImage) -> Result<(), RecordError> {
        let Some(topics) = self.sensors.get(sweep.sensor) else {
            return Ok(());
        };
        let Some((image_topic, points_topic)) = topics.radar else {
            return Ok(());
        };
        let (ns, image, points) = convert::radar_image(sweep, &topics.frame);
        self.write(image_topic, ns, &image)?;
        self.write(points_topic, ns, &points)
    }

    /// Adds the topic of map `name`; returns its index for [`Ros2Bag::grid`].
    pub fn add_map(&mut self, name: &str) -> Result<usize, RecordError> {
        let topic = self.topic(
            &format!("/map/{}", frames::ros_name(name)),
            "nav_msgs/msg/OccupancyGrid",
            false,
        )?;
        self.maps.push(topic);
        Ok(self.maps.len() - 1)
    }

    /// Logs map `map` (an index from [`Ros2Bag::add_map`]) as it is at time `t`.
    pub fn grid(&mut self, map: usize, t: f64, grid: &Grid) -> Result<(), RecordError> {
        let ns = unix_ns(t);
        self.write(self.maps[map], ns, &convert::occupancy_grid(ns, grid))
    }

    /// Closes the MCAP file; returns the sink and the text of `metadata.yaml`.
    pub fn finish(mut self) -> Result<(W, String), RecordError> {
        let info = self.metadata();
        let serialized = json(&info)?;
        self.out
            .write_metadata(&mcap::records::Metadata {
                name: "rosbag2".into(),
                metadata: BTreeMap::from([("serialized_metadata".to_owned(), serialized)]),
            })
            .map_err(mcap_err)?;
        self.out.finish().map_err(mcap_err)?;
        let yaml = json(&serde_json::json!({ "rosbag2_bagfile_information": info }))?;
        Ok((self.out.into_inner(), yaml + "\n"))
    }

    /// rosbag2's bag information (metadata version 9).
    fn metadata(&self) -> serde_json::Value {
        let count: u64 = self.topics.iter().map(|t| t.count).sum();
        let duration = self.last_ns - self.first_ns;
        let topics: Vec<_> = self
            .topics
            .iter()
            .map(|t| {
                serde_json::json!({
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.type_name,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": qos(t.latched),
                        "type_description_hash": "",
                    },
                    "message_count": t.count,
                })
            })
            .collect();
        serde_json::json!({
            "version": 9,
            "storage_identifier": "mcap",
            "relative_file_paths": [BAG_FILE],
            "duration": { "nanoseconds": duration },
            "starting_time": { "nanoseconds_since_epoch": self.first_ns },
            "message_count": count,
            "topics_with_message_count": topics,
            "compression_format": "",
            "compression_mode": "",
            "files": [{
                "path": BAG_FILE,
                "starting_time": { "nanoseconds_since_epoch": self.first_ns },
                "duration": { "nanoseconds": duration },
                "message_count": count,
            }],
            "custom_data": {},
            "ros_distro": "",
        })
    }
}
