"""The recipe (agents/recipe.py) end to end at CI size: the shipped policy's shape is a plain SB3 model."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents import recipe
from mdr_drive_agents.distill import DistillConfig
from mdr_drive_agents.drive_field import FieldConfig, align_phase, cycle_action

TINY = Path(__file__).parent / "data" / "recipe_tiny.yaml"


@pytest.fixture(scope="module")
def recipe_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("recipe")
    summary = recipe.run(TINY, out, progress=False, force=True)
    return out, summary


def test_recipe_writes_a_plain_sb3_policy_that_loads_and_acts(recipe_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, summary = recipe_run
    assert set(summary["stage_wall_time_s"]) == {"teacher_s", "student_s", "total_s"}
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: gym.make("MDRDrive-v0", k=0.1, cargo_mass=0.05)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    obs = venv.reset()
    for _ in range(3):
        action, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(action)
    assert action.shape == (1, 5) and np.all(np.abs(action) <= 1.0)
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["algo"] == "ppo" and "residual_scale" not in run["hyperparameters"]
    assert len(run["distilled_from"]["history"]) == 2  # the teacher's round and one DAgger round
    assert not (out / ".tasks").exists()


def test_the_distilled_policy_fine_tunes_with_train_resume(recipe_run):
    from mdr_drive_agents.train import train

    out, _ = recipe_run
    record = train(resume=out / "policy", steps=64, progress_bar=False, eval_freq=10_000)
    assert record["resumes"] == 1 and record["total_timesteps"] >= 64


def test_an_existing_output_is_refused_without_resume_or_force(recipe_run, capsys):
    out, _ = recipe_run
    assert recipe.main([str(TINY), "--out", str(out), "--no-progress", "--workers", "1"]) == 2
    assert "--resume" in capsys.readouterr().err


def test_configs_reject_bad_values_naming_them():
    with pytest.raises(ValueError, match="k_values"):
        FieldConfig(k_values=1)
    with pytest.raises(ValueError, match="learning_rate"):
        DistillConfig(learning_rate=0.0)
    with pytest.raises(ValueError, match="activation"):
        DistillConfig(activation="gelu")


def test_cycle_labels_follow_the_previous_action():
    drives = np.array([[[1.0, 0, 0, 0, 0], [-1.0, 0, 0, 0, 0]]] * 3)
    prev = np.array([[0.0] * 5, [0.9, 0, 0, 0, 0], [-0.9, 0, 0, 0, 0]])
    labels = cycle_action(drives, prev)
    assert labels[:, 0].tolist() == [1.0, -1.0, 1.0]  # start: first; after the first: second; after it: first
    assert np.array_equal(align_phase(drives[0][::-1], drives[0]), drives[0])
