"""pyboreas (the Boreas dataset's own loader, from PyPI) reads radarnav's radar images.

A robot stands at the origin facing +x with a Navtech CTS350-X preset; a metal pole stands
10 m ahead and 6 m to its left. radarnav writes the run's images in the Oxford Radar RobotCar
layout; pyboreas' `load_radar` must read their stamps, azimuths, valid flags and power, and
its `radar_polar_to_cartesian` must put the pole ahead and to the left in its Cartesian image.
"""

import math
import os
import subprocess
import tempfile
import unittest
from pathlib import Path

import numpy as np
from pyboreas.utils.radar import load_radar, radar_polar_to_cartesian

RADARNAV = os.environ.get("RADARNAV", "radarnav")

SCENARIO = """
description = "a pole ahead and to the left of a standing radar"
[sim]
dt = 0.05
duration = 1.0
seed = 3

[[object]]
name = "pole"
material = "metal"
cylinder = { center = [10.0, 6.0], radius = 0.3, height = 2.0 }

[[robot]]
name = "r"
vehicle = "p3at"
start = { x = 0.0, y = 0.0, yaw_deg = 0.0 }

[[robot.sensor]]
name = "nav"
preset = "navtech_cts350x"
mount = { x = 0.0, y = 0.0, z = 0.6 }
"""

BIN = 0.0438  # the preset's bin size, m (the dataset's 4.38 cm)
ROWS, BINS = 400, 3768


class OxfordLayout(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        root = Path(cls.tmp.name)
        (root / "pole.toml").write_text(SCENARIO)
        subprocess.run(
            [RADARNAV, "run", str(root / "pole.toml"), "--out", str(root / "out"),
             "--no-mcap", "--no-maps"],
            check=True, capture_output=True,
        )
        cls.dir = root / "out" / "radar" / "nav"
        cls.stamps = [int(line.split()[0]) for line in
                      (cls.dir / "radar.timestamps").read_text().splitlines()]

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_index_names_every_image(self):
        # 1 s at 4 Hz: rotations starting at 0, 0.25, 0.5 s end inside the run.
        self.assertGreaterEqual(len(self.stamps), 3)
        for t in self.stamps:
            self.assertTrue((self.dir / f"{t}.png").is_file())
        self.assertEqual(self.stamps[1] - self.stamps[0], 250_000)

    def test_load_radar_reads_stamps_azimuths_valid_and_power(self):
        path = str(self.dir / f"{self.stamps[0]}.png")
        timestamps, azimuths, valid, fft, resolution = load_radar(path)
        self.assertEqual(timestamps.shape, (ROWS, 1))
        # Row k is measured k / (400 * 4 Hz) s after the first.
        expected = self.stamps[0] + np.round(np.arange(ROWS) * 1e6 / (ROWS * 4.0))
        np.testing.assert_array_equal(timestamps[:, 0], expected.astype(np.int64))
        np.testing.assert_allclose(azimuths[:, 0], np.arange(ROWS) * 2 * np.pi / ROWS, atol=1e-6)
        self.assertTrue(valid.all())
        self.assertEqual(fft.shape, (ROWS, BINS))
        # The loader hard-codes 4.381 cm for images stamped after Boreas' radar upgrade.
        self.assertAlmostEqual(resolution, 0.04381)
        # The pole: the strongest return lies at its range (11.66 m to its centre, less the
        # radius) in the rows of its azimuth (30.96 deg, clockwise from ahead in the radar's
        # frame: 360 - 30.96).
        row, col = np.unravel_index(np.argmax(fft), fft.shape)
        az = math.degrees(azimuths[row, 0])
        self.assertLess(abs(az - (360 - math.degrees(math.atan2(6, 10)))), 1.5)
        self.assertLess(abs((col + 0.5) * BIN - (math.hypot(10, 6) - 0.3)), 0.3)

    def test_polar_to_cartesian_puts_the_pole_ahead_and_left(self):
        path = str(self.dir / f"{self.stamps[0]}.png")
        _, azimuths, _, fft, _ = load_radar(path)
        res, width = 0.1, 301  # 30 m across, the radar in the middle pixel
        cart = radar_polar_to_cartesian(azimuths, fft, BIN, res, width)
        row, col = np.unravel_index(np.argmax(cart), cart.shape)
        centre = width // 2
        ahead, left = (centre - row) * res, (centre - col) * res
        self.assertGreater(ahead, 0)
        self.assertGreater(left, 0)
        # The pole's near face, within a few pixels.
        dist = math.hypot(ahead - 10.0, left - 6.0)
        self.assertLess(dist, 0.6, f"peak at {ahead:.2f} ahead, {left:.2f} left")


if __name__ == "__main__":
    unittest.main()
