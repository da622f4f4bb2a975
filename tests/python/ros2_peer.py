"""A ROS 2 peer on CycloneDDS (PyPI `cyclonedds`), for test_ros2_live.py: run inside the
test's network namespace next to `radarnav ros2`. It subscribes to /scan/radar, /scan/laser,
/odom, /clock and /tf_static with ROS 2's DDS names and types, counts what arrives for a
while, then publishes geometry_msgs/Twist on /cmd_vel and watches /odom move. Prints one
JSON object."""

import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time


@dataclass
class LaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    header: Header
    angle_min: float32
    angle_max: float32
    angle_increment: float32
    time_increment: float32
    scan_time: float32
    range_min: float32
    range_max: float32
    ranges: sequence[float32]
    intensities: sequence[float32]


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


LISTEN = float(sys.argv[1]) if len(sys.argv) > 1 else 4.0
DRIVE = float(sys.argv[2]) if len(sys.argv) > 2 else 3.0
IMAGING = sys.argv[3] if len(sys.argv) > 3 else None  # an imaging radar's name

reliable = Qos(Policy.Reliability.Reliable(max_blocking_time=1), Policy.Durability.Volatile,
               Policy.History.KeepLast(100))
latched = Qos(Policy.Reliability.Reliable(max_blocking_time=1),
              Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
dp = DomainParticipant(0)
readers = {
    "/scan/radar": DataReader(dp, Topic(dp, "rt/scan/radar", LaserScan), qos=reliable),
    "/scan/laser": DataReader(dp, Topic(dp, "rt/scan/laser", LaserScan), qos=reliable),
    "/odom": DataReader(dp, Topic(dp, "rt/odom", Odometry), qos=reliable),
    "/clock": DataReader(dp, Topic(dp, "rt/clock", Clock), qos=reliable),
}
if IMAGING:
    readers[f"/scan/{IMAGING}"] = DataReader(
        dp, Topic(dp, f"rt/scan/{IMAGING}", LaserScan), qos=reliable)
if IMAGING:
    readers[f"/radar/{IMAGING}/image"] = DataReader(
        dp, Topic(dp, f"rt/radar/{IMAGING}/image", Image), qos=reliable)
tf_static = DataReader(dp, Topic(dp, "rt/tf_static", TFMessage), qos=latched)
cmd_vel = DataWriter(dp, Topic(dp, "rt/cmd_vel", Twist), qos=reliable)


def stamp(h):
    return h.stamp.sec + h.stamp.nanosec * 1e-9


# Wait for discovery: the first scan of the laser.
t0 = time.time()
while time.time() - t0 < 20 and not readers["/scan/laser"].take(N=100):
    time.sleep(0.01)
discovery = time.time() - t0
counts = {k: 0 for k in readers}
frames = {}
clock = []
odom_x = []
statics = []
start = time.time()


def poll():
    for topic, reader in readers.items():
        for m in reader.take(N=1000):
            counts[topic] += 1
            if topic == "/clock":
                clock.append(m.clock.sec + m.clock.nanosec * 1e-9)
                continue
            frames.setdefault(topic, m.header.frame_id)
            if topic.endswith("/image"):
                frames.setdefault(topic + " size", [m.height, m.width, len(m.data), m.encoding])
            if topic == "/odom":
                frames.setdefault("/odom child", m.child_frame_id)
                odom_x.append(m.pose.pose.position.x)
    for m in tf_static.take(N=10):
        statics.extend([t.header.frame_id, t.child_frame_id] for t in m.transforms)


while time.time() - start < LISTEN:
    poll()
    time.sleep(0.01)
listened = time.time() - start
rates = {k: v / listened for k, v in counts.items()}
x_before = odom_x[-1] if odom_x else None
drive_start = time.time()
while time.time() - drive_start < DRIVE:
    cmd_vel.write(Twist(Vector3(0.3, 0.0, 0.0), Vector3(0.0, 0.0, 0.0)))
    poll()
    time.sleep(0.05)
cmd_vel.write(Twist(Vector3(0.0, 0.0, 0.0), Vector3(0.0, 0.0, 0.0)))
poll()
print(json.dumps({
    "discovery": discovery,
    "listened": listened,
    "rates": rates,
    "frames": frames,
    "tf_static": statics,
    "clock_increasing": all(a < b for a, b in zip(clock, clock[1:])),
    "clock_first": clock[0] if clock else None,
    "odom_x_before": x_before,
    "odom_x_after": odom_x[-1] if odom_x else None,
}))
