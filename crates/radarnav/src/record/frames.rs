//! What the two MCAP recordings (Foxglove and rosbag2) share: the REP-105 frames, topic names,
//! the transforms between the frames, and the packed point layouts of echoes and detections.
//!
//! Frames: `map` (the world; the true pose of the robot is `map → base_link`), `odom` (where
//! the odometry started: `odom → base_link` is the odometry estimate, so `map → odom` is its
//! drift), `base_link` (the robot), and one frame per sensor, named as the sensor (mount
//! transforms, fixed). A scan is in its sensor's frame; maps, detections and paths are in
//! `map`.

use glam::DVec3;

use crate::map::CellClass;
use crate::pose::Pose;
use crate::sensor::{EchoKind, Scan, beam_ray};

/// The world frame.
pub const MAP: &str = "map";
/// The odometry frame.
pub const ODOM: &str = "odom";
/// The robot's frame.
pub const BASE_LINK: &str = "base_link";

/// `name` as a ROS graph name token: ASCII letters, digits and `_`, not starting with a digit
/// (other characters become `_`). Sensor and map names are free text in scenarios.
pub fn ros_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    s
}

/// The frame of sensor `name`.
pub fn sensor_frame(name: &str) -> String {
    ros_name(name)
}

/// The `map → odom` transform: the odometry's drift, such that `map → odom → base_link` is
/// the true pose when `odom → base_link` is the odometry estimate.
pub fn map_to_odom(truth: &Pose, odometry: &Pose) -> Pose {
    truth.compose(&odometry.inverse())
}

/// ROS occupancy of a map class: -1 unknown, 0 free, 100 for anything the robot cannot
/// cross (an obstacle, or foliage seen through but impassable: both lethal to a planner).
pub fn occupancy(class: CellClass) -> i8 {
    match class {
        CellClass::Unknown => -1,
        CellClass::Clear => 0,
        CellClass::SeeThrough | CellClass::Obstacle => 100,
    }
}

/// The type of a packed point field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// `float32`.
    F32,
    /// `uint8`.
    U8,
}

/// A field of a packed point: name, byte offset, type.
pub type PointFieldSpec = (&'static str, u32, FieldType);

/// The fields of an echo point: position (in the sensor frame), power in dB, kind (0 surface,
/// 1 volume), specular bounces before it.
pub const ECHO_FIELDS: &[PointFieldSpec] = &[
    ("x", 0, FieldType::F32),
    ("y", 4, FieldType::F32),
    ("z", 8, FieldType::F32),
    ("power_db", 12, FieldType::F32),
    ("kind", 16, FieldType::U8),
    ("bounces", 17, FieldType::U8),
];
/// Bytes per echo point.
pub const ECHO_STRIDE: u32 = 18;

/// The fields of a detection point: position (in `map`) and the image's value there.
pub const DETECTION_FIELDS: &[PointFieldSpec] = &[
    ("x", 0, FieldType::F32),
    ("y", 4, FieldType::F32),
    ("z", 8, FieldType::F32),
    ("power", 12, FieldType::U8),
];
/// Bytes per detection point.
pub const DETECTION_STRIDE: u32 = 13;

/// Every echo of `scan` packed as [`ECHO_FIELDS`], in the sensor's frame; with the count.
pub fn echo_points(scan: &Scan) -> (Vec<u8>, usize) {
    let mut data = Vec::with_capacity(scan.echoes.len() * ECHO_STRIDE as usize);
    let sensor = Pose::default();
    for i in 0..scan.len() {
        let (az, el) = scan.angles(i);
        let ray = beam_ray(&sensor, az, el.sin_cos(), 0.0);
        for e in scan.echoes_of(i) {
            let p = ray.at(e.range);
            for v in [p.x, p.y, p.z, e.power_db()] {
                data.extend_from_slice(&(v as f32).to_le_bytes());
            }
            data.push(match e.kind {
                EchoKind::Surface => 0,
                EchoKind::Volume => 1,
            });
            data.push(e.bounces);
        }
    }
    let n = data.len() / ECHO_STRIDE as usize;
    (data, n)
}

/// Detections (value, position in `map`) packed as [`DETECTION_FIELDS`].
pub fn detection_points<'a>(detections: impl IntoIterator<Item = (u8, &'a DVec3)>) -> Vec<u8> {
    let mut data = Vec::new();
    for (power, p) in detections {
        for v in [p.x, p.y, p.z] {
            data.extend_from_slice(&(v as f32).to_le_bytes());
        }
        data.push(power);
    }
    data
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_odom_base_link_composes_to_the_true_pose() {
        let truth = Pose::new(3.0, -2.0, 0.0, 2.5);
        let odometry = Pose::new(2.7, -1.6, 0.0, 2.3);
        let m2o = map_to_odom(&truth, &odometry);
        let back = m2o.compose(&odometry);
        assert!((back.x - truth.x).abs() < 1e-12 && (back.y - truth.y).abs() < 1e-12);
        assert!((back.yaw - truth.yaw).abs() < 1e-12);
        // No drift: `map` and `odom` coincide.
        let p = map_to_odom(&truth, &truth);
        assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12 && p.yaw.abs() < 1e-12);
    }

    #[test]
    fn names_become_ros_tokens() {
        assert_eq!(ros_name("navtech_cts350x"), "navtech_cts350x");
        assert_eq!(ros_name("front laser-2"), "front_laser_2");
        assert_eq!(ros_name("2d"), "_2d");
        assert_eq!(ros_name(""), "_");
    }
}
