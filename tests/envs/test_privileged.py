"""MDRDrive-v0's privileged observation: the full observation and the episode's friction ratio mu1 / mu (for
teachers)."""

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401

RANGES = {"k": (0.0, 0.6), "load_ratio": (0.0, 0.4), "friction_coefficient": (0.2, 0.4),
          "base_friction_coefficient": (0.07, 0.13)}




def test_the_privileged_observation_is_the_full_one_and_the_episodes_friction_ratio():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make("MDRDrive-v0", observation="privileged", **RANGES)
    full = gym.make("MDRDrive-v0", **RANGES)
    check_env(env.unwrapped)
    sb3_check_env(env.unwrapped)
    obs, info = env.reset(seed=7)
    assert env.observation_space.shape == (15,) and env.unwrapped.observation_structure["friction_ratio"] == slice(14, 15)
    assert obs[14] == pytest.approx(info["base_friction_coefficient"] / info["friction_coefficient"], rel=1e-6)
    assert 0.07 / 0.4 <= obs[14] <= 0.13 / 0.2
    assert np.array_equal(obs[:14], full.reset(seed=7)[0])
    action = np.full(5, 0.4, dtype=np.float32)
    obs, *_ = env.step(action)
    assert np.array_equal(obs[:14], full.step(action)[0])
    assert np.array_equal(env.unwrapped.privileged_observation(friction=True), obs)
    assert env.unwrapped.privileged_observation().shape == (14,)  # the full layout, as before
    sensor = gym.make("MDRDriveSensor-v0")
    _, info = sensor.reset(seed=2)
    assert sensor.unwrapped.privileged_observation(friction=True)[14] == pytest.approx(
        info["base_friction_coefficient"] / info["friction_coefficient"], rel=1e-6)
    with pytest.raises(ValueError, match="observation"):
        gym.make("MDRDrive-v0", observation="oracle")


def test_the_batched_vector_env_gives_each_drive_its_own_friction_entries():
    venv = gym.make_vec("MDRDrive-v0", num_envs=3, vectorization_mode="vector_entry_point", observation="privileged",
                        **RANGES)
    single = gym.make("MDRDrive-v0", observation="privileged", **RANGES)
    obs, _ = venv.reset(seed=11)
    stepped, *_ = venv.step(np.full((3, 5), 0.3, dtype=np.float32))
    for i in range(3):
        assert np.array_equal(obs[i], single.reset(seed=11 + i)[0])
        assert np.array_equal(stepped[i], single.step(np.full(5, 0.3, dtype=np.float32))[0])
    assert len(set(obs[:, 14].tolist())) == 3
