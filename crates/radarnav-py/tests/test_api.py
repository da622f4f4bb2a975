"""The Python API: loading, stepping, scans, maps, runs; checked against the CLI."""

import filecmp
import os
import subprocess

import numpy as np
import pytest

import radarnav


def test_builtins_load_and_unknown_names_are_key_errors():
    assert "foliage-wall" in radarnav.builtins()
    s = radarnav.Scenario.load("foliage-wall")
    assert s.name == "foliage-wall" and "radar" in s.sensors()
    with pytest.raises(KeyError, match="neither a file nor a built-in"):
        radarnav.Scenario.load("no-such-map")


def test_a_bad_scenario_text_names_line_and_key():
    text = "[sim]\ndt = 5.0\n"
    with pytest.raises(ValueError, match=r"<bad>:2:.*`dt`"):
        radarnav.Scenario.from_toml(text, name="bad")


def test_ranges_are_float32_arrays_and_the_radar_sees_past_the_hedge():
    sim = radarnav.Sim("foliage-wall", seed=1)
    sim.advance(0.0, 0.0, 0.3)
    radar, laser = sim.scan("radar"), sim.scan("laser")
    assert radar["ranges"].dtype == np.float32 and radar["ranges"].shape == (360,)
    assert radar["hits"].dtype == np.uint8 and radar["azimuths"].shape == (360,)
    # Facing the foliage wall: the laser stops at it, the radar's mean range is longer.
    ahead = np.abs(radar["azimuths"]) < np.radians(10)
    lahead = np.abs(laser["azimuths"]) < np.radians(10)
    assert np.nanmean(radar["ranges"][ahead]) > np.nanmean(laser["ranges"][lahead]) + 0.5


def test_driving_moves_the_robot_and_a_wall_stops_it():
    sim = radarnav.Sim("nav/box-goal", seed=1, sensors=["radar"])
    x0 = sim.pose()[0]
    assert sim.advance(0.5, 0.0, 2.0) is False
    assert sim.pose()[0] == pytest.approx(x0 + 1.0, abs=0.02)
    # Drive into the box 10 m ahead until the bumper of the simulation refuses the move.
    bumped = any(sim.advance(0.7, 0.0, 1.0) for _ in range(30))
    assert bumped and sim.bumps > 0


def test_reset_with_a_seed_repeats_the_run_exactly():
    sim = radarnav.Sim("foliage-wall", seed=4)

    def drive():
        for _ in range(40):
            sim.step(0.4, 0.1)
        return sim.odometry(), sim.ranges("radar").copy()

    a = drive()
    sim.reset(seed=4)
    b = drive()
    sim.reset(seed=5)
    c = drive()
    assert a[0] == b[0] and np.array_equal(a[1], b[1])
    assert a[0] != c[0]


def test_reset_to_a_blocked_start_is_an_error():
    sim = radarnav.Sim("nav/box-goal")
    assert not sim.is_free(14.0, 6.0, 0.0)
    with pytest.raises(ValueError, match="box"):
        sim.reset(start=(14.0, 6.0, 0.0))
    with pytest.raises(ValueError, match="start x: expected -5000 to 5000 m"):
        sim.reset(start=(1e308, 6.0, 0.0))


def test_maps_are_class_grids(tmp_path):
    sim = radarnav.Sim("foliage-wall", seed=1, maps=["radar", "laser"])
    sim.advance(0.3, 0.0, 5.0)
    m = sim.map("radar")
    classes = m["classes"]
    assert classes.dtype == np.uint8 and classes.ndim == 2
    assert m["sensed"].shape == classes.shape
    counts = np.bincount(classes.ravel(), minlength=4)
    assert counts[1] > 0 and counts[3] > 0
    paths = sim.save_map("radar", str(tmp_path))
    assert all(os.path.getsize(p) > 0 for p in paths)
    with pytest.raises(KeyError, match="no map"):
        sim.map("ground_truth")


def test_slam_estimate_tracks_the_truth():
    sim = radarnav.Sim("foliage-wall", seed=2, slam="radar")
    for _ in range(10):
        sim.advance(0.4, 0.05, 1.0)
    x, y, _ = sim.pose()
    sx, sy, _ = sim.slam()
    assert np.hypot(x - sx, y - sy) < 0.2


def test_run_writes_the_cli_bytes(tmp_path, cli):
    py = tmp_path / "py"
    summary = radarnav.run("nav/box-goal", str(py), seed=3, mcap=False, maps=None)
    assert summary["outcome"] == "reached"
    rs = tmp_path / "rs"
    subprocess.run(
        [cli, "run", "nav/box-goal", "--seed", "3", "--no-mcap", "--no-maps", "--out", str(rs)],
        check=True,
        capture_output=True,
    )
    for name in ["trajectory.csv", "truth.tum", "odometry.tum", "scans/radar.rnscan"]:
        assert filecmp.cmp(py / name, rs / name, shallow=False), name


def test_an_imaging_radar_gives_oxford_power_images():
    sim = radarnav.Sim("foliage-wall", seed=1, add_sensors=["navtech_cts350x"])
    assert sim.image("navtech_cts350x") is None
    sim.advance(0.2, 0.0, 0.6)  # one rotation takes 0.25 s at 4 Hz
    im = sim.image("navtech_cts350x")
    assert im["power"].dtype == np.uint8 and im["power"].shape == (400, 3768)
    assert im["bin_size"] == pytest.approx(0.0438, abs=1e-4)
    assert im["detections"].shape[1] == 6 and len(im["detections"]) > 0
    # The wall 5 m ahead is brighter than the noise floor around it.
    assert im["power"].max() > 3 * np.median(im["power"])
