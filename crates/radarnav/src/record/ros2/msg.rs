//! The ROS 2 messages radarnav publishes, as serde structs in field order (CDR serialises
//! fields in declaration order), and their `.msg` definitions for the bag's `ros2msg` schemas.
//!
//! The definitions are the field and constant lines of the ROS 2 interface files (comments
//! left out: they carry no type information); [`definition`] joins a type with everything it
//! uses the way rosbag2 does.

use serde::ser::{SerializeTuple, Serializer};
use serde::{Deserialize, Serialize};

/// builtin_interfaces/msg/Time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, below 1e9.
    pub nanosec: u32,
}

impl Time {
    /// The stamp of UNIX nanoseconds `ns`.
    pub fn from_ns(ns: u64) -> Self {
        let (sec, nanosec) = crate::stamp::split(ns);
        Self {
            sec: i32::try_from(sec).unwrap_or(i32::MAX),
            nanosec,
        }
    }
}

/// std_msgs/msg/Header.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data.
    pub stamp: Time,
    /// Frame the data is in.
    pub frame_id: String,
}

/// rosgraph_msgs/msg/Clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// Simulation time.
    pub clock: Time,
}

/// geometry_msgs/msg/Vector3 (also Point: the same fields).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// geometry_msgs/msg/Quaternion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// A turn by `yaw` about z.
    pub fn yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Self {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }
}

/// geometry_msgs/msg/Transform.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation, m.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// geometry_msgs/msg/Pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseMsg {
    /// Position, m.
    pub position: Vector3,
    /// Orientation.
    pub orientation: Quaternion,
}

impl From<&crate::pose::Pose> for PoseMsg {
    fn from(p: &crate::pose::Pose) -> Self {
        Self {
            position: Vector3 {
                x: p.x,
                y: p.y,
                z: p.z,
            },
            orientation: Quaternion::yaw(p.yaw),
        }
    }
}

impl From<&crate::pose::Pose> for Transform {
    fn from(p: &crate::pose::Pose) -> Self {
        let m = PoseMsg::from(p);
        Self {
            translation: m.position,
            rotation: m.orientation,
        }
    }
}

/// geometry_msgs/msg/TransformStamped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent frame.
    pub transform: Transform,
}

/// tf2_msgs/msg/TFMessage.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// A row-major 6 × 6 covariance (`float64[36]`: a fixed array, so no length in CDR).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Self([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

/// geometry_msgs/msg/PoseWithCovariance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: PoseMsg,
    /// Its covariance (x, y, z, roll, pitch, yaw).
    pub covariance: Covariance,
}

/// geometry_msgs/msg/Twist.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistMsg {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

/// geometry_msgs/msg/TwistWithCovariance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: TwistMsg,
    /// Its covariance.
    pub covariance: Covariance,
}

/// nav_msgs/msg/Odometry.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Odometry {
    /// Stamp and the pose's frame (`odom`).
    pub header: Header,
    /// The twist's frame (`base_link`).
    pub child_frame_id: String,
    /// Pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Velocity in `child_frame_id`.
    pub twist: TwistWithCovariance,
}

/// sensor_msgs/msg/LaserScan.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LaserScan {
    /// Stamp of the first ray and the sensor frame.
    pub header: Header,
    /// rad.
    pub angle_min: f32,
    /// rad.
    pub angle_max: f32,
    /// rad.
    pub angle_increment: f32,
    /// s between rays.
    pub time_increment: f32,
    /// s between scans.
    pub scan_time: f32,
    /// m.
    pub range_min: f32,
    /// m.
    pub range_max: f32,
    /// m; +inf where nothing returned (REP-117).
    pub ranges: Vec<f32>,
    /// Device-specific; empty.
    pub intensities: Vec<f32>,
}

/// sensor_msgs/msg/Image.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Image {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`mono8`).
    pub encoding: String,
    /// 0: little-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// Pixels, row after row.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// sensor_msgs/msg/PointField.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointField {
    /// Field name.
    pub name: String,
    /// Byte offset in a point.
    pub offset: u32,
    /// Type code: 2 UINT8, 7 FLOAT32.
    pub datatype: u8,
    /// Elements.
    pub count: u32,
}

/// PointField's type code of a `uint8`.
pub const UINT8: u8 = 2;
/// PointField's type code of a `float32`.
pub const FLOAT32: u8 = 7;

/// sensor_msgs/msg/PointCloud2.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// 1: unordered.
    pub height: u32,
    /// Points.
    pub width: u32,
    /// The fields of a point.
    pub fields: Vec<PointField>,
    /// false.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The points.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// Whether every point is finite.
    pub is_dense: bool,
}

/// nav_msgs/msg/MapMetaData.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapMetaData {
    /// When the map was made.
    pub map_load_time: Time,
    /// m per cell.
    pub resolution: f32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pose of cell (0, 0)'s corner in the header's frame.
    pub origin: PoseMsg,
}

/// nav_msgs/msg/OccupancyGrid.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OccupancyGrid {
    /// Stamp and frame (`map`).
    pub header: Header,
    /// Size and placement.
    pub info: MapMetaData,
    /// Row-major from the origin: -1 unknown, 0 free, 100 occupied.
    pub data: Vec<i8>,
}

/// Every definition: (package resource name, `.msg` fields).
const DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"),
    ("rosgraph_msgs/msg/Clock", "builtin_interfaces/Time clock\n"),
    (
        "std_msgs/msg/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
    ),
    (
        "tf2_msgs/msg/TFMessage",
        "geometry_msgs/TransformStamped[] transforms\n",
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    ),
    (
        "geometry_msgs/msg/Transform",
        "Vector3 translation\nQuaternion rotation\n",
    ),
    (
        "geometry_msgs/msg/Vector3",
        "float64 x\nfloat64 y\nfloat64 z\n",
    ),
    (
        "geometry_msgs/msg/Point",
        "float64 x\nfloat64 y\nfloat64 z\n",
    ),
    (
        "geometry_msgs/msg/Quaternion",
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    ),
    (
        "geometry_msgs/msg/Pose",
        "Point position\nQuaternion orientation\n",
    ),
    (
        "geometry_msgs/msg/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance\n",
    ),
    (
        "geometry_msgs/msg/Twist",
        "Vector3 linear\nVector3 angular\n",
    ),
    (
        "geometry_msgs/msg/TwistWithCovariance",
        "Twist twist\nfloat64[36] covariance\n",
    ),
    (
        "nav_msgs/msg/Odometry",
        "std_msgs/Header header\nstring child_frame_id\n\
         geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
    ),
    (
        "nav_msgs/msg/MapMetaData",
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\n\
         uint32 height\ngeometry_msgs/Pose origin\n",
    ),
    (
        "nav_msgs/msg/OccupancyGrid",
        "std_msgs/Header header\nMapMetaData info\nint8[] data\n",
    ),
    (
        "sensor_msgs/msg/LaserScan",
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\n\
         float32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\n\
         float32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n",
    ),
    (
        "sensor_msgs/msg/Image",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
         uint8 is_bigendian\nuint32 step\nuint8[] data\n",
    ),
    (
        "sensor_msgs/msg/PointField",
        "uint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\nuint8 INT32 = 5\n\
         uint8 UINT32 = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\nstring name\nuint32 offset\n\
         uint8 datatype\nuint32 count\n",
    ),
    (
        "sensor_msgs/msg/PointCloud2",
        "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n\
         bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
    ),
];

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "float32", "float64", "string", "wstring",
];

fn fields(type_name: &str) -> Option<&'static str> {
    DEFINITIONS
        .iter()
        .find(|(n, _)| *n == type_name)
        .map(|(_, f)| *f)
}

/// The types a definition uses, as package resource names, in the order of its lines.
fn dependencies(type_name: &str, text: &str) -> Vec<String> {
    let package = type_name.split('/').next().unwrap_or_default();
    text.lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(|t| t.split('[').next().unwrap_or(t))
        .filter(|t| !PRIMITIVES.contains(t) && !t.starts_with("string<"))
        .map(|t| match t.split_once('/') {
            Some((pkg, name)) => format!("{pkg}/msg/{name}"),
            None => format!("{package}/msg/{t}"),
        })
        .collect()
}

/// The complete `ros2msg` definition of `type_name` (e.g. `sensor_msgs/msg/LaserScan`): its
/// fields, then each type it uses, once, depth first, after a line of 80 `=` and
/// `MSG: <type>` (rosbag2's encoding). None for a type not listed here.
pub fn definition(type_name: &str) -> Option<String> {
    fn add(type_name: &str, seen: &mut Vec<String>, out: &mut String) -> Option<()> {
        let text = fields(type_name)?;
        out.push_str(text);
        for dep in dependencies(type_name, text) {
            if !seen.contains(&dep) {
                seen.push(dep.clone());
                out.push('\n');
                out.push_str(&"=".repeat(80));
                out.push_str("\nMSG: ");
                out.push_str(&dep);
                out.push('\n');
                add(&dep, seen, out)?;
            }
        }
        Some(())
    }
    let mut out = String::new();
    add(type_name, &mut Vec::new(), &mut out)?;
    Some(out)
}

/// `msg` in CDR, little-endian, after the 4-byte encapsulation header (`CDR_LE`), as ROS 2
/// puts it on the wire and rosbag2 stores it.
pub fn cdr<T: Serialize>(msg: &T) -> Result<Vec<u8>, cdr_encoding::Error> {
    let mut out = vec![0x00, 0x01, 0x00, 0x00];
    cdr_encoding::to_writer::<T, byteorder::LittleEndian, _>(&mut out, msg)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_used_type_is_defined() {
        for (name, text) in DEFINITIONS {
            for dep in dependencies(name, text) {
                assert!(fields(&dep).is_some(), "{name} uses {dep}, not defined");
            }
        }
    }

    #[test]
    fn a_definition_lists_each_dependency_once_after_rosbag2s_delimiter() {
        let d = definition("nav_msgs/msg/Odometry").expect("defined");
        assert!(d.starts_with("std_msgs/Header header\n"));
        for dep in [
            "std_msgs/msg/Header",
            "builtin_interfaces/msg/Time",
            "geometry_msgs/msg/PoseWithCovariance",
            "geometry_msgs/msg/Pose",
            "geometry_msgs/msg/Point",
            "geometry_msgs/msg/Quaternion",
            "geometry_msgs/msg/TwistWithCovariance",
            "geometry_msgs/msg/Twist",
            "geometry_msgs/msg/Vector3",
        ] {
            let line = format!("{}\nMSG: {dep}\n", "=".repeat(80));
            assert_eq!(d.matches(&line).count(), 1, "{dep} in\n{d}");
        }
        assert!(definition("std_msgs/msg/Nothing").is_none());
    }

    #[test]
    fn cdr_aligns_each_primitive_to_its_size_after_the_header() {
        let msg = Header {
            stamp: Time { sec: 1, nanosec: 2 },
            frame_id: "ab".into(),
        };
        let bytes = cdr(&msg).expect("encodes");
        assert_eq!(
            bytes,
            [
                0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, b'a', b'b', 0
            ]
        );
        // A float64 after a 1-byte-long string pads to 8 from the payload's start.
        let t = TransformStamped {
            header: Header {
                stamp: Time::default(),
                frame_id: String::new(),
            },
            child_frame_id: String::new(),
            transform: Transform::from(&crate::pose::Pose::new(1.0, 0.0, 0.0, 0.0)),
        };
        let b = cdr(&t).expect("encodes");
        // payload: time 8, "" 4 + 1, pad 3 to 16, "" 4 + 1, pad 3 to 24, then 7 float64.
        assert_eq!(b.len(), 4 + 24 + 7 * 8);
        assert_eq!(&b[4 + 24..4 + 32], &1.0f64.to_le_bytes());
    }
}
