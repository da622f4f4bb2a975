"""radarnav: a robot simulation workbench for navigation with a radar that sees through
foliage and smoke, beside a laser that cannot.

Four verbs::

    import radarnav
    sim = radarnav.Sim("foliage-wall", seed=1, maps=["radar"])
    while sim.step(0.3, 0.0):            # v m/s, omega rad/s, one dt step
        ranges = sim.ranges("radar")     # numpy float32, inf where nothing returned
    sim.save_map("radar", "out")

``radarnav.env`` holds the Gymnasium environment ``radarnav/Navigate-v0`` (registered on
import when gymnasium is installed); ``radarnav.sweep`` runs sweeps on Ray.
"""

import json as _json

from ._core import Scenario, Sim, __version__, builtins
from ._core import run as _run
from ._core import sweep_load, sweep_merge, sweep_runs, sweep_shard

__all__ = [
    "Scenario",
    "Sim",
    "builtins",
    "run",
    "summary",
    "sweep_load",
    "sweep_merge",
    "sweep_runs",
    "sweep_shard",
    "__version__",
]


def run(scenario, out: str, **options) -> dict:
    """What ``radarnav run`` does, from Python: the scenario's mission recorded into ``out``
    (same files, same bytes as the CLI for the same scenario and seed). Options: ``seed``,
    ``duration``, ``robot``, ``teleop`` (a CSV path), ``mcap``, ``ros2_bag``, ``maps`` (sensor
    names; ``None`` for no maps), ``map_pose``, ``pixels``. Returns ``summary.json`` as a dict.
    """
    return _json.loads(_run(scenario, out, **options))


def summary(sim: Sim) -> dict:
    """What the run of ``sim`` did so far (the run part of ``summary.json``), as a dict."""
    return _json.loads(sim.summary_json())


try:  # The environment needs gymnasium, an optional dependency.
    import gymnasium as _gym

    if "radarnav/Navigate-v0" not in _gym.registry:
        _gym.register(id="radarnav/Navigate-v0", entry_point="radarnav.env:NavigateEnv")
except ImportError:  # pragma: no cover - gymnasium not installed
    pass
