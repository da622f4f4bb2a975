"""Sweeps: shards in this process and on Ray merge into the CLI's table byte for byte."""

import os
import subprocess

import pytest

import radarnav
from radarnav.sweep import run_local, run_on_ray

SPEC = """
scenarios = ["nav/box-goal", "nav/pillar"]
seeds = [1, 2]
duration = 90.0
[grid]
"mission.type" = ["bug1", "bug2"]
"""


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    path = d / "spec.toml"
    path.write_text(SPEC)
    return path


@pytest.fixture(scope="module")
def cli_table(spec, cli):
    out = spec.parent / "cli"
    subprocess.run([cli, "sweep", str(spec), "--out", str(out)], check=True, capture_output=True)
    return (out / "sweep.csv").read_bytes()


def test_the_spec_counts_its_runs(spec):
    assert radarnav.sweep_runs(radarnav.sweep_load(str(spec))) == 8


def test_three_local_shards_merge_to_the_cli_table(spec, cli_table, tmp_path):
    paths = run_local(str(spec), str(tmp_path), shards=3)
    assert (tmp_path / "sweep.csv").read_bytes() == cli_table
    assert any(p.endswith("sweep.png") for p in paths)


def test_a_two_shard_ray_sweep_merges_to_the_cli_table(spec, cli_table, tmp_path):
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    run_on_ray(
        str(spec),
        shards=2,
        out=str(tmp_path),
        init_kwargs={"num_cpus": 2, "_node_ip_address": "127.0.0.1"},
    )
    assert sorted(os.listdir(tmp_path))[:2] == ["shard-0-of-2.json", "shard-1-of-2.json"]
    assert (tmp_path / "sweep.csv").read_bytes() == cli_table


def test_a_bad_spec_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('scenarios = ["nav/box-goal"]\nseeds = []\n')
    with pytest.raises(ValueError, match="bad.toml: `seeds` is empty"):
        radarnav.sweep_load(str(bad))
