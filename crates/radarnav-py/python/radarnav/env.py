"""The Gymnasium environment ``radarnav/Navigate-v0``: reach a goal on radar.

Observation (``Box``, float32): the radar's ranges divided by its maximum range (1 where
nothing returned), then the goal's distance divided by ``goal_scale`` (default: the world's diagonal) and
clipped to 1, the cosine and sine of
its bearing in the robot frame, and whether the last step bumped. Action (``Box`` in
[-1, 1]^2): forward speed and turn rate as fractions of the vehicle's limits.

Reward: metres of progress toward the goal, minus ``bump_penalty`` for each refused move and
``step_cost`` per step, plus ``goal_reward`` on arrival. An episode terminates at the goal
and is truncated after ``max_steps``.

Options (constructor keywords; ``reset(options=...)`` may change ``start`` and ``goal``):
``scenario`` (a built-in, a file or a ``radarnav.Scenario``), ``sensor`` (the radar read),
``control_hz`` (steps per simulated second; the sensor scans at this rate), ``random_start``
and ``random_goal`` (drawn free of obstacles inside the world with the env's seeded RNG),
``start`` and ``goal`` (fixed; default the scenario robot's start and its mission's goal),
``pose`` (``"truth"``, ``"odometry"`` or ``"slam"``: where the robot believes it is).
"""

from __future__ import annotations

import math
from typing import Any, Optional

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ._core import Scenario, Sim


class NavigateEnv(gym.Env):
    """Goal reaching with radar observations (see the module doc)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: Any = "nav/box-goal",
        sensor: str = "radar",
        robot: Optional[str] = None,
        control_hz: float = 10.0,
        max_steps: int = 600,
        random_start: bool = False,
        random_goal: bool = False,
        start: Optional[tuple] = None,
        goal: Optional[tuple] = None,
        goal_tolerance: float = 0.5,
        goal_scale: Optional[float] = None,
        goal_reward: float = 10.0,
        bump_penalty: float = 0.2,
        step_cost: float = 0.01,
        pose: str = "truth",
        render_mode: Optional[str] = None,
    ):
        if not isinstance(scenario, Scenario):
            scenario = Scenario.load(str(scenario))
        if pose not in ("truth", "odometry", "slam"):
            raise ValueError(f"pose must be truth, odometry or slam, not {pose!r}")
        if not 0.01 <= control_hz <= 1000.0:
            raise ValueError(f"control_hz must be in 0.01..1000, not {control_hz}")
        if not 1 <= max_steps <= 10_000_000:
            raise ValueError(f"max_steps must be in 1..10000000, not {max_steps}")
        if not 0.01 <= goal_tolerance <= 100.0:
            raise ValueError(f"goal_tolerance must be in 0.01..100 m, not {goal_tolerance}")
        if goal_scale is not None and not 0.01 <= goal_scale <= 1e4:
            raise ValueError(f"goal_scale must be in 0.01..10000 m, not {goal_scale}")
        for name, v in [("goal_reward", goal_reward), ("bump_penalty", bump_penalty),
                        ("step_cost", step_cost)]:
            if not math.isfinite(v):
                raise ValueError(f"{name} must be a finite number, not {v}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'rgb_array', not {render_mode!r}")
        self.scenario = scenario
        self.sensor = sensor
        self.control_hz = float(control_hz)
        self.max_steps = int(max_steps)
        self.random_start = random_start
        self.random_goal = random_goal
        self.goal_tolerance = goal_tolerance
        x0, y0, x1, y1 = scenario.bounds()
        self.goal_scale = float(goal_scale) if goal_scale else math.hypot(x1 - x0, y1 - y0)
        self.goal_reward = goal_reward
        self.bump_penalty = bump_penalty
        self.step_cost = step_cost
        self.pose_source = pose
        self.render_mode = render_mode
        duration = self.max_steps / self.control_hz + 1.0
        self.sim = Sim(
            scenario,
            robot=robot,
            sensors=[sensor],
            rate_hz=self.control_hz,
            duration=duration,
            slam=sensor if pose == "slam" else None,
        )
        self._fixed_start = start
        self._fixed_goal = goal if goal is not None else scenario.goal()
        if self._fixed_goal is None and not random_goal:
            raise ValueError(
                f"scenario {scenario.name!r} has no goal: pass goal=(x, y) or random_goal=True"
            )
        self.sim.advance(0.0, 0.0, 1e-9)  # the first scan, for the ray count
        first = self.sim.ranges(sensor)
        self._rays = 0 if first is None else len(first)
        self._range_max = float(self.sim.scan(sensor)["range_max"])
        self._v_max, self._w_max = self.sim.limits
        n = self._rays + 4
        low = np.zeros(n, dtype=np.float32)
        high = np.ones(n, dtype=np.float32)
        low[self._rays + 1 : self._rays + 3] = -1.0
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.goal = self._fixed_goal
        self._steps = 0
        self._distance = 0.0

    # -- helpers -------------------------------------------------------------------------
    def _believed_pose(self):
        if self.pose_source == "odometry":
            return self.sim.odometry()
        if self.pose_source == "slam":
            return self.sim.slam() or self.sim.odometry()
        return self.sim.pose()

    def _free_point(self, margin: float = 0.6):
        x0, y0, x1, y1 = self.scenario.bounds()
        for _ in range(10_000):
            x = float(self.np_random.uniform(x0 + margin, x1 - margin))
            y = float(self.np_random.uniform(y0 + margin, y1 - margin))
            yaw = float(self.np_random.uniform(-math.pi, math.pi))
            if self.sim.is_free(x, y, yaw):
                return x, y, yaw
        raise RuntimeError("no free place found in 10 000 draws")

    def _observe(self):
        ranges = self.sim.ranges(self.sensor)
        obs = np.ones(self._rays + 4, dtype=np.float32)
        if ranges is not None:
            r = np.minimum(ranges, self._range_max) / self._range_max
            obs[: self._rays] = np.where(np.isfinite(r), r, 1.0)
        x, y, yaw = self._believed_pose()
        dx, dy = self.goal[0] - x, self.goal[1] - y
        bearing = math.atan2(dy, dx) - yaw
        obs[self._rays] = min(1.0, math.hypot(dx, dy) / self.goal_scale)
        obs[self._rays + 1] = math.cos(bearing)
        obs[self._rays + 2] = math.sin(bearing)
        obs[self._rays + 3] = 1.0 if self.sim.bumped else 0.0
        return obs

    def _true_distance(self):
        x, y, _ = self.sim.pose()
        return math.hypot(self.goal[0] - x, self.goal[1] - y)

    def _info(self):
        x, y, yaw = self.sim.pose()
        return {
            "pose": (x, y, yaw),
            "goal": tuple(self.goal),
            "distance": self._distance,
            "bumps": self.sim.bumps,
            "time": self.sim.time,
        }

    # -- gymnasium API -------------------------------------------------------------------
    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        options = options or {}
        sim_seed = int(self.np_random.integers(0, 2**63 - 1))
        start = options.get("start", self._fixed_start)
        if start is None and self.random_start:
            start = self._free_point()
        self.sim.reset(seed=sim_seed, start=None if start is None else tuple(map(float, start)))
        goal = options.get("goal", None)
        if goal is None:
            goal = self._free_point()[:2] if self.random_goal else self._fixed_goal
        self.goal = (float(goal[0]), float(goal[1]))
        self._steps = 0
        # One step standing still takes the first scan.
        self.sim.advance(0.0, 0.0, 1.0 / self.control_hz)
        self._distance = self._true_distance()
        return self._observe(), self._info()

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        bumped = self.sim.advance(a[0] * self._v_max, a[1] * self._w_max, 1.0 / self.control_hz)
        self._steps += 1
        d = self._true_distance()
        reward = (self._distance - d) - self.step_cost - (self.bump_penalty if bumped else 0.0)
        self._distance = d
        terminated = d <= self.goal_tolerance
        if terminated:
            reward += self.goal_reward
        truncated = not terminated and (self._steps >= self.max_steps or self.sim.done)
        return self._observe(), float(reward), bool(terminated), bool(truncated), self._info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self.sim.render_rgb(400)
