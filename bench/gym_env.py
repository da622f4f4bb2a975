#!/usr/bin/env python3
"""Steps per second of the Gymnasium environment radarnav/Navigate-v0 (360-azimuth radar).

    crates/radarnav-py/tests/run          # once: builds the venv target/py-pkg with the wheel
    target/py-pkg/bin/python bench/gym_env.py [--steps 3000] [--repeats 5]

Random actions from a seeded action space; episodes that end are reset. Prints the median
wall and CPU rates of the repeats, through gym.make's wrappers and on the bare env.
"""

import argparse
import statistics
import time

import gymnasium as gym

import radarnav  # noqa: F401  (registers the environment)


def rate(env, steps, seed):
    env.action_space.seed(seed)
    env.reset(seed=seed)
    w0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    return steps / (time.perf_counter() - w0), steps / (time.process_time() - c0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scenario", default="nav/box-goal")
    a = ap.parse_args()
    for label, env in [
        ("gym.make", gym.make("radarnav/Navigate-v0", scenario=a.scenario, random_start=True, random_goal=True)),
        ("bare env", gym.make("radarnav/Navigate-v0", scenario=a.scenario, random_start=True, random_goal=True).unwrapped),
    ]:
        runs = [rate(env, a.steps, seed) for seed in range(a.repeats)]
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        rays = env.observation_space.shape[0] - 4
        print(f"{label:<9} {a.scenario}: {wall:8.0f} steps/s wall, {cpu:8.0f} steps/CPU-s "
              f"({rays} radar azimuths, one scan a step; median of {a.repeats} x {a.steps})")


if __name__ == "__main__":
    main()
