"""evo (the trajectory evaluation tool, from PyPI) reads radarnav's TUM trajectories and finds
the ATE and RPE that radarnav wrote in `summary.json`.

`bug-spiral` drives about 340 m on the true pose while its odometry (2 % speed noise, 0.5 °/s
turn-rate noise) drifts and its radar localiser registers the scans. evo reads `truth.tum`,
`odometry.tum` and `slam.tum` with its own TUM reader and
computes the absolute pose error (translation part, no alignment) and the relative pose error
over 10 m of path (consecutive pairs, translation part and rotation angle); each must be
within a ten-thousandth of radarnav's (the issue asks for 1 %).
"""

import json
import os

os.environ.setdefault("MPLBACKEND", "Agg")  # evo imports matplotlib; no display here
import subprocess
import tempfile
import unittest
from pathlib import Path

from evo.core import metrics, sync  # noqa: E402
from evo.tools import file_interface  # noqa: E402

RADARNAV = os.environ.get("RADARNAV", "radarnav")


_RUN = {}


def run_once():
    """The one bug-spiral run both estimates are checked on."""
    if not _RUN:
        tmp = tempfile.TemporaryDirectory()
        out = Path(tmp.name) / "run"
        subprocess.run(
            [RADARNAV, "run", "bug-spiral", "--out", str(out), "--no-mcap", "--no-maps"],
            check=True, capture_output=True,
        )
        _RUN.update(tmp=tmp, out=out, summary=json.loads((out / "summary.json").read_text()))
    return _RUN


def tearDownModule():
    if _RUN:
        _RUN["tmp"].cleanup()


class EvoReadsTheOdometry(unittest.TestCase):
    estimate = "odometry"

    @classmethod
    def setUpClass(cls):
        run = run_once()
        out = run["out"]
        cls.summary = run["summary"]
        ref = file_interface.read_tum_trajectory_file(str(out / "truth.tum"))
        est = file_interface.read_tum_trajectory_file(str(out / f"{cls.estimate}.tum"))
        cls.ref, cls.est = sync.associate_trajectories(ref, est)
        cls.steps = cls.summary["steps"]

    def ours(self):
        return self.summary["accuracy"][self.estimate]

    def assert_close(self, theirs, ours, what):
        self.assertGreater(ours, 0.0, what)
        # The issue asks for 1 %. The files keep micrometres: here the two agree to a few parts
        # in a billion, on short runs to a few parts in a million; a ten-thousandth is asked.
        self.assertLessEqual(abs(theirs - ours), 1e-4 * ours, f"{what}: evo {theirs}, radarnav {ours}")

    def test_every_step_is_a_pose(self):
        # One pose per step and the state at the end.
        self.assertEqual(self.ref.num_poses, self.steps + 1)
        self.assertEqual(self.est.num_poses, self.ref.num_poses)
        self.assertEqual(self.ours()["poses"], self.ref.num_poses)

    def test_ate(self):
        ape = metrics.APE(metrics.PoseRelation.translation_part)
        ape.process_data((self.ref, self.est))
        self.assert_close(ape.get_statistic(metrics.StatisticsType.rmse), self.ours()["ate_rmse_m"], "ATE")

    def rpe(self, relation):
        rpe = metrics.RPE(relation, delta=10.0, delta_unit=metrics.Unit.meters, all_pairs=False)
        rpe.process_data((self.ref, self.est))
        return rpe

    def test_rpe_translation(self):
        rpe = self.rpe(metrics.PoseRelation.translation_part)
        ours = self.ours()["rpe"]
        self.assertEqual(len(rpe.error), ours["segments"])
        self.assertGreaterEqual(ours["segments"], 20)
        self.assert_close(rpe.get_statistic(metrics.StatisticsType.rmse), ours["translation_rmse_m"], "RPE translation")

    def test_rpe_rotation(self):
        rpe = self.rpe(metrics.PoseRelation.rotation_angle_deg)
        self.assert_close(rpe.get_statistic(metrics.StatisticsType.rmse), self.ours()["rpe"]["rotation_rmse_deg"], "RPE rotation")


class EvoReadsTheSlamPath(EvoReadsTheOdometry):
    estimate = "slam"


if __name__ == "__main__":
    unittest.main()
