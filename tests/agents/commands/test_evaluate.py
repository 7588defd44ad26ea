"""``mdr-drive evaluate``, the interface other tools call: one point, paired points, critical loads."""

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.policy import PRETRAINED  # noqa: E402
from mdr_drive_agents.protocol import open_loop_velocity, trapezoid_action, trapezoid_critical_load  # noqa: E402
from mdr_drive_agents.train.sb3 import train  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402

POLICY = str(PRETRAINED)


def _run(argv, capsys):
    code = main(["evaluate", "--policy", POLICY, *argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_one_point_prints_one_object_with_the_trapezoid_of_the_protocol(capsys):
    code, out, _ = _run(["--k", "0.2", "--cargo-mass", "0.1", "--json"], capsys)
    record = json.loads(out)
    assert code == 0 and isinstance(record, dict)
    assert record["k"] == 0.2 and record["cargo_mass"] == 0.1
    assert record["trapezoid_mean_velocity"] == pytest.approx(open_loop_velocity([(0.2, 0.1)], trapezoid_action())[0],
                                                              rel=1e-12)
    assert 0.0 < record["learned_mean_velocity"] < 0.05  # m/s, not mm/s


def test_paired_values_print_a_list_in_order(capsys):
    code, out, _ = _run(["--k", "0.0", "0.3", "--cargo-mass", "0.0", "0.4", "--json"], capsys)
    records = json.loads(out)
    assert code == 0 and [(r["k"], r["cargo_mass"]) for r in records] == [(0.0, 0.0), (0.3, 0.4)]
    heavy = records[1]  # 0.4 kg at k = 0.3: the load runs away with the slider, no velocity to report
    assert heavy["trapezoid_runaway"] and heavy["trapezoid_mean_velocity"] is None
    assert records[0]["trapezoid_mean_velocity"] == pytest.approx(15.49e-3, rel=2e-3)
    code, out, _ = _run(["--k", "0.3", "--cargo-mass", "0.4"], capsys)  # the text says runaway, without a unit
    assert code == 0 and "runaway" in out and "runaway mm/s" not in out


@pytest.mark.parametrize("argv,needle", [
    (["--k", "0.2", "0.3", "--cargo-mass", "0.1"], "--k and --cargo-mass pair up: got 2 and 1"),
    (["--k", "0.2"], "--cargo-mass is required"),
    (["--k", "0.2", "--cargo-mass", "0.1", "--critical-load"], "--critical-load finds the load itself"),
    (["--k", "1.2", "--cargo-mass", "0.1"], "--k: Material.grading_exponent=1.2"),
    (["--k", "0.2", "--cargo-mass", "-0.1"], "--cargo-mass: Drive.cargo_mass=-0.1"),
])
def test_bad_requests_are_one_line_errors(argv, needle, capsys):
    code, out, err = _run(argv, capsys)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1 and not out


def test_critical_load_per_k_in_kg(capsys):
    code, out, _ = _run(["--k", "0.3", "--critical-load", "--json"], capsys)
    record = json.loads(out)
    assert code == 0 and set(record) >= {"k", "critical_load_learned", "critical_load_trapezoid"}
    expected = trapezoid_critical_load([0.3])[0]
    assert record["critical_load_trapezoid"] == expected and 0.05 < expected < 0.1  # kg (0.070 by bisection)
    # the policy moves its critical load forward and the next grid load not
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import policy_velocity

    v = policy_velocity(load_policy(POLICY), [(0.3, record["critical_load_learned"])])
    assert v[0] > 0


def test_warns_outside_the_trained_range(capsys):
    code, out, err = _run(["--k", "0.7", "--cargo-mass", "0.0", "--json"], capsys)
    assert code == 0 and "outside the trained range [0, 0.6]" in err
    assert np.isfinite(json.loads(out)["trapezoid_mean_velocity"])


def test_policies_are_named_by_what_they_are_not_by_paths(tmp_path):
    from mdr_drive_agents.policy import policy_label

    assert policy_label(PRETRAINED) == "shipped policy"
    run = tmp_path / "deep" / "folder" / "ppo_s3"
    run.mkdir(parents=True)
    (run / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 3}))
    assert policy_label(run) == "PPO seed 3 (ppo_s3)" and str(tmp_path) not in policy_label(run)
    (run / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 1, "distilled_from": {"recipe": "r.yaml"}}))
    assert policy_label(run) == "recipe policy (ppo_s3)"  # a recipe's student, not an RL run of that seed
    (run / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 0, "picks_from": {},
                                              "env_kwargs": {"sensor_tier": "trace"}}))
    assert policy_label(run) == "sensor policy, trace tier (ppo_s3)"


def test_periods_friction_and_a_load_step(capsys):
    _, out, _ = _run(["--k", "0.2", "--cargo-mass", "0.05", "--json"], capsys)
    base = json.loads(out)
    assert len(base["learned_period_velocity"]) == len(base["trapezoid_period_velocity"]) == 30
    # the same model through the single-env path (an explicit friction) gives the same trapezoid, bit for bit
    _, out, _ = _run(["--k", "0.2", "--cargo-mass", "0.05", "--friction-coefficient", "0.3", "--json"], capsys)
    same = json.loads(out)
    assert same["trapezoid_period_velocity"] == base["trapezoid_period_velocity"]
    assert same["learned_mean_velocity"] == pytest.approx(base["learned_mean_velocity"], rel=1e-4)
    _, out, _ = _run(["--k", "0.2", "--cargo-mass", "0.05", "--periods", "40", "--load-step", "15:0.2", "--json"],
                     capsys)
    stepped = json.loads(out)
    v = stepped["trapezoid_period_velocity"]
    assert len(v) == 40 and stepped["protocol"] == "mean over periods 31-40, m/s"
    assert v[:15] == base["trapezoid_period_velocity"][:15]  # before the step: the same run
    assert v[-1] < 0 < v[14]  # 0.2 kg at k = 0.2 is past the trapezoid's critical load (0.18 kg)
    code, _, err = _run(["--k", "0.2", "--cargo-mass", "0.05", "--load-step", "30:0.2"], capsys)
    assert code == 2 and "is not before the last of --periods 30" in err


def test_a_sensor_policy_is_evaluated_on_the_sensor_observation(tmp_path, capsys):
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: gym.make("MDRDriveSensor-v0", history=2)])
    PPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0, device="cpu").learn(32).save(tmp_path / "model.zip")
    (tmp_path / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 0, "env_kwargs": {
        "observation": "sensor", "history": 2, "k": [0.0, 0.6], "load_ratio": [0.0, 0.4]}}))
    code = main(["evaluate", "--policy", str(tmp_path), "--k", "0.3", "--cargo-mass", "0.02",
                 "--friction-coefficient", "0.25", "--load-step", "10:0.05", "--json"])
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and len(record["learned_period_velocity"]) == 30
    assert record["friction_coefficient"] == 0.25 and record["load_step"] == [10, 0.05]
    assert all(np.isfinite(record["learned_period_velocity"]))


def test_warns_at_a_friction_it_was_not_trained_with(capsys):
    code, out, err = _run(["--k", "0.2", "--cargo-mass", "0.1", "--friction-coefficient", "0.25", "--json"], capsys)
    assert code == 0 and "friction coefficient 0.25 is outside the trained value 0.3" in err
    code, out, err = _run(["--k", "0.2", "--cargo-mass", "0.1", "--friction-coefficient", "0.3", "--json"], capsys)
    assert "friction" not in err


def test_evaluate_reports_the_last_waveform_as_the_policys_env_quantises_it():
    import numpy as np

    from mdr_drive_agents.commands.evaluate import _velocity_record
    from mdr_drive_agents.drive import PAPER_DRIVE

    action = np.array([0.5, 0.2 + 2.8 / 180, 0.8, 0.1, 0.3])  # 0.4 of a 10 us quantum past a centre
    rise = [_velocity_record(0.2, 0.1, PAPER_DRIVE, 1e-3, 1e-3, action, q)["learned_waveform_last_period"]["x_rise_time"]
            for q in (1e-5, 5e-6)]
    assert abs(rise[1] - rise[0]) == pytest.approx(5e-6)


def test_evaluate_cli_prints_finite_velocities(tmp_path):
    out = tmp_path / "ppo"
    train("ppo", steps=128, seed=1, out=out, n_envs=4, eval_freq=10_000, progress_bar=False)
    res = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "evaluate", "--policy", str(out), "--k", "0.2",
                          "--cargo-mass", "0.1", "--json"], capture_output=True, text=True, check=True)
    data = json.loads(res.stdout)
    assert np.isfinite(data["learned_mean_velocity"]) and np.isfinite(data["trapezoid_mean_velocity"])
    assert set(data["learned_waveform_last_period"]) >= {"x_amplitude", "z_amplitude", "z_phase"}


def test_a_sensor_policy_plays_the_drives_nominal_friction_unless_told_otherwise(capsys):
    """Its run.json draws mu in [0.2, 0.4] and mu1 in [0.07, 0.13] per episode; evaluated at a point it
    plays the middle, the paper's pair, and says so, the same as with that pair named."""
    from mdr_drive_agents.policy import SENSOR_PRETRAINED

    argv = ["evaluate", "--policy", str(SENSOR_PRETRAINED), "--k", "0.469", "--cargo-mass", "0.0099", "--json"]
    assert main(argv) == 0
    default = json.loads(capsys.readouterr().out)
    assert (default["friction_coefficient"], default["base_friction_coefficient"]) == (0.3, 0.1)
    assert main(argv + ["--friction-coefficient", "0.3", "--base-friction-coefficient", "0.1"]) == 0
    named = json.loads(capsys.readouterr().out)
    assert named["learned_period_velocity"] == default["learned_period_velocity"]
    assert named["trapezoid_period_velocity"] == default["trapezoid_period_velocity"]
    # the trapezoid is the paper drive's at that point, not at a drawn pair
    assert default["trapezoid_mean_velocity"] == pytest.approx(
        open_loop_velocity([(0.469, 0.0099)], trapezoid_action())[0], rel=1e-9)
    assert main(argv[:-1] + ["--base-friction-coefficient", "0.12"]) == 0  # inside the trained range: no warning
    captured = capsys.readouterr()
    assert "0.3, mu1 0.12" in captured.out and "warning" not in captured.err


def test_the_text_names_the_friction_pair_and_the_load_step(capsys):
    code, out, _ = _run(["--k", "0.2", "--cargo-mass", "0.05", "--load-step", "15:0.08"], capsys)
    assert code == 0 and "mu 0.3, mu1 0.1" in out and "the cargo becomes 0.08 kg before period 15" in out
    code, out, _ = _run(["--k", "0.3", "--critical-load"], capsys)
    assert code == 0 and "mu 0.3, mu1 0.1" in out


def test_a_load_step_above_the_trained_loads_warns(capsys):
    # the generalist's loads reach 0.55 of mu F_ref: 0.304 kg at k = 0.2, mu 0.3
    code, _, err = _run(["--k", "0.2", "--cargo-mass", "0.1", "--load-step", "15:0.35"], capsys)
    assert code == 0 and "m = 0.35 kg at k = 0.2 is above the trained loads" in err
    code, _, err = _run(["--k", "0.2", "--cargo-mass", "0.1", "--load-step", "15:0.25"], capsys)
    assert code == 0 and "warning" not in err


@pytest.mark.parametrize("argv,needle", [
    (["--friction-coefficient", "0.05"], "--friction-coefficient 0.05 must exceed --base-friction-coefficient 0.1"),
    (["--base-friction-coefficient", "0.3"], "--friction-coefficient 0.3 must exceed --base-friction-coefficient 0.3"),
    (["--base-friction-coefficient", "-0.1"], "mu1 >= 0"),
])
def test_an_impossible_friction_pair_is_an_error(argv, needle, capsys):
    code, out, err = _run(["--k", "0.2", "--cargo-mass", "0.1", *argv], capsys)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1 and not out


def test_the_nominal_friction_of_a_drive_is_its_value_or_the_middle_of_its_range():
    from mdr_drive_agents.drive import PAPER_DRIVE, DriveDescription

    assert PAPER_DRIVE.nominal_friction == (0.3, 0.1)
    drawn = DriveDescription((("friction_coefficient", (0.2, 0.4)), ("base_friction_coefficient", (0.07, 0.13))))
    assert drawn.nominal_friction == (0.3, 0.1)
    assert DriveDescription((("friction_coefficient", 0.25),)).nominal_friction == (0.25, 0.1)
