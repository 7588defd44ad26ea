"""The friction-aware teacher (agents/friction_teacher.py), its env observation and its use by the
sensor training, CI-sized."""

from __future__ import annotations

import json
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import mdr_drive_env  # noqa: F401
from mdr_drive_agents import friction_teacher
from mdr_drive_agents.drive_field import DriveField, FieldConfig
from mdr_drive_agents.friction_teacher import FrictionField, FrictionTeacherConfig

TINY = Path(__file__).parent / "data" / "friction_teacher_tiny.yaml"
RANGES = {"k": (0.0, 0.6), "load_ratio": (0.0, 0.4), "friction_coefficient": (0.2, 0.4),
          "base_friction_coefficient": (0.07, 0.13)}


def test_the_privileged_observation_is_the_full_one_and_the_episodes_friction():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make("MDRDrive-v0", observation="privileged", **RANGES)
    full = gym.make("MDRDrive-v0", **RANGES)
    check_env(env.unwrapped)
    sb3_check_env(env.unwrapped)
    obs, info = env.reset(seed=7)
    assert env.observation_space.shape == (16,) and env.unwrapped.observation_structure["friction"] == slice(14, 16)
    assert obs[14:] == pytest.approx([info["friction_coefficient"], info["base_friction_coefficient"]], rel=1e-6)
    assert np.array_equal(obs[:14], full.reset(seed=7)[0])
    action = np.full(5, 0.4, dtype=np.float32)
    obs, *_ = env.step(action)
    assert np.array_equal(obs[:14], full.step(action)[0])
    assert np.array_equal(env.unwrapped.privileged_observation(friction=True), obs)
    assert env.unwrapped.privileged_observation().shape == (14,)  # the full layout, as before
    sensor = gym.make("MDRDriveSensor-v0")
    _, info = sensor.reset(seed=2)
    assert sensor.unwrapped.privileged_observation(friction=True)[14] == pytest.approx(info["friction_coefficient"])
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


def _field(mu1: float, ks=(0.0, 0.3), fill: float = 0.5) -> DriveField:
    """A synthetic 2 x 3 field searched (notionally) at mu = 0.3, mu1."""
    drives = np.full((len(ks), 3, 2, 5), fill)
    return DriveField(np.array(ks), np.linspace(0.0, 1.2, 3), np.full(len(ks), 0.05), drives, np.zeros((len(ks), 3)),
                      {"config": {"friction": [0.3, mu1]}})


def test_a_field_searched_at_other_friction_plays_its_nodes_there_and_reads_loads_over_mu():
    field = _field(0.15)
    assert field.friction == (0.3, 0.15) and field.point(1, 2) == (0.3, pytest.approx(0.06), 0.3, 0.15)
    assert field.with_friction([(0.1, 0.02)]) == [(0.1, 0.02, 0.3, 0.15)]
    assert field.field_load((0.1, 0.02, 0.2, 0.1)) == pytest.approx(0.03)  # the same load over mu F_ref
    assert _field(0.1).friction == (0.3, 0.1) == DriveField(*[getattr(field, a) for a in (
        "ks", "fractions", "trapezoid_critical", "drives", "velocities")]).friction  # no config: the paper's
    with pytest.raises(ValueError, match="friction mu"):
        FieldConfig(friction=(0.0, 0.1))
    with pytest.raises(ValueError, match="friction"):
        FieldConfig(friction=(0.3,))


def test_the_friction_field_mixes_the_two_fields_around_the_points_ratio():
    low, high = _field(0.06, fill=0.2), _field(0.12, fill=0.6)  # rho 0.2 and 0.4
    ff = FrictionField([high, low])
    assert ff.rhos.tolist() == pytest.approx([0.2, 0.4])  # sorted by rho
    cands = ff.candidates((0.15, 0.01, 0.3, 0.09), radius=1)  # rho 0.3: halfway
    assert len(cands) == 1 + 5 + 5 and cands[0] == pytest.approx(np.full((2, 5), 0.4))
    assert ff.candidates((0.15, 0.01, 0.3, 0.03))[0] == pytest.approx(np.full((2, 5), 0.2))  # below the range: clipped
    drives, v = ff.best([(0.15, 0.01, 0.25, 0.075), (0.1, 0.0)])
    assert drives.shape == (2, 2, 5) and v.shape == (2,) and np.isfinite(v).all()
    with pytest.raises(ValueError, match="ratio"):
        FrictionField([low, _field(0.06)])
    with pytest.raises(ValueError, match="k grid"):
        FrictionField([low, _field(0.12, ks=(0.0, 0.6))])
    with pytest.raises(ValueError, match="rhos"):
        FrictionTeacherConfig(rhos=(0.0,))
    with pytest.raises(ValueError, match="base_friction_coefficient"):
        FrictionTeacherConfig(base_friction_coefficient=(0.2, 0.1))


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


def test_a_sensor_policy_learns_friction_too_from_a_privileged_teacher(teacher_run):
    from mdr_drive_agents.adapt import AdaptConfig, collect, sensor_env_kwargs, sensor_envs
    from mdr_drive_agents.estimator import Estimator, SensorTeacher, hidden_entries, merged_policy, teacher_layout
    from mdr_drive_agents.evaluate import Policy
    from mdr_drive_env.gym_envs.spaces import PrivilegedLayout, SensorLayout

    out, _ = teacher_run
    teacher = Policy(out / "policy")
    assert teacher_layout(teacher) is PrivilegedLayout and hidden_entries(PrivilegedLayout) == [10, 11, 12, 14, 15]
    config = AdaptConfig(teacher=str(out / "policy"), history=2, episodes=4, periods=6, load_step_periods=(1, 4),
                         estimator_arch=(8, 8))
    sensed, privileged, _ = collect(*sensor_envs(config, 4, seed=2), lambda s, p: teacher(p), friction=True)
    assert privileged.shape[1] == 16
    estimator = Estimator(sensed.shape[1], config.estimator_arch, seed=0, n_out=5)
    estimator.fit(sensed, privileged[:, hidden_entries(PrivilegedLayout)], 5, 16, 1e-3, 0, False)
    composed = SensorTeacher(teacher, estimator, SensorLayout(2).structure)
    merged = merged_policy(composed, sensor_env_kwargs(config), config.log_std)
    assert np.abs(merged.act(sensed) - np.clip(composed(sensed), -1, 1)).max() < 1e-4


def test_the_friction_teacher_check_scores_fields_against_an_adaptation_report(capsys, tmp_path):
    import runpy

    root = Path(__file__).resolve().parents[1]
    main = runpy.run_path(str(root / "scripts" / "friction_teacher_check.py"))["main"]
    report = root / "results" / "adaptation" / "seed1777_validation" / "adaptation.json"
    assert main([str(report), str(root / "results" / "recipe" / "teacher_field.npz"), "--scaling", "2",
                 "--radius", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("\n| 0.") == 2  # two replayed drives
    assert "| friction-aware teacher (fields) |" in out and "| sensor policy |" in out
    # the full-observation policy runs away at one of these draws: scored as no motion, never "nan"
    # (its mean depends on the shipped teacher field, which the reference includes where it is faster)
    assert "nan" not in out and re.search(r"\| full-observation policy \| 0\.\d{3} / 0\.000 / \d+ \(27\) \|", out)
    with pytest.raises(SystemExit):
        main([str(tmp_path / "missing.json"), str(root / "results" / "recipe" / "teacher_field.npz")])


def test_a_friction_teacher_config_with_a_missing_field_is_one_line(tmp_path, capsys):
    config = yaml.safe_load(TINY.read_text())
    config["friction"]["fields"] = [str(tmp_path / "nowhere.npz")]
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    assert friction_teacher.main([str(tmp_path / "config.yaml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nowhere.npz" in err and "friction.fields" in err


def test_stall_probes_with_a_drawn_friction_are_refused_before_any_work(tmp_path, capsys):
    from mdr_drive_agents.distill import DistillConfig, distill

    config = yaml.safe_load(TINY.read_text())
    config["distill"]["stall_probes"] = 4
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    assert friction_teacher.main([str(tmp_path / "config.yaml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "stall_probes" in err and not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="stall_probes"):  # no field, no student: refused before either is used
        distill(None, DistillConfig(stall_probes=4), friction=((0.2, 0.4), (0.07, 0.13)))


def test_the_probe_check_scores_robust_and_probing_choices_among_the_fields_drives(capsys, tmp_path):
    import runpy

    root = Path(__file__).resolve().parents[1]
    main = runpy.run_path(str(root / "scripts" / "friction_probe_check.py"))["main"]
    report = root / "results" / "adaptation" / "seed1777_validation" / "adaptation.json"
    fields = [root / "results" / "recipe" / "teacher_field.npz",
              *sorted((root / "results" / "adaptation" / "friction_fields").glob("rho*.npz"))]
    assert len(fields) == 4
    assert main([str(report), *map(str, fields), "--limit", "3", "--radius", "1", "--probe-periods", "2"]) == 0
    out = capsys.readouterr().out
    assert "3 draws of seed 1777" in out and "0.175, 0.333, 0.460, 0.650" in out
    rows = {line.split(" | ")[0].strip("| "): line for line in out.splitlines() if line.startswith("| ") and not line.startswith("| drive")}
    assert {"told rho: the best of the drives", "robust, max-min", "robust, max-mean",
            "probe 2 periods each, then pick", "sensor policy"} <= set(rows)
    # the told-rho row is the best of the drives each choice picks from: no choice has a higher mean
    mean = {name: float(line.split(" | ")[2].split(" / ")[0]) for name, line in rows.items()}
    assert all(mean[name] <= mean["told rho: the best of the drives"] + 1e-9
               for name in ("robust, max-min", "robust, max-mean", "probe 2 periods each, then pick"))
    assert main([str(report), *map(str, fields), "--limit", "2", "--radius", "1", "--probe-periods", "2",
                 "--sequential"]) == 0
    assert "| probe 2 periods each, in turn, then pick |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main([str(report), str(tmp_path / "missing.npz")])
