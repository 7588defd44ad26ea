"""What the sensor policy's estimator tells the teacher about the load (agents/told_load.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_env.gym_envs.spaces import ObservationLayout
from mdr_drive_agents.told_load import TEACHER_FRICTION, TOLD_RATIOS, told_entries, told_ratio, told_velocities


def test_told_entries_are_what_the_env_shows_at_the_teachers_friction():
    env = gym.make("MDRDrive-v0", k=0.37, cargo_mass=0.08)
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    assert u.params.contact.friction_coefficient == TEACHER_FRICTION
    ratio = u.params.drive.load / (TEACHER_FRICTION * u.force_ref)
    told = told_entries(np.array([0.37]), np.array([ratio]), np.array([u.force_ref]))
    s = ObservationLayout.structure
    assert told[0] == pytest.approx(obs[s["k"].start:s["load_over_10N"].stop], rel=1e-6)


def test_the_told_ratio_is_the_nearest_to_the_truth_among_the_fastest():
    ratios = np.array([0.0, 0.1, 0.2, 0.3])
    v = np.array([[5.0, 9.9, 10.0, 2.0],     # 9.9 is within 3 % of 10: the truth's neighbour 0.1 wins
                  [5.0, 9.0, 10.0, 2.0],     # only 0.2 is within 3 %
                  [-3e-5, -1e-5, -2e-5, -9.0],  # nothing moves: within the 0.1 mm/s slack of the best
                  [1.0, 1.0, 1.0, 1.0]]) * 1e-3  # flat: the truth itself
    truth = np.array([0.05, 0.05, 0.3, 0.21])
    assert told_ratio(v, truth, ratios).tolist() == [0.1, 0.2, 0.2, 0.2]


def test_told_velocities_play_the_teacher_at_the_draws_friction():
    from mdr_drive_agents.evaluate import Policy

    teacher = Policy("agents/pretrained/ppo_sensor/teacher")
    draws = np.array([[0.2, 0.05, 0.3, 0.1], [0.2, 0.05, 0.22, 0.1]])
    v = told_velocities(teacher, draws, ratios=TOLD_RATIOS[:3], periods=12)
    assert v.shape == (2, 3) and np.all(np.isfinite(v))
    assert not np.allclose(v[0], v[1])  # another friction, another response to the same told loads
    # each entry is the single env's run of the teacher told that load, at the draw's friction
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.05, friction_coefficient=0.22, max_periods=12, **teacher.play_kwargs)
    obs, _ = env.reset(seed=1)
    told = told_entries(np.array([0.2]), TOLD_RATIOS[1:2], np.array([env.unwrapped.force_ref]))[0]
    structure = ObservationLayout.structure
    dynamics, hidden = structure["dynamics"], slice(structure["k"].start, structure["load_over_10N"].stop)
    disp = []
    for _ in range(12):
        full = np.array(obs, dtype=np.float32)
        full[dynamics] = teacher.obs_rms.mean[dynamics]
        full[hidden] = told
        obs, _, _, _, info = env.step(np.asarray(teacher(full[None]), dtype=np.float32).reshape(5))
        disp.append(info["displacement"])
    assert v[1, 1] == pytest.approx(np.mean(disp[-10:]) / env.unwrapped.action_map.period, rel=1e-6)  # the batched network's round-off


def test_the_told_load_report_runs_and_refuses_a_mismatched_adaptation_file(tmp_path, capsys):
    import json

    from mdr_drive_agents.told_load import main

    path = tmp_path / "adaptation.json"
    path.write_text(json.dumps({"best_velocity_m_s": [0.02, 0.01]}))
    assert main(["--seed", "3", "--n", "2", "--adaptation", str(path)]) == 0
    out = capsys.readouterr().out
    assert "told the truth" in out and "told the best ratio" in out
    with pytest.raises(SystemExit):
        main(["--seed", "3", "--n", "3", "--adaptation", str(path)])
    assert "not --n 3" in capsys.readouterr().err
