"""The sensor policy's recipe (mdr_drive_agents.train.sensor, mdr-drive train-sensor), CI-sized."""

from __future__ import annotations

import json
import pickle

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_env.cli import main
from mdr_drive_agents.train.sensor import SensorConfig
from tests import DATA

TINY = DATA / "sensor_tiny.yaml"


@pytest.fixture(scope="module")
def sensor_run(tmp_path_factory):
    """The tiny recipe in the trace tier (the shipped sensor policy's; the config says encoder), by the CLI."""
    out = tmp_path_factory.mktemp("sensor")
    assert main(["train-sensor", str(TINY), "--out", str(out), "--force", "--no-progress", "--sensor-tier", "trace",
                 "--workers", "1"]) == 0
    return out, json.loads((out / "adapt.json").read_text())


def test_the_sensor_policy_is_a_plain_sb3_policy_that_picks_the_rows_of_its_drive_table(sensor_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from mdr_drive_agents.teacher.drive_table import DriveTable
    from mdr_drive_agents.train.sensor import ESTIMATED

    out, summary = sensor_run
    assert [r["round"] for r in summary["rounds"]] == [0, 1] and summary["interrupted"] is False
    assert summary["rounds"][1]["samples"] == 2 * 8 * 12  # every episode of both rounds
    assert summary["merged"]["merge_rows_differ"] == 0 and summary["merged"]["merge_rows_checked"] == 16 * 12
    errors = {key: v for key, v in summary["rounds"][-1].items() if key.startswith("val_error_")}
    assert set(errors) == {f"val_error_{name}" for name in ESTIMATED}  # what the motion can tell, never mu, mu1 apart
    assert ESTIMATED == ("k", "load_over_friction", "load_over_10N", "friction_ratio")
    assert all(0.0 < v < 10.0 for v in errors.values())
    record = summary["rounds"][0]
    assert 0 < record["val_points_scored"] <= 64 and record["val_load_steps_scored"] <= 32
    assert -1.0 <= record["val_min_fraction_of_table"] <= record["val_mean_fraction_of_table"] <= 1.0 + 1e-9
    table = DriveTable.load(out / "drive_table.npz")
    assert summary["drives"] == len(table.drives) <= 5 and summary["rows"] == len(table.rows)
    np.testing.assert_array_equal(np.load(out / "policy" / "action_codebook.npy"), table.rows)
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["env_id"] == "MDRDriveSensor-v0" and run["env_kwargs"]["history"] == 3
    assert run["env_kwargs"]["action_codebook"] == "action_codebook.npy"
    tier = {key: run["env_kwargs"][key] for key in ("sensor_tier", "trace_samples", "encoder_noise")}
    assert tier == {"sensor_tier": "trace", "trace_samples": 4, "encoder_noise": 2e-9}
    assert run["picks_from"]["sensor"]["sensor_tier"] == "trace"
    env = gym.make("MDRDriveSensor-v0", history=3, action_codebook=table.rows, **tier)
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"), DummyVecEnv([lambda: env]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    obs = venv.reset()
    for _ in range(3):
        action, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(action)
    assert action.shape == (1,) and 0 <= action[0] < len(table.rows)
    assert main(["train-sensor", str(TINY), "--out", str(out), "--no-progress"]) == 2  # no overwrite without --force


def test_another_tier_reuses_the_drive_table_and_the_episode_values(sensor_run, tmp_path, monkeypatch):
    import mdr_drive_agents.train.sensor as sensor

    out, _ = sensor_run

    def no_values(*args, **kwargs):
        raise AssertionError("the episodes' values were computed again")

    monkeypatch.setattr(sensor, "drive_values", no_values)
    monkeypatch.setattr(sensor, "Validation", lambda *args: None)  # its own values are not the episodes'
    other = tmp_path / "encoder"
    assert main(["train-sensor", str(TINY), "--out", str(other), "--no-progress", "--sensor-tier", "encoder",
                 "--reuse", str(out)]) == 0
    assert (other / "drive_table.npz").read_bytes() == (out / "drive_table.npz").read_bytes()
    assert (other / "episode_values.npz").read_bytes() == (out / "episode_values.npz").read_bytes()
    run = json.loads((other / "policy" / "run.json").read_text())
    assert run["env_kwargs"].get("sensor_tier", "encoder") == "encoder"


def test_reuse_needs_a_folder_with_a_drive_table(tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["train-sensor", str(TINY), "--out", str(tmp_path / "out"), "--reuse", str(tmp_path)])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "has no drive_table.npz" in err and err.count("\n") == 1


@pytest.mark.parametrize("kwargs, name", [({"history": 0}, "history"), ({"explore": 2.0}, "explore"),
                                          ({"load_step_periods": (5, 40)}, "load_step_periods"),
                                          ({"arch": ()}, "arch"), ({"rounds": -1}, "rounds"),
                                          ({"continuation": 1.5}, "continuation"),
                                          ({"learning_rate": 0.0}, "learning_rate"),
                                          ({"play_switch_cost": -0.1}, "play_switch_cost"),
                                          ({"keep_best_round": "yes"}, "keep_best_round")])
def test_bad_sensor_settings_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SensorConfig(**kwargs)


def test_the_validation_sizes_of_the_recipe_reach_the_rounds_and_the_record(sensor_run):
    from mdr_drive_agents.teacher.drive_table import DriveTable
    from mdr_drive_agents.train.sensor import Validation, load_config

    recipe = load_config(TINY)
    out, res = sensor_run
    assert (recipe.validation_points, recipe.validation_load_steps) == (6, 4)
    picks = json.loads((out / "policy" / "run.json").read_text())["picks_from"]
    assert (picks["validation_points"], picks["validation_load_steps"]) == (6, 4)
    assert res["rounds"][0]["val_load_steps_scored"] <= 4
    table = DriveTable.load(out / "drive_table.npz")
    validation = Validation(recipe.sensor, table, recipe.validation_seed, 6, 4)
    assert len(validation.points) == 6 and len(validation.steps) == 4
    assert validation.velocities.shape == (6, len(table.drives))


@pytest.mark.parametrize("name", ["validation_points", "validation_load_steps"])
def test_bad_validation_sizes_name_themselves(name):
    from mdr_drive_agents.train.sensor import SensorRecipeConfig

    with pytest.raises(ValueError, match=f"{name}=0 is outside"):
        SensorRecipeConfig(seed=0, sensor=SensorConfig(), **{name: 0})


def test_keeping_the_best_round_needs_a_validation_seed():
    from mdr_drive_agents.train.sensor import SensorRecipeConfig, round_rank

    with pytest.raises(ValueError, match="keep_best_round=True needs a validation_seed"):
        SensorRecipeConfig(seed=0, sensor=SensorConfig(keep_best_round=True))
    worse, better = ({"val_points_below_trapezoid": b, "val_mean_fraction_of_table": m, "val_min_fraction_of_table": n}
                     for b, m, n in ((1, 0.99, 0.9), (0, 0.9, 0.5)))
    assert round_rank(better) > round_rank(worse)  # fewer points below the trapezoid first


@pytest.mark.parametrize("folder, says", [("no/such/folder", "is not a policy folder"),
                                          ("agents/pretrained/ppo_sensor_encoder", "is not a full-observation policy")])
def test_a_table_searched_from_a_policy_that_cannot_be_told_the_truth_is_refused_in_one_line(tmp_path, capsys, folder,
                                                                                            says):
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("polish_from: agents/pretrained/ppo_sensor/teacher", f"polish_from: {folder}"))
    assert main(["train-sensor", str(bad), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"polish_from={folder!r}" in err and says in err and err.count("\n") == 1


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
    from mdr_drive_agents.sensor_episodes import ProbeFirst, probe_actions

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
    collect_rows = sensor.collect_rows

    def interrupted(envs, *args, **kwargs):
        if len(envs) == 8:  # the tiny config's episodes per round (validation and the merge check play others)
            calls.append(1)
            if len(calls) == interrupt_at:
                raise KeyboardInterrupt
        return collect_rows(envs, *args, **kwargs)

    monkeypatch.setattr(sensor, "collect_rows", interrupted)
    out = tmp_path / "sensor"
    assert main(["train-sensor", str(TINY), "--out", str(out), "--no-progress", "--sensor-tier", "trace",
                 "--workers", "1"]) == 130
    err = capsys.readouterr().err
    if kept is None:
        assert "nothing was saved" in err and not (out / "policy" / "model.zip").exists()
        return
    assert "last finished round" in err
    summary = json.loads((out / "adapt.json").read_text())
    assert summary["interrupted"] and [r["round"] for r in summary["rounds"]] == kept
    assert summary["merged"]["merge_rows_differ"] == 0
    assert json.loads((out / "policy" / "run.json").read_text())["interrupted"] is True
    policy = load_policy(out / "policy")
    env = policy.make_env()
    obs, _ = env.reset(seed=0)
    assert 0 <= policy.predict(obs) < env.action_space.n


def test_the_play_switch_cost_reaches_the_merged_policy_and_its_record(tmp_path):
    tiny = tmp_path / "switch.yaml"
    tiny.write_text(TINY.read_text().replace("  rounds: 1\n", "  rounds: 1\n  play_switch_cost: 0.2\n"))
    out = tmp_path / "out"
    assert main(["train-sensor", str(tiny), "--out", str(out), "--no-progress", "--workers", "1"]) == 0
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["picks_from"]["sensor"]["play_switch_cost"] == 0.2
    assert run["picks_from"]["merged"]["merge_rows_differ"] == 0  # the SB3 policy picks as the network with the cost
