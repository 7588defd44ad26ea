"""The sensor policy's recipe (mdr_drive_agents.train.sensor, mdr-drive train-sensor), CI-sized."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import mdr_drive_env  # noqa: F401
from mdr_drive_env.cli import main
from mdr_drive_agents.train.sensor import AdaptConfig
from tests import DATA

TINY = DATA / "sensor_tiny.yaml"


@pytest.fixture(scope="module")
def sensor_run(tmp_path_factory):
    """The tiny recipe in the trace tier (the shipped sensor policy's; the config says encoder), by the CLI."""
    out = tmp_path_factory.mktemp("sensor")
    assert main(["train-sensor", str(TINY), "--out", str(out), "--force", "--no-progress", "--sensor-tier", "trace"]) == 0
    return out, json.loads((out / "adapt.json").read_text())


@pytest.mark.parametrize("tier, width", [("encoder", 17), ("trace", 17 + 2 * 3), ("self-sensing", 17 + 2 * 5)])
def test_the_merged_network_is_the_estimator_informed_teacher(tier, width):
    from mdr_drive_agents.train.sensor import sensor_env_kwargs, sensor_envs, sensor_structure_of
    from mdr_drive_agents.student.estimator import (Estimator, SensorTeacher, hidden_entries, merged_policy,
                                                    teacher_layout)
    from mdr_drive_agents.policy import load_policy

    config = AdaptConfig(history=2, episodes=4, periods=6, load_step_periods=(1, 4), estimator_arch=(8, 8, 8),
                         sensor_tier=tier, trace_samples=3)
    envs, first = sensor_envs(config, 4, seed=2)
    assert first.shape[1] == width
    assert sensor_env_kwargs(config).get("sensor_tier", "encoder") == tier  # what evaluation plays it in
    assert envs[0].unwrapped.sensor.tier.name == tier
    sensed = np.vstack([first, np.random.default_rng(0).normal(size=(50, first.shape[1])).astype(np.float32)])
    teacher = load_policy(config.teacher)  # the default: the shipped teacher told mu1 / mu too
    n_hidden = len(hidden_entries(teacher_layout(teacher)))
    assert n_hidden == 4
    estimator = Estimator(sensed.shape[1], config.estimator_arch, seed=0, n_out=n_hidden)
    estimator.fit(sensed, np.random.default_rng(1).uniform(size=(len(sensed), n_hidden)), 5, 16, 1e-3, 0, False)
    composed = SensorTeacher(teacher, estimator, sensor_structure_of(config))
    merged = merged_policy(composed, sensor_env_kwargs(config), config.log_std)
    assert merged.model.observation_space.shape == first.shape[1:]
    stats = composed.teacher.normalize  # exact where the teacher's normalised inputs stay inside its clip
    z = (composed.full_observation(sensed) - stats.mean) / np.sqrt(stats.var + stats.epsilon)
    inside = np.all(np.abs(z) < stats.clip_obs, axis=1)
    assert inside.sum() >= 40
    assert np.abs(merged.act(sensed) - np.clip(composed(sensed), -1, 1))[inside].max() < 1e-4


def test_the_sensor_student_is_a_plain_sb3_policy_on_the_sensor_observation(sensor_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, summary = sensor_run
    assert [r["round"] for r in summary["rounds"]] == [0, 1] and summary["interrupted"] is False
    assert summary["rounds"][1]["samples"] == 2 * 8 * 12
    assert "val_mean_fraction_of_teacher" in summary["rounds"][0]
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.student.estimator import hidden_entries, teacher_layout

    errors = {key: v for key, v in summary["rounds"][-1].items() if key.startswith("val_error_")}
    layout = teacher_layout(load_policy(yaml.safe_load(TINY.read_text())["adapt"]["teacher"]))
    assert set(errors) == {f"val_error_{layout.NAMES[i]}" for i in hidden_entries(layout)}  # the identifiable entries
    assert set(errors) >= {"val_error_k", "val_error_load_over_friction", "val_error_load_over_10N"}
    assert all(0.0 < v < 10.0 for v in errors.values())
    assert "action_fit" not in summary["rounds"][0] and summary["rounds"][1]["action_fit"] == 10  # action_rounds: 1
    assert summary["merged"]["merge_max_action_difference"] < 1e-4  # one MlpPolicy = estimator + teacher
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["env_id"] == "MDRDriveSensor-v0" and run["env_kwargs"]["history"] == 3
    tier = {key: run["env_kwargs"][key] for key in ("sensor_tier", "trace_samples", "encoder_noise")}
    assert tier == {"sensor_tier": "trace", "trace_samples": 4, "encoder_noise": 2e-9}
    assert run["adapted_from"]["adapt"]["sensor_tier"] == "trace"
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: gym.make("MDRDriveSensor-v0", history=3, **tier)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    obs = venv.reset()
    for _ in range(3):
        action, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(action)
    assert action.shape == (1, 5) and np.all(np.abs(action) <= 1.0)
    assert main(["train-sensor", str(TINY), "--out", str(out), "--no-progress"]) == 2  # no overwrite without --force


@pytest.mark.parametrize("kwargs, name", [({"history": 0}, "history"), ({"action_noise": 2.0}, "action_noise"),
                                          ({"load_step_periods": (5, 40)}, "load_step_periods"),
                                          ({"estimator_arch": ()}, "estimator_arch"),
                                          ({"action_rounds": 9}, "action_rounds"),
                                          ({"action_learning_rate": 0.0}, "action_learning_rate")])
def test_bad_adapt_settings_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        AdaptConfig(**kwargs)


def test_a_config_with_a_missing_teacher_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("teacher: agents/pretrained/ppo_sensor/teacher", "teacher: no/such/folder"))
    assert main(["train-sensor", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "teacher='no/such/folder'" in err and err.count("\n") == 1


def test_a_codebook_teacher_with_action_steps_is_refused_in_one_line(tmp_path, capsys):
    import shutil

    teacher = tmp_path / "picks"  # a policy folder with an action table: Discrete actions (TINY fits through actions)
    shutil.copytree("agents/pretrained/ppo_sensor/teacher", teacher)
    np.save(teacher / "action_codebook.npy", np.zeros((3, 5)))
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("teacher: agents/pretrained/ppo_sensor/teacher", f"teacher: {teacher}"))
    assert main(["train-sensor", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "picks from an action table" in err and "action_steps=10" in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_the_sensor_policy_fine_tunes_with_ppo_through_train_resume(sensor_run, tmp_path):
    import shutil

    from mdr_drive_agents.train.sb3 import train

    out, _ = sensor_run
    shutil.copytree(out / "policy", tmp_path / "policy")
    before = pickle.loads((tmp_path / "policy" / "vecnormalize.pkl").read_bytes()).obs_rms
    record = train(resume=tmp_path / "policy", steps=64, progress_bar=False, eval_freq=10_000, n_envs=2)
    assert record["resumes"] == 1 and record["total_timesteps"] >= 64
    assert record["env_id"] == "MDRDriveSensor-v0" and record["env_kwargs"]["observation"] == "sensor"
    after = pickle.loads((tmp_path / "policy" / "vecnormalize.pkl").read_bytes()).obs_rms
    # the statistics the sensor network was adapted on stay as they were
    np.testing.assert_array_equal(after.mean, before.mean)
    np.testing.assert_array_equal(after.var, before.var)


def test_fitting_the_estimator_through_the_teacher_brings_its_actions_to_the_told_truth():
    import torch

    from mdr_drive_agents.train.sensor import collect, sensor_envs
    from mdr_drive_agents.student.network import edge_loss
    from mdr_drive_agents.student.estimator import Estimator, SensorTeacher, hidden_entries, teacher_layout
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_env.gym_envs.spaces import PrivilegedLayout, SensorLayout

    from mdr_drive_agents.policy import SENSOR_PRETRAINED

    # the sensor recipe's own pinned teacher, so the check does not move with the shipped generalist
    config = AdaptConfig(history=2, episodes=8, periods=6, load_step_periods=(1, 4), estimator_arch=(16,),
                         teacher=str(Path(SENSOR_PRETRAINED) / "teacher"))
    teacher = load_policy(config.teacher)
    layout = teacher_layout(teacher)
    sensed, privileged, _ = collect(*sensor_envs(config, 8, seed=4), lambda s, p: teacher.act(p),
                                    friction=layout is PrivilegedLayout)
    hidden = hidden_entries(layout)
    estimator = Estimator(sensed.shape[1], config.estimator_arch, seed=0, n_out=len(hidden))
    estimator.fit(sensed, privileged[:, hidden], 3, 16, 1e-3, 0, False)  # a poor estimate to start from
    composed = SensorTeacher(teacher, estimator, SensorLayout(2).structure)
    labels = composed.told_truth(sensed, privileged)
    told = composed.full_observation(sensed)
    told[:, hidden] = privileged[:, hidden]
    assert np.allclose(np.clip(labels, -1, 1), teacher.act(told), atol=1e-5)  # the teacher's action told the truth

    def loss() -> float:
        with torch.no_grad():
            return float(edge_loss(torch.as_tensor(composed(sensed)), torch.as_tensor(labels), 0.05))

    before = loss()
    composed.fit_actions(sensed, labels, 300, 16, 1e-3, 0, progress=False)
    assert loss() < 0.85 * before
    assert all(p.requires_grad for p in teacher.model.policy.parameters())  # the teacher is left as it was


def test_mdr_drive_evaluate_plays_a_sensor_policy_in_its_own_tier(sensor_run, capsys):
    out, _ = sensor_run
    code = main(["evaluate", "--policy", str(out / "policy"), "--k", "0.3", "--cargo-mass", "0.02", "--periods", "12",
                 "--load-step", "6:0.05", "--json"])
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and len(record["learned_period_velocity"]) == 12 and record["load_step"] == [6, 0.05]
    assert all(np.isfinite(record["learned_period_velocity"]))
    from mdr_drive_agents.policy import load_policy

    policy = load_policy(out / "policy")
    env = policy.make_env(k=0.3, cargo_mass=0.02)
    assert env.unwrapped.sensor.tier.name == "trace" and env.observation_space.shape == policy.model.observation_space.shape


def test_the_probe_plays_its_varied_waveforms_first_then_the_driver():
    from mdr_drive_agents.train.sensor import ProbeFirst, probe_actions

    env = gym.make("MDRDriveSensor-v0", history=2)
    amap = env.unwrapped.action_map
    probe = probe_actions(env)
    trapezoid, reversed_, lifted, half, symmetric, clamp = (amap.to_params(a) for a in probe)
    assert trapezoid == amap.to_params(env.unwrapped.trapezoid_action())
    assert (reversed_.z_phase - trapezoid.z_phase) % 1.0 == pytest.approx(0.5, abs=0.01)
    assert lifted.z_amplitude == 0.0 and lifted.x_amplitude == trapezoid.x_amplitude
    assert half.z_amplitude == pytest.approx(trapezoid.z_amplitude / 2)
    assert symmetric.x_rise_time == pytest.approx(symmetric.period / 2, abs=amap.time_quantum)
    assert clamp.x_amplitude == 0.0 and clamp.z_amplitude == trapezoid.z_amplitude
    driver = ProbeFirst(lambda s, p: np.full((len(s), 5), 0.5), probe, periods=8, max_periods=40)
    sensed = np.zeros((10, 4), dtype=np.float32)
    sensed[:, -1] = np.arange(10) / 40  # the elapsed fraction: periods 0 ... 9
    played = driver(sensed)
    np.testing.assert_array_equal(played[:6], probe)
    np.testing.assert_array_equal(played[6:8], probe[:2])  # in turn
    assert np.all(played[8:] == 0.5)


def test_the_policy_keeps_its_estimator_and_the_report_plots_its_estimates(sensor_run, tmp_path):
    from mdr_drive_agents.benchmarks import adaptation
    from mdr_drive_agents.policy import ESTIMATOR_FILE, policy_files
    from mdr_drive_agents.student.estimator import Estimator
    from mdr_drive_env.sweep import Executor

    out, _ = sensor_run
    assert ESTIMATOR_FILE in policy_files(out / "policy")  # shipped with the policy
    est = Estimator.load(out / "policy" / ESTIMATOR_FILE)
    assert est.names[:3] == ("k", "load_over_friction", "load_over_10N")
    x = np.random.default_rng(0).normal(size=(5, len(est.scales[0]))).astype(np.float32)
    again = tmp_path / "again.npz"
    est.save(again)
    np.testing.assert_array_equal(Estimator.load(again)(x), est(x))
    res = adaptation.run([str(out / "policy")], adaptation.FULL_POLICY, 1, 2, seed=5, out=tmp_path / "report",
                         quick=True, executor=Executor(workers=1, progress=False))
    tracked = res["load_step_estimates"]
    assert tracked["names"] == list(est.names) and len(tracked["estimate"]) == 2
    assert np.shape(tracked["truth"][0]) == (adaptation.STEP_EPISODE_PERIODS, len(est.names))
    assert (tmp_path / "report" / "adaptation_estimates.png").stat().st_size > 0


@pytest.mark.parametrize("interrupt_at, kept", [(2, [0]), (1, None)])
def test_ctrl_c_keeps_the_policy_of_the_last_finished_round(tmp_path, monkeypatch, capsys, interrupt_at, kept):
    """A Ctrl-C in round 1's episodes saves round 0's policy, marked interrupted; one in round 0 saves nothing."""
    import mdr_drive_agents.train.sensor as sensor
    from mdr_drive_agents.policy import load_policy

    calls = []
    collect = sensor.collect

    def interrupted_collect(envs, *args, **kwargs):
        if len(envs) == 8:  # the tiny config's episodes per round (validation and the merge check play 64)
            calls.append(1)
            if len(calls) == interrupt_at:
                raise KeyboardInterrupt
        return collect(envs, *args, **kwargs)

    monkeypatch.setattr(sensor, "collect", interrupted_collect)
    out = tmp_path / "sensor"
    assert main(["train-sensor", str(TINY), "--out", str(out), "--no-progress", "--sensor-tier", "trace"]) == 130
    err = capsys.readouterr().err
    if kept is None:
        assert "nothing was saved" in err and not (out / "policy" / "model.zip").exists()
        return
    assert "last finished round" in err
    summary = json.loads((out / "adapt.json").read_text())
    assert summary["interrupted"] and [r["round"] for r in summary["rounds"]] == kept
    assert summary["merged"]["merge_max_action_difference"] < 1e-4
    assert json.loads((out / "policy" / "run.json").read_text())["interrupted"] is True
    policy = load_policy(out / "policy")
    env = policy.make_env()
    obs, _ = env.reset(seed=0)
    assert np.all(np.abs(policy.predict(obs)) <= 1.0)


def test_a_sensor_policy_as_teacher_is_refused_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"  # a policy that sees only the sensor observation cannot be told the truth
    bad.write_text(TINY.read_text().replace("teacher: agents/pretrained/ppo_sensor/teacher",
                                            "teacher: agents/pretrained/ppo_sensor_encoder"))
    assert main(["train-sensor", str(bad), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "is not a full-observation policy" in err and err.count("\n") == 1
