"""rosbags and mcap-ros2-support (the ROS 2 bag readers on PyPI) read radarnav's rosbag2.

`radarnav run foliage-wall --ros2-bag` with an imaging, multi-echo radar added records every
topic of the bag. rosbags must open the bag directory (metadata.yaml + MCAP), list the topics
with their ROS types and deserialise every message; mcap-ros2-support must decode every
message from the schemas in the MCAP alone. The messages must carry REP-105 frames, stamps
from the fixed epoch that agree with the run's own trajectory.csv, and the counts the run's
summary.json reports.
"""

import csv
import json
import math
import os
import subprocess
import tempfile
import unittest
from collections import Counter, defaultdict
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

RADARNAV = os.environ.get("RADARNAV", "radarnav")
EPOCH_NS = 1_700_000_000 * 10**9
DURATION = 6.0
NAVTECH = "navtech_cts350x"

TYPES = {
    "/clock": "rosgraph_msgs/msg/Clock",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/odom": "nav_msgs/msg/Odometry",
    "/scan/radar": "sensor_msgs/msg/LaserScan",
    "/scan/laser": "sensor_msgs/msg/LaserScan",
    f"/scan/{NAVTECH}": "sensor_msgs/msg/LaserScan",
    f"/echoes/{NAVTECH}": "sensor_msgs/msg/PointCloud2",
    f"/radar/{NAVTECH}/image": "sensor_msgs/msg/Image",
    f"/radar/{NAVTECH}/points": "sensor_msgs/msg/PointCloud2",
    "/map/radar": "nav_msgs/msg/OccupancyGrid",
    "/map/laser": "nav_msgs/msg/OccupancyGrid",
    f"/map/{NAVTECH}": "nav_msgs/msg/OccupancyGrid",
}


def ns(stamp):
    return stamp.sec * 10**9 + stamp.nanosec


def yaw(q):
    return 2.0 * math.atan2(q.z, q.w)


class Ros2Bag(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        out = Path(cls.tmp.name) / "out"
        subprocess.run(
            [RADARNAV, "run", "foliage-wall", "--ros2-bag", "--add-sensor", NAVTECH,
             "--duration", str(DURATION), "--out", str(out)],
            check=True, capture_output=True,
        )
        cls.bag = out / "ros2_bag"
        cls.summary = json.loads((out / "summary.json").read_text())
        with open(out / "trajectory.csv", newline="") as f:
            cls.trajectory = [
                {k: float(v) for k, v in row.items()} for row in csv.DictReader(f)
            ]
        cls.messages = defaultdict(list)  # topic -> [(log time, message)]
        store = get_typestore(Stores.ROS2_HUMBLE)
        with AnyReader([cls.bag], default_typestore=store) as reader:
            cls.connections = {c.topic: c for c in reader.connections}
            for conn, t, raw in reader.messages():
                cls.messages[conn.topic].append((t, reader.deserialize(raw, conn.msgtype)))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_topics_types_and_counts(self):
        self.assertEqual({t: c.msgtype for t, c in self.connections.items()}, TYPES)
        for topic, conn in self.connections.items():
            self.assertEqual(conn.msgcount, len(self.messages[topic]), topic)
        steps = self.summary["steps"]
        # Every step and the final state.
        self.assertEqual(len(self.messages["/clock"]), steps + 1)
        self.assertEqual(len(self.messages["/odom"]), steps + 1)
        self.assertEqual(len(self.trajectory), steps + 1)
        scans = {s["name"]: s["scans"] for s in self.summary["sensors"]}
        for name in ("radar", "laser", NAVTECH):
            self.assertEqual(len(self.messages[f"/scan/{name}"]), scans[name], name)
        self.assertEqual(len(self.messages[f"/echoes/{NAVTECH}"]), scans[NAVTECH])
        # A rotation of 400 azimuths at 4 Hz: one image a rotation, less one turning at the end.
        images = len(self.messages[f"/radar/{NAVTECH}/image"])
        self.assertEqual(images, int(DURATION * 4) - 1)
        self.assertEqual(len(self.messages[f"/radar/{NAVTECH}/points"]), images)
        self.assertEqual(len(self.messages["/tf_static"]), 1)

    def test_frames_follow_rep_105(self):
        (_, static), = self.messages["/tf_static"]
        mounts = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
        self.assertEqual(mounts, {("base_link", s) for s in ("radar", "laser", NAVTECH)})
        for _, m in self.messages["/tf"]:
            pairs = [(t.header.frame_id, t.child_frame_id) for t in m.transforms]
            self.assertEqual(pairs, [("map", "odom"), ("odom", "base_link")])
        for _, m in self.messages["/odom"]:
            self.assertEqual((m.header.frame_id, m.child_frame_id), ("odom", "base_link"))
        for name in ("radar", "laser", NAVTECH):
            for _, m in self.messages[f"/scan/{name}"]:
                self.assertEqual(m.header.frame_id, name)
        for _, m in self.messages[f"/radar/{NAVTECH}/image"]:
            self.assertEqual((m.header.frame_id, m.encoding), (NAVTECH, "mono8"))
            self.assertEqual(m.step, m.width)
            self.assertEqual(len(m.data), m.width * m.height)
        for name in ("radar", "laser", NAVTECH):
            for _, m in self.messages[f"/map/{name}"]:
                self.assertEqual(m.header.frame_id, "map")
                self.assertEqual(len(m.data), m.info.width * m.info.height)
                self.assertTrue(set(m.data.tolist()) <= {-1, 0, 100})

    def test_stamps_start_at_the_epoch_and_match_the_log_times(self):
        clock = [ns(m.clock) for _, m in self.messages["/clock"]]
        self.assertEqual(clock[0], EPOCH_NS)
        self.assertTrue(all(a < b for a, b in zip(clock, clock[1:])))
        self.assertEqual(clock[-1], EPOCH_NS + round(self.summary["duration"] * 1e9))
        for topic, messages in self.messages.items():
            for t, m in messages:
                if hasattr(m, "header"):
                    self.assertEqual(ns(m.header.stamp), t, topic)
                elif hasattr(m, "transforms"):
                    for tr in m.transforms:
                        self.assertEqual(ns(tr.header.stamp), t, topic)
        # No transform stamp twice (tf2 warns of repeated data).
        tf = [t for t, _ in self.messages["/tf"]]
        self.assertEqual(len(tf), len(set(tf)))

    def test_transforms_and_odometry_are_the_runs_poses(self):
        rows = {EPOCH_NS + round(r["time"] * 1e9): r for r in self.trajectory}
        tf = {t: m for t, m in self.messages["/tf"]}
        checked = 0
        for t, odom in self.messages["/odom"]:
            row = rows[t]
            p = odom.pose.pose
            self.assertAlmostEqual(p.position.x, row["odom_x"], places=4)
            self.assertAlmostEqual(p.position.y, row["odom_y"], places=4)
            self.assertAlmostEqual(math.degrees(yaw(p.orientation)), row["odom_yaw_deg"], places=3)
            # map → odom → base_link is the true pose.
            m2o, o2b = tf[t].transforms
            a, b = m2o.transform, o2b.transform
            th = yaw(a.rotation)
            x = a.translation.x + math.cos(th) * b.translation.x - math.sin(th) * b.translation.y
            y = a.translation.y + math.sin(th) * b.translation.x + math.cos(th) * b.translation.y
            self.assertAlmostEqual(x, row["x"], places=4)
            self.assertAlmostEqual(y, row["y"], places=4)
            checked += 1
        self.assertEqual(checked, len(self.trajectory))
        end = self.summary["final_pose"]
        last = self.trajectory[-1]
        self.assertAlmostEqual(last["x"], end["x"], places=4)
        self.assertAlmostEqual(last["y"], end["y"], places=4)

    def test_scans_are_laser_scans_in_their_own_frame(self):
        _, scan = self.messages["/scan/laser"][0]
        self.assertEqual(len(scan.ranges), 1081)
        self.assertAlmostEqual(scan.angle_max - scan.angle_min, math.radians(270), places=5)
        self.assertAlmostEqual(scan.scan_time, 1 / 40, places=6)
        finite = [r for r in scan.ranges if math.isfinite(r)]
        self.assertTrue(finite and all(scan.range_min <= r <= scan.range_max for r in finite))
        self.assertEqual(len(scan.intensities), 0)
        _, cloud = self.messages[f"/echoes/{NAVTECH}"][-1]
        self.assertEqual([f.name for f in cloud.fields],
                         ["x", "y", "z", "power_db", "kind", "bounces"])
        self.assertEqual(len(cloud.data), cloud.width * cloud.point_step)
        self.assertGreater(cloud.width, 0)

    def test_mcap_ros2_support_decodes_every_message_from_the_schemas(self):
        counts = Counter()
        with open(self.bag / "ros2_bag_0.mcap", "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            self.assertEqual(reader.get_header().profile, "ros2")
            for schema, channel, _message, decoded in reader.iter_decoded_messages():
                self.assertEqual(schema.encoding, "ros2msg")
                self.assertEqual(channel.message_encoding, "cdr")
                self.assertEqual(schema.name, TYPES[channel.topic])
                counts[channel.topic] += 1
                if channel.topic == "/odom":
                    self.assertEqual(decoded.child_frame_id, "base_link")
        self.assertEqual(dict(counts), {t: len(m) for t, m in self.messages.items()})


if __name__ == "__main__":
    unittest.main()
