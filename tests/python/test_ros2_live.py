"""The live ROS 2 node (`radarnav ros2`, built with the `ros2` feature) seen by a ROS 2 peer
on CycloneDDS from PyPI, both inside a network namespace of their own (`unshare -rn`): only
loopback exists there, multicast is off, and the peers find each other by unicast on
127.0.0.1, so no packet can leave the machine.

The peer (ros2_peer.py) must receive /scan/radar, /scan/laser, /odom and /clock at their
rates (4, 40, 20 and 20 Hz on foliage-wall), the Navtech's polar images (a rotation each
0.25 s), in their REP-105 frames, the mounts on the latched /tf_static, and, after it publishes geometry_msgs/Twist (0.3 m/s) on /cmd_vel for
3 s, see /odom move forward.
"""

import json
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

RADARNAV = os.environ.get("RADARNAV", "radarnav")
HERE = Path(__file__).resolve().parent

CYCLONE = (
    '<CycloneDDS><Domain><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery>"
    '<ParticipantIndex>auto</ParticipantIndex><Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery></Domain></CycloneDDS>"
)

SCRIPT = """
set -e
ip link set lo up
ip link set lo multicast off
"$RADARNAV" ros2 foliage-wall --duration 40 --no-maps --add-sensor navtech_cts350x 2>"$LOG" &
node=$!
"$PYTHON" "$PEER" 4 3 navtech_cts350x
kill -INT $node
wait $node
"""


class Ros2Live(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        log = Path(cls.tmp.name) / "node.log"
        env = dict(os.environ, RADARNAV=RADARNAV, PYTHON=sys.executable,
                   PEER=str(HERE / "ros2_peer.py"), LOG=str(log), CYCLONEDDS_URI=CYCLONE)
        out = subprocess.run(["unshare", "-rn", "bash", "-c", SCRIPT], env=env,
                             capture_output=True, text=True, timeout=120)
        cls.node_log = log.read_text() if log.exists() else ""
        if out.returncode != 0:
            raise AssertionError(f"exit {out.returncode}\n{out.stderr}\n{cls.node_log}")
        cls.result = json.loads(out.stdout.strip().splitlines()[-1])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_topics_arrive_at_their_rates(self):
        rates = self.result["rates"]
        expected = {"/scan/radar": 4, "/scan/laser": 40, "/odom": 20, "/clock": 20,
                    "/scan/navtech_cts350x": 4, "/radar/navtech_cts350x/image": 4}
        for topic, hz in expected.items():
            # Loose bounds: the peer counts over a 4 s window on a shared machine.
            self.assertGreater(rates[topic], 0.5 * hz, f"{topic}: {rates}")
            self.assertLess(rates[topic], 1.5 * hz, f"{topic}: {rates}")

    def test_frames_and_static_transforms(self):
        f = self.result["frames"]
        self.assertEqual((f["/scan/radar"], f["/scan/laser"]), ("radar", "laser"))
        self.assertEqual((f["/odom"], f["/odom child"]), ("odom", "base_link"))
        self.assertEqual(sorted(map(tuple, self.result["tf_static"])),
                         [("base_link", "laser"), ("base_link", "navtech_cts350x"),
                          ("base_link", "radar")])
        self.assertEqual(f["/radar/navtech_cts350x/image"], "navtech_cts350x")
        # 400 azimuths, each row 11 header bytes and 3768 bins, mono8.
        self.assertEqual(f["/radar/navtech_cts350x/image size"], [400, 3779, 400 * 3779, "mono8"])
        self.assertTrue(self.result["clock_increasing"])
        self.assertGreaterEqual(self.result["clock_first"], 1_700_000_000)

    def test_cmd_vel_drives_the_robot(self):
        moved = self.result["odom_x_after"] - self.result["odom_x_before"]
        # 0.3 m/s for 3 s facing +x: 0.9 m, less what the first and last messages cost.
        self.assertGreater(moved, 0.4, self.result)
        self.assertIn("/cmd_vel messages", self.node_log)


if __name__ == "__main__":
    unittest.main()
