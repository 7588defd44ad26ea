"""The sensor policy's training (agents/adapt.py) and its adaptation report (agents/adaptation.py), CI-sized."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents import adapt, adaptation
from mdr_drive_agents.adapt import AdaptConfig

TINY = Path(__file__).parent / "data" / "sensor_tiny.yaml"


def test_the_privileged_observation_is_the_full_observation_with_the_coming_load():
    full = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.05)
    obs, _ = full.reset(seed=1)
    assert np.array_equal(full.unwrapped.privileged_observation(), obs)
    for _ in range(2):
        obs, *_ = full.step(full.action_space.sample())
        assert np.array_equal(full.unwrapped.privileged_observation(), obs)

    env = gym.make("MDRDriveSensor-v0", max_periods=10)
    _, info = env.reset(seed=3, options={"load_step": (2, 0.2)})
    priv = env.unwrapped.privileged_observation()
    assert priv.shape == (14,) and priv[10] == np.float32(info["k"])
    load_entry = priv[12]  # load / 10 N
    assert load_entry == pytest.approx(info["load_force"] / 10.0, rel=1e-6)
    env.step(env.action_space.sample())
    env.step(env.action_space.sample())  # the next period is the step's: the teacher is told the new load
    assert env.unwrapped.privileged_observation()[12] == pytest.approx(0.2 * 9.81 / 10.0, rel=1e-6)


@pytest.fixture(scope="module")
def sensor_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sensor")
    summary = adapt.run(TINY, out, force=True, progress=False)
    return out, summary


@pytest.mark.parametrize("forces", [False, True])
def test_the_merged_network_is_the_estimator_informed_teacher(forces):
    from mdr_drive_agents.adapt import sensor_env_kwargs, sensor_envs
    from mdr_drive_agents.estimator import Estimator, SensorTeacher, merged_policy
    from mdr_drive_agents.evaluate import Policy
    from mdr_drive_env.gym_envs.spaces import SensorLayout

    config = AdaptConfig(history=2, episodes=4, periods=6, load_step_periods=(1, 4), estimator_arch=(8, 8, 8),
                         sensor_forces=forces)
    envs, first = sensor_envs(config, 4, seed=2)
    assert first.shape[1] == len(SensorLayout(2, forces).names) == (21 if forces else 17)
    assert sensor_env_kwargs(config).get("sensor_forces", False) == forces  # what evaluation plays it in
    sensed = np.vstack([first, np.random.default_rng(0).normal(size=(50, first.shape[1])).astype(np.float32)])
    estimator = Estimator(sensed.shape[1], config.estimator_arch, seed=0)
    estimator.fit(sensed, np.random.default_rng(1).uniform(size=(len(sensed), 3)), 5, 16, 1e-3, 0, False)
    composed = SensorTeacher(Policy(config.teacher), estimator, SensorLayout(2, forces).structure)
    merged = merged_policy(composed, sensor_env_kwargs(config), config.log_std)
    assert merged.model.observation_space.shape == first.shape[1:]
    assert np.abs(merged.act(sensed) - np.clip(composed(sensed), -1, 1)).max() < 1e-4


def test_the_sensor_student_is_a_plain_sb3_policy_on_the_sensor_observation(sensor_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, summary = sensor_run
    assert [r["round"] for r in summary["rounds"]] == [0, 1]
    assert summary["rounds"][1]["samples"] == 2 * 8 * 12
    assert "val_mean_fraction_of_teacher" in summary["rounds"][0]
    assert "action_fit" not in summary["rounds"][0] and summary["rounds"][1]["action_fit"] == 10  # action_rounds: 1
    assert summary["merged"]["merge_max_action_difference"] < 1e-4  # one MlpPolicy = estimator + teacher
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["env_id"] == "MDRDriveSensor-v0" and run["env_kwargs"]["history"] == 3
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: gym.make("MDRDriveSensor-v0", history=3)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    obs = venv.reset()
    for _ in range(3):
        action, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(action)
    assert action.shape == (1, 5) and np.all(np.abs(action) <= 1.0)
    assert adapt.main([str(TINY), "--out", str(out), "--no-progress"]) == 2  # no overwrite without --force


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
    assert adapt.main([str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "teacher='no/such/folder'" in err and err.count("\n") == 1


def test_a_codebook_teacher_is_refused_in_one_line(tmp_path, capsys):
    import shutil

    teacher = tmp_path / "picks"  # a policy folder with an action table: Discrete actions
    shutil.copytree("agents/pretrained/ppo_sensor/teacher", teacher)
    np.save(teacher / "action_codebook.npy", np.zeros((3, 5)))
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("teacher: agents/pretrained/ppo_sensor/teacher", f"teacher: {teacher}"))
    assert adapt.main([str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "picks from an action table" in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_recovery_counts_the_periods_to_nine_tenths_of_the_new_steady_velocity():
    s = adaptation.STEP_PERIOD
    v = np.full(adaptation.STEP_EPISODE_PERIODS, 10e-3)
    v[s:s + 3] = 1e-3  # three slow periods after the step, then back at 10 mm/s
    steady, periods, ok = adaptation.recovery(v)
    assert steady == pytest.approx(10e-3) and periods == 3 and ok
    v[s:s + 7] = 1e-3  # seven slow periods: too late
    assert adaptation.recovery(v)[2] is False
    assert adaptation.recovery(np.zeros_like(v))[1:] == (None, None)  # nothing to recover to


def test_the_adaptation_report_runs_in_quick_mode(sensor_run, tmp_path):
    from mdr_drive_env.sweep import Executor

    out, _ = sensor_run
    res = adaptation.run(str(out / "policy"), adaptation.FULL_POLICY, 2, 2, seed=5, out=tmp_path, quick=True,
                         executor=Executor(workers=1, progress=False))
    assert set(res["statistics"]) == set(adaptation.DRIVES)
    assert all(0.0 <= d["k"] <= 0.6 and 0.2 <= d["friction_coefficient"] <= 0.4 for d in res["points"])
    assert all(np.asarray(res["load_step_velocity_m_s"][d]).shape == (2, adaptation.STEP_EPISODE_PERIODS)
               for d in adaptation.DRIVES)
    for name in ("adaptation.json", "adaptation.md", "points.csv", "load_steps.csv", "adaptation_load_steps.png",
                 "adaptation_tracking.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert res["points"] == adaptation.draw_hidden(2, 5)  # the draws follow the seed

    again = adaptation.run(str(out / "policy"), adaptation.FULL_POLICY, 2, 1, seed=5, out=tmp_path / "again", quick=True,
                           reuse=tmp_path / "adaptation.json")  # another policy judged on the same searches
    assert again["best_search"] == json.loads((tmp_path / "adaptation.json").read_text())["best_search"]
    assert again["search_reused_from"] == str(tmp_path / "adaptation.json")
    with pytest.raises(ValueError, match="--reuse-search .* seed"):
        adaptation.run(str(out / "policy"), adaptation.FULL_POLICY, 2, 1, seed=6, out=tmp_path / "other", quick=True,
                       reuse=tmp_path / "adaptation.json")


def test_the_sensor_policy_fine_tunes_with_ppo_through_train_resume(sensor_run, tmp_path):
    import shutil

    from mdr_drive_agents.train import train

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


def test_the_demo_drives_the_shipped_sensor_policy_through_a_load_step(tmp_path, capsys):
    from mdr_drive_agents.demo import load_steps
    from mdr_drive_agents.evaluate import PRETRAINED, SENSOR_PRETRAINED, Policy

    load_steps(Policy(SENSOR_PRETRAINED), Policy(PRETRAINED), tmp_path)
    assert (tmp_path / "load_step.png").stat().st_size > 10_000
    assert capsys.readouterr().out.count("sensor policy") == 2  # one line per load step


def test_fitting_the_estimator_through_the_teacher_brings_its_actions_to_the_told_truth():
    import torch

    from mdr_drive_agents.adapt import collect, sensor_envs
    from mdr_drive_agents.student import edge_loss
    from mdr_drive_agents.estimator import Estimator, SensorTeacher, hidden_entries, teacher_layout
    from mdr_drive_agents.evaluate import Policy
    from mdr_drive_env.gym_envs.spaces import SensorLayout

    from mdr_drive_agents.evaluate import SENSOR_PRETRAINED

    # the sensor recipe's own pinned teacher, so the check does not move with the shipped generalist
    config = AdaptConfig(history=2, episodes=8, periods=6, load_step_periods=(1, 4), estimator_arch=(16,),
                         teacher=str(Path(SENSOR_PRETRAINED) / "teacher"))
    teacher = Policy(config.teacher)
    sensed, privileged, _ = collect(*sensor_envs(config, 8, seed=4), lambda s, p: teacher(p))
    hidden = hidden_entries(teacher_layout(teacher))
    estimator = Estimator(sensed.shape[1], config.estimator_arch, seed=0)
    estimator.fit(sensed, privileged[:, hidden], 3, 16, 1e-3, 0, False)  # a poor estimate to start from
    composed = SensorTeacher(teacher, estimator, SensorLayout(2).structure)
    labels = composed.told_truth(sensed, privileged)
    told = composed.full_observation(sensed)
    told[:, hidden] = privileged[:, hidden]
    assert np.allclose(np.clip(labels, -1, 1), teacher(told), atol=1e-5)  # the teacher's action told the truth

    def loss() -> float:
        with torch.no_grad():
            return float(edge_loss(torch.as_tensor(composed(sensed)), torch.as_tensor(labels), 0.05))

    before = loss()
    composed.fit_actions(sensed, labels, 300, 16, 1e-3, 0, progress=False)
    assert loss() < 0.85 * before
    assert all(p.requires_grad for p in teacher.model.policy.parameters())  # the teacher is left as it was


def test_the_memory_script_scores_a_frame_stack_and_an_lstm_on_the_same_episodes(capsys):
    import runpy
    from pathlib import Path

    main = runpy.run_path(str(Path(__file__).parents[1] / "scripts" / "estimation_memory.py"))["main"]
    assert main(["--episodes", "8", "--periods", "6", "--history", "2", "--steps", "5", "--lstm", "8",
                 "--seed", "3", "--sensor-forces"]) == 0
    out = capsys.readouterr().out
    assert "with a force sensor" in out
    rows = [line.split("|")[1:-1] for line in out.splitlines() if line.startswith("| ")][1:]
    assert [row[0].strip() for row in rows] == ["frame-stacked MLP", "LSTM over the episode"]
    for row in rows:
        values = [float(cell) for cell in row[1:]]
        assert len(values) == 11 and all(np.isfinite(v) and v >= 0.0 for v in values)
        assert values[5] == pytest.approx(np.mean(values[:5]), abs=1e-3)  # "all" is the entries' mean
