"""The friction-aware teacher's recipe (mdr_drive_agents.train.friction_teacher, mdr-drive
friction-teacher) and its use by the sensor training, CI-sized."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import yaml

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.train import friction_teacher
from mdr_drive_env.cli import main
from mdr_drive_agents.teacher import DriveField
from tests import DATA
from tests.agents.fields import friction_field as _field
from tests.agents.train.student_stage import interrupt_in_the_hole_round, record_fits

TINY = DATA / "friction_teacher_tiny.yaml"


@pytest.fixture(scope="module")
def teacher_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("friction_teacher")
    _field(0.1).save(tmp / "paper.npz")
    config = yaml.safe_load(TINY.read_text())
    config["friction"]["fields"] = [str(tmp / "paper.npz")]
    (tmp / "config.yaml").write_text(yaml.safe_dump(config))
    summary = friction_teacher.run(tmp / "config.yaml", tmp / "out", progress=False)
    return tmp / "out", summary


def test_the_friction_teacher_searches_its_ratios_and_distils_a_privileged_sb3_policy(teacher_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, summary = teacher_run
    assert summary["rhos"] == pytest.approx([1 / 3, 0.5])
    assert DriveField.load(out / "fields" / "rho0.500.npz").friction == (0.3, 0.15)
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["env_kwargs"]["observation"] == "privileged" and run["env_kwargs"]["friction_coefficient"] == [0.2, 0.4]
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: gym.make("MDRDrive-v0", **run["env_kwargs"])]))
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    action, _ = model.predict(venv.normalize_obs(venv.reset()), deterministic=True)
    assert action.shape == (1, 5)
    with pytest.raises(ValueError, match="not empty"):
        friction_teacher.run(TINY, out, progress=False)


def test_the_sensor_policys_drive_table_starts_its_searches_from_the_teachers_own_cycles(teacher_run):
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import open_loop_velocity, policy_velocity
    from mdr_drive_agents.student.estimator import hidden_entries, teacher_layout
    from mdr_drive_agents.teacher.drive_table import policy_cycles
    from mdr_drive_env.gym_envs.spaces import PrivilegedLayout

    out, _ = teacher_run
    teacher = load_policy(out / "policy")
    assert teacher_layout(teacher) is PrivilegedLayout and hidden_entries(PrivilegedLayout) == [10, 11, 12, 14]
    points = [(0.1, 0.02, 0.25, 0.1), (0.4, 0.005, 0.35, 0.08)]  # (k, cargo mass, mu, mu1): told friction too
    cycles = policy_cycles(out / "policy", points)
    assert cycles.shape == (2, 2, 5) and np.all(np.abs(cycles) <= 1.0)
    closed = policy_velocity(teacher, points)
    # the cycle it settles into, played open loop from rest, drives as it does (it settles by period 20 here)
    np.testing.assert_allclose(open_loop_velocity(points, cycles), closed, atol=0.5e-3)


def test_a_friction_teacher_config_with_a_missing_field_is_one_line(tmp_path, capsys):
    config = yaml.safe_load(TINY.read_text())
    config["friction"]["fields"] = [str(tmp_path / "nowhere.npz")]
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    assert main(["friction-teacher", str(tmp_path / "config.yaml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nowhere.npz" in err and "friction.fields" in err


def test_stall_probes_with_a_drawn_friction_are_refused_before_any_work(tmp_path, capsys):
    from mdr_drive_agents.student.distill import DistillConfig, distill

    config = yaml.safe_load(TINY.read_text())
    config["distill"]["stall_probes"] = 4
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    assert main(["friction-teacher", str(tmp_path / "config.yaml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stall_probes" in err and not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="stall_probes"):  # no field, no student: refused before either is used
        distill(None, DistillConfig(stall_probes=4), friction=((0.2, 0.4), (0.07, 0.13)))


def test_an_interrupted_friction_teacher_resumes_after_its_students_first_fit(teacher_run, tmp_path, monkeypatch,
                                                                              capsys):
    out, _ = teacher_run
    assert not (out / ".tasks").exists()  # a finished run leaves no task files
    config = yaml.safe_load(TINY.read_text())
    config["friction"]["fields"] = [str(p) for p in sorted((out / "fields").glob("*.npz"))]  # no search: fast
    config["friction"]["rhos"] = []
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    run = tmp_path / "run"

    saved = interrupt_in_the_hole_round(["friction-teacher", str(tmp_path / "config.yaml"), "--out", str(run),
                                         "--no-progress"], run, monkeypatch, capsys)
    fits = record_fits(monkeypatch)
    friction_teacher.run(tmp_path / "config.yaml", run, progress=False, resume=True)
    assert f"round 0 read from {saved}" in capsys.readouterr().out
    assert fits == [config["distill"]["hole_steps"]]  # only the hole round was fitted
    assert (run / "policy" / "model.zip").exists() and not (run / ".tasks").exists()


def test_a_codebook_friction_teacher_picks_every_fields_drives(tmp_path):
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.student.data import grid_actions
    from mdr_drive_agents.teacher import FrictionField

    fields = [_field(0.1, fill=0.2), _field(0.15, fill=0.6)]  # two ratios, no search
    for i, f in enumerate(fields):
        f.save(tmp_path / f"f{i}.npz")
    config = yaml.safe_load(TINY.read_text())
    config["friction"].update(rhos=[], fields=[str(tmp_path / "f0.npz"), str(tmp_path / "f1.npz")])
    config["distill"].update(action_codebook=True, quantum_centres=True)
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    friction_teacher.run(tmp_path / "config.yaml", tmp_path / "out", progress=False)
    teacher = load_policy(tmp_path / "out" / "policy")
    np.testing.assert_array_equal(teacher.codebook, grid_actions(FrictionField(fields)))
    assert len(teacher.codebook) == 2  # each field's one drive

