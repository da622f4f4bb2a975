"""Sweeps on Ray: each shard of a sweep spec runs as one Ray task (on ``cpus_per_shard``
threads), the shard files are written on the driver and merged into ``sweep.csv``,
``sweep_groups.csv`` and ``sweep.png``, byte for byte what ``radarnav sweep SPEC`` writes.

    from radarnav.sweep import run_on_ray
    run_on_ray("sweeps/bug-maps.toml", out="out/sweep")                 # a local ray.init()
    run_on_ray("sweeps/bug-maps.toml", address="ray://head:10001", shards=16, out="out/sweep")

The spec travels to the workers with its scenario files inside; meshes and teleop files a
scenario names must be readable at the same path on every node (a shared file system).
"""

from __future__ import annotations

import os
from typing import Optional

from ._core import sweep_load, sweep_merge, sweep_runs, sweep_shard


def _write_whole(path: str, text: str) -> None:
    tmp = path + ".partial"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def _shard(sweep_json: str, index: int, count: int) -> str:
    """One shard's table as JSON text (a Python function, as Ray's tasks must be)."""
    return sweep_shard(sweep_json, index, count)


def run_local(spec: str, out: str, shards: int = 1) -> list:
    """Runs every shard in this process, one after another, and merges them."""
    sweep = sweep_load(spec)
    os.makedirs(out, exist_ok=True)
    for i in range(shards):
        _write_whole(os.path.join(out, f"shard-{i}-of-{shards}.json"), sweep_shard(sweep, i, shards))
    return sweep_merge([out], out)


def run_on_ray(
    spec: str,
    address: Optional[str] = None,
    shards: Optional[int] = None,
    out: str = "out/sweep",
    cpus_per_shard: int = 1,
    init_kwargs: Optional[dict] = None,
) -> list:
    """Runs the sweep at ``spec`` as ``shards`` Ray tasks and merges them into ``out``.

    ``address``: a Ray cluster (``"auto"``, ``"ray://host:10001"``); ``None`` starts a local
    Ray on this machine (dashboard off). Each task reserves ``cpus_per_shard`` CPUs and runs
    its shard's runs on that many threads. ``shards`` defaults to the cluster's CPUs divided
    by ``cpus_per_shard``, at least 1, at most the number of runs. Returns the merged files'
    paths.
    """
    import ray

    sweep = sweep_load(spec)
    started_here = False
    if not ray.is_initialized():
        kwargs = {"include_dashboard": False, "log_to_driver": False}
        kwargs.update(init_kwargs or {})
        ray.init(address=address, **kwargs)
        started_here = True
    try:
        runs = sweep_runs(sweep)
        cpus_per_shard = max(1, int(cpus_per_shard))
        if shards is None:
            cpus = int(ray.cluster_resources().get("CPU", 1))
            shards = max(1, cpus // cpus_per_shard)
        shards = max(1, min(int(shards), runs))
        # A shard runs its runs on rayon's pool: size it to the CPUs the task holds.
        task = ray.remote(
            num_cpus=cpus_per_shard,
            runtime_env={"env_vars": {"RAYON_NUM_THREADS": str(cpus_per_shard)}},
        )(_shard)
        pending = [task.remote(sweep, i, shards) for i in range(shards)]
        os.makedirs(out, exist_ok=True)
        for i, text in enumerate(ray.get(pending)):
            _write_whole(os.path.join(out, f"shard-{i}-of-{shards}.json"), text)
        return sweep_merge([out], out)
    finally:
        if started_here:
            ray.shutdown()
