"""The Gymnasium environment radarnav/Navigate-v0."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import radarnav  # noqa: F401  (registers the environment)


def test_passes_the_gymnasium_checker():
    env = gym.make("radarnav/Navigate-v0")
    check_env(env.unwrapped)


def test_spaces_hold_360_ranges_and_the_goal():
    env = gym.make("radarnav/Navigate-v0")
    assert env.observation_space.shape == (364,)
    assert env.action_space.shape == (2,)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    assert info["goal"] == (12.3, 6.0)


def test_same_seed_same_episode():
    def episode(seed):
        env = gym.make("radarnav/Navigate-v0", random_start=True, random_goal=True)
        obs, _ = env.reset(seed=seed)
        env.action_space.seed(seed)
        out = [obs]
        for _ in range(50):
            obs, r, term, trunc, _ = env.step(env.action_space.sample())
            out.append(np.append(obs, r))
            if term or trunc:
                break
        return out

    a, b, c = episode(7), episode(7), episode(8)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c))


def test_a_random_rollout_of_1000_steps_stays_in_its_spaces():
    env = gym.make("radarnav/Navigate-v0", random_start=True, random_goal=True, max_steps=200)
    env.action_space.seed(3)
    obs, _ = env.reset(seed=3)
    episodes = 1
    for _ in range(1000):
        obs, reward, term, trunc, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        assert np.isfinite(reward)
        if term or trunc:
            obs, _ = env.reset()
            episodes += 1
    assert episodes >= 5  # max_steps truncates


def test_driving_at_the_goal_reaches_it():
    env = gym.make("radarnav/Navigate-v0", max_steps=400).unwrapped
    obs, _ = env.reset(seed=2)
    total, terminated = 0.0, False
    for _ in range(400):
        bearing = np.arctan2(obs[-2], obs[-3])
        obs, r, terminated, truncated, _ = env.step(np.array([1.0, np.clip(2 * bearing, -1, 1)]))
        total += r
        if terminated or truncated:
            break
    assert terminated and total > 10.0


def test_bad_options_are_clear_errors():
    with pytest.raises(ValueError, match="pose must be"):
        gym.make("radarnav/Navigate-v0", pose="gps")
    with pytest.raises(ValueError, match="goal_tolerance must be"):
        gym.make("radarnav/Navigate-v0", goal_tolerance=0.0)
    with pytest.raises(ValueError, match="has no goal"):
        gym.make("radarnav/Navigate-v0", scenario="foliage-wall")
