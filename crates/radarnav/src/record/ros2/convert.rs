//! radarnav's values as ROS 2 messages, the one place both the rosbag2 recording and the live
//! ROS 2 node build them (frames as in [`crate::record::frames`], stamps as UNIX ns from
//! [`crate::stamp`]).

use super::msg::{self, Header, Time};
use crate::map::Grid;
use crate::pose::Pose;
use crate::record::frames::{self, BASE_LINK, FieldType, MAP, ODOM, PointFieldSpec};
use crate::record::radar_images::SweepImage;
use crate::sensor::Scan;
use crate::setup::Robot;
use crate::sim::Step;

/// A header at `ns` in `frame`.
pub fn header(ns: u64, frame: &str) -> Header {
    Header {
        stamp: Time::from_ns(ns),
        frame_id: frame.to_owned(),
    }
}

/// `/clock` at `ns`.
pub fn clock(ns: u64) -> msg::Clock {
    msg::Clock {
        clock: Time::from_ns(ns),
    }
}

/// `child`'s pose in `parent` at `ns`.
pub fn transform(ns: u64, parent: &str, child: &str, pose: &Pose) -> msg::TransformStamped {
    msg::TransformStamped {
        header: header(ns, parent),
        child_frame_id: child.to_owned(),
        transform: msg::Transform::from(pose),
    }
}

/// `/tf` at `ns`: `map → odom` (the odometry's drift) and `odom → base_link` (the odometry).
pub fn tf(ns: u64, truth: &Pose, odometry: &Pose) -> msg::TfMessage {
    msg::TfMessage {
        transforms: vec![
            transform(ns, MAP, ODOM, &frames::map_to_odom(truth, odometry)),
            transform(ns, ODOM, BASE_LINK, odometry),
        ],
    }
}

/// `/tf_static` at `ns`: `base_link → <sensor>` for every sensor of `robot`.
pub fn tf_static(ns: u64, robot: &Robot) -> msg::TfMessage {
    msg::TfMessage {
        transforms: robot
            .sensors
            .iter()
            .map(|s| transform(ns, BASE_LINK, &frames::sensor_frame(&s.name), &s.mount))
            .collect(),
    }
}

/// `/odom` of a step: the odometry estimate in `odom`, the executed command (none if the
/// move was refused) as twist in `base_link`.
pub fn odometry(ns: u64, step: &Step) -> msg::Odometry {
    let executed = if step.bumped {
        crate::vehicle::Twist::default()
    } else {
        step.command
    };
    msg::Odometry {
        header: header(ns, ODOM),
        child_frame_id: BASE_LINK.to_owned(),
        pose: msg::PoseWithCovariance {
            pose: msg::PoseMsg::from(&step.odometry),
            covariance: msg::Covariance::default(),
        },
        twist: msg::TwistWithCovariance {
            twist: msg::TwistMsg {
                linear: msg::Vector3 {
                    x: executed.v,
                    ..Default::default()
                },
                angular: msg::Vector3 {
                    z: executed.omega,
                    ..Default::default()
                },
            },
            covariance: msg::Covariance::default(),
        },
    }
}

/// A scan as a LaserScan in its sensor's `frame`: the plane `plane` (see
/// [`SensorConfig::horizontal_plane`](crate::sensor::SensorConfig::horizontal_plane)),
/// `scan_time` s between scans, +inf where nothing returned.
pub fn laser_scan(scan: &Scan, frame: &str, plane: usize, scan_time: f64) -> msg::LaserScan {
    let rows = plane * scan.azimuths..(plane + 1) * scan.azimuths;
    let angle_max = scan.angle_min + (scan.azimuths.max(1) - 1) as f64 * scan.angle_increment;
    msg::LaserScan {
        header: header(crate::stamp::unix_ns(scan.stamp), frame),
        angle_min: scan.angle_min as f32,
        angle_max: angle_max as f32,
        angle_increment: scan.angle_increment as f32,
        time_increment: 0.0,
        scan_time: scan_time as f32,
        range_min: scan.range_min as f32,
        range_max: scan.range_max as f32,
        ranges: scan.ranges.get(rows).unwrap_or_default().to_vec(),
        intensities: Vec::new(),
    }
}

fn fields(spec: &[PointFieldSpec]) -> Vec<msg::PointField> {
    spec.iter()
        .map(|&(name, offset, kind)| msg::PointField {
            name: name.to_owned(),
            offset,
            datatype: match kind {
                FieldType::F32 => msg::FLOAT32,
                FieldType::U8 => msg::UINT8,
            },
            count: 1,
        })
        .collect()
}

/// Packed points as an unordered PointCloud2.
pub fn cloud(
    ns: u64,
    frame: &str,
    spec: &[PointFieldSpec],
    stride: u32,
    data: Vec<u8>,
) -> msg::PointCloud2 {
    let width = (data.len() / stride as usize) as u32;
    msg::PointCloud2 {
        header: header(ns, frame),
        height: 1,
        width,
        fields: fields(spec),
        is_bigendian: false,
        point_step: stride,
        row_step: width * stride,
        data,
        is_dense: true,
    }
}

/// Every echo of a scan as a PointCloud2 in the sensor's `frame`.
pub fn echoes(scan: &Scan, frame: &str) -> msg::PointCloud2 {
    let (data, _) = frames::echo_points(scan);
    cloud(
        crate::stamp::unix_ns(scan.stamp),
        frame,
        frames::ECHO_FIELDS,
        frames::ECHO_STRIDE,
        data,
    )
}

/// A finished rotation as a `mono8` Image in the Oxford layout, stamped at its first row,
/// and its detections as a PointCloud2 in `map`; with the stamp.
pub fn radar_image(sweep: &SweepImage, frame: &str) -> (u64, msg::Image, msg::PointCloud2) {
    let img = &sweep.image;
    let first_us = img
        .timestamps_us
        .first()
        .copied()
        .unwrap_or(crate::stamp::EPOCH_US);
    let ns = u64::try_from(first_us).unwrap_or(0).saturating_mul(1000);
    let width = crate::sensor::image::ROW_HEADER + img.bins;
    let image = msg::Image {
        header: header(ns, frame),
        height: img.rows() as u32,
        width: width as u32,
        encoding: "mono8".into(),
        is_bigendian: 0,
        step: width as u32,
        data: img.oxford_rows(),
    };
    let data = frames::detection_points(sweep.detections.iter().map(|(d, p)| (d.power, p)));
    let points = cloud(
        ns,
        MAP,
        frames::DETECTION_FIELDS,
        frames::DETECTION_STRIDE,
        data,
    );
    (ns, image, points)
}

/// A map as an OccupancyGrid in `map` at `ns`, whole: -1 unknown, 0 free, 100 impassable.
pub fn occupancy_grid(ns: u64, grid: &Grid) -> msg::OccupancyGrid {
    let o = grid.origin();
    msg::OccupancyGrid {
        header: header(ns, MAP),
        info: msg::MapMetaData {
            map_load_time: Time::from_ns(ns),
            resolution: grid.resolution() as f32,
            width: grid.width() as u32,
            height: grid.height() as u32,
            origin: msg::PoseMsg::from(&Pose::new(o.x, o.y, 0.0, 0.0)),
        },
        data: (0..grid.width() * grid.height())
            .map(|i| frames::occupancy(grid.class_at(i)))
            .collect(),
    }
}
