"""Drive descriptions (mdr_drive_agents.drive): a YAML of MDRDrive-v0 keywords that the protocol,
the recipe, evaluate and the blind benchmark act on; end to end on a tiny drive."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.drive import PAPER_DRIVE, DriveDescription
from mdr_drive_agents.protocol import ACTION_MAP, open_loop_velocity, trapezoid_action
from mdr_drive_env.cli import main
from tests import DATA, ROOT

TINY_DRIVE = DATA / "drive_tiny.yaml"


def test_the_paper_drive_is_the_env_default_and_its_trapezoid_the_papers():
    assert PAPER_DRIVE.is_paper and PAPER_DRIVE.env_kwargs == {}
    assert np.array_equal(PAPER_DRIVE.trapezoid_action(), ACTION_MAP.to_action(mdr_drive_env.core.Waveform.paper()))
    assert PAPER_DRIVE.period == 2e-3 and PAPER_DRIVE.z_amplitude_max == 6e-6


def test_a_drives_sensor_policy_hides_its_ranges_and_a_spread_of_its_friction_pair():
    from mdr_drive_env import SENSOR_DEFAULTS

    assert PAPER_DRIVE.sensor_env_kwargs() == {key: list(v) if isinstance(v, tuple) else v
                                               for key, v in SENSOR_DEFAULTS.items()}  # MDRDriveSensor-v0 as it is
    tiny = DriveDescription.load(TINY_DRIVE)
    kwargs = tiny.sensor_env_kwargs()
    assert kwargs["k"] == [0.1, 0.3] and kwargs["load_ratio"] == [0.0, 0.4]  # its load range, up to 0.4 of mu F_ref
    assert kwargs["friction_coefficient"] == pytest.approx([0.25 * 2 / 3, 0.25 * 4 / 3])
    assert kwargs["base_friction_coefficient"] == pytest.approx([0.08 * 0.7, 0.08 * 1.3])
    assert kwargs["period"] == 5e-4 and kwargs["observation"] == "sensor"
    ranged = DriveDescription.from_mapping({"friction_coefficient": [0.28, 0.32], "base_friction_coefficient": [0.09, 0.11],
                                            "load_ratio": [0.05, 0.3]})
    kwargs = ranged.sensor_env_kwargs()
    assert kwargs["friction_coefficient"] == [0.28, 0.32] and kwargs["base_friction_coefficient"] == [0.09, 0.11]
    assert kwargs["load_ratio"] == [0.05, 0.3] and ranged.nominal_friction == (0.3, 0.1)
    contact = ranged.params(0.2, 0.01).contact  # a point of a ranged drive plays its nominal pair
    assert (contact.friction_coefficient, contact.base_friction_coefficient) == (0.3, 0.1)
    env = gym.make("MDRDriveSensor-v0", **kwargs)
    _, info = env.reset(seed=3)
    assert 0.28 <= info["friction_coefficient"] <= 0.32
    with pytest.raises(ValueError, match="friction ranges mu .* overlap"):
        DriveDescription.from_mapping({"friction_coefficient": 0.2, "base_friction_coefficient": 0.15}).sensor_env_kwargs()


def test_a_description_reads_yaml_numbers_validates_keys_and_values(tmp_path):
    drive = DriveDescription.load(TINY_DRIVE)
    assert drive.name == "drive_tiny" and drive.k_range == (0.1, 0.3) and drive.load_ratio_range == (0.0, 0.5)
    assert drive.env_kwargs["youngs_modulus"] == 1.2e11  # written 1.2e11: YAML 1.1 reads a string, the loader a float
    assert not drive.is_paper and drive.period == 5e-4
    bad = tmp_path / "bad.yaml"
    bad.write_text("slider_mas: 0.02\n")
    with pytest.raises(ValueError, match="bad.yaml: drive key 'slider_mas' is not one of"):
        DriveDescription.load(bad)
    bad.write_text("slider_mass: -1\n")
    with pytest.raises(ValueError, match=r"slider_mass=-1.0 is outside the allowed range"):
        DriveDescription.load(bad)
    bad.write_text("k: [0.5, 0.2]\n")
    with pytest.raises(ValueError, match="low must not exceed high"):
        DriveDescription.load(bad)
    with pytest.raises(ValueError, match="cannot be read"):
        DriveDescription.load(tmp_path / "missing.yaml")
    bad.write_text("friction_coefficient: 0.15\nbase_friction_coefficient: 0.2\n")  # both in their env ranges
    with pytest.raises(ValueError, match="friction_coefficient=0.15 must exceed base_friction_coefficient=0.2"):
        DriveDescription.load(bad)
    with pytest.raises(ValueError, match="must exceed"):  # the default mu = 0.3
        PAPER_DRIVE.with_settings(base_friction_coefficient=0.3)


def test_a_search_solver_steps_relative_to_the_period_and_leaves_the_drive_what_it_is():
    slow = DriveDescription.from_mapping({"period": 4e-3, "x_amplitude_max": 20e-6, "z_amplitude_max": 4e-6})
    searched = slow.with_search_solver(200)
    assert searched.numerics.time_step == pytest.approx(2e-5)  # T / 200, not the env's 5 us
    assert searched.numerics.max_x_step == slow.numerics.max_x_step  # the solver still shortens steps on edges
    assert slow.numerics.time_step == 5e-6 and searched.with_search_solver(None).numerics == slow.numerics
    assert searched == slow and hash(searched) == hash(slow) and searched.to_record() == slow.to_record()
    assert PAPER_DRIVE.with_search_solver(1000).numerics == PAPER_DRIVE.numerics  # never finer than the env's
    with pytest.raises(ValueError, match=r"search_steps_per_period=10 is outside the allowed range \[50, inf\)"):
        slow.with_search_solver(10)
    points, action = [(0.3, 0.02), (0.5, 0.0)], slow.trapezoid_action()
    fine, coarse = (open_loop_velocity(points, action, drive=d) for d in (slow, searched))
    assert not np.array_equal(fine, coarse)  # played with another step ...
    np.testing.assert_allclose(coarse, fine, rtol=0.02, atol=1e-5)  # ... to about the same velocity


def test_the_trapezoid_of_any_drive_is_the_papers_shape_at_its_strokes_and_period():
    env = gym.make("MDRDrive-v0", period=1e-3, x_amplitude_max=20e-6, z_amplitude_max=4e-6).unwrapped
    action = env.trapezoid_action()  # the example of issue 76: it used to raise "lies outside the action box"
    assert np.all(np.abs(action) <= 1.0)
    waveform = env.action_to_waveform(action)
    assert waveform.x.amplitude == pytest.approx(20e-6) and waveform.z.amplitude == pytest.approx(4e-6)
    assert waveform.x.rise_time == pytest.approx(0.95e-3) and waveform.z.rise_time == pytest.approx(0.85e-3)
    drive = DriveDescription.from_mapping({"period": 1e-3, "x_amplitude_max": 20e-6, "z_amplitude_max": 4e-6})
    np.testing.assert_array_equal(drive.trapezoid_action(), action)


def test_the_protocol_on_a_drive_plays_what_the_env_on_that_drive_plays():
    drive = DriveDescription.load(TINY_DRIVE)
    k, m = 0.2, 0.002
    v = open_loop_velocity([(k, m)], trapezoid_action(drive), drive=drive)[0]
    env = gym.make("MDRDrive-v0", k=k, cargo_mass=m, max_periods=30, **drive.env_kwargs)
    env.reset(seed=0)
    displacements = [env.step(env.unwrapped.trapezoid_action())[4]["displacement"] for _ in range(30)]
    assert v == pytest.approx(np.mean(displacements[-10:]) / 5e-4, rel=1e-9)
    assert v != pytest.approx(open_loop_velocity([(k, m)], trapezoid_action())[0], rel=1e-3)  # not the paper drive


@pytest.fixture(scope="module")
def drive_recipe(tmp_path_factory):
    out = tmp_path_factory.mktemp("drive_recipe")
    code = main(["recipe", str(DATA / "recipe_tiny.yaml"), "--drive", str(TINY_DRIVE), "--out", str(out / "r"),
                 "--force", "--no-progress", "--workers", "1"])
    assert code == 0
    return out / "r"


def test_the_recipe_builds_a_policy_for_the_drive_that_loads_and_plays_on_it(drive_recipe):
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import drive_of
    from mdr_drive_agents.teacher import DriveField

    run = json.loads((drive_recipe / "policy" / "run.json").read_text())
    assert run["env_kwargs"]["period"] == 5e-4 and run["env_kwargs"]["k"] == [0.1, 0.3]
    assert run["drive"]["name"] == "drive_tiny"
    field = DriveField.load(drive_recipe / "teacher_field.npz")
    assert field.drive.settings == DriveDescription.load(TINY_DRIVE).settings
    assert field.ks.min() == 0.1 and field.ks.max() == 0.3 and field.friction == (0.25, 0.08)
    recipe = json.loads((drive_recipe / "recipe.json").read_text())
    assert recipe["drive"]["name"] == "drive_tiny"
    policy = load_policy(drive_recipe / "policy")
    drive = drive_of(policy)
    assert drive.name == "drive_tiny" and drive.k_range == (0.1, 0.3) and drive.period == 5e-4


def test_evaluate_plays_the_policy_and_the_trapezoid_on_the_policys_drive(drive_recipe, capsys):
    code = main(["evaluate", "--policy", str(drive_recipe / "policy"), "--k", "0.2", "--cargo-mass", "0.002", "--json"])
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and record["drive"] == "drive_tiny"
    drive = DriveDescription.load(TINY_DRIVE)
    trapezoid = open_loop_velocity([(0.2, 0.002)], trapezoid_action(drive), drive=drive, mark_runaway=True)[0]
    assert record["trapezoid_mean_velocity"] == pytest.approx(trapezoid, rel=1e-12)
    waveform = record["learned_waveform_last_period"]
    assert waveform["x_amplitude"] <= 10e-6 + 1e-12 and waveform["x_rise_time"] < 5e-4  # the drive's strokes and period
    assert main(["evaluate", "--policy", str(drive_recipe / "policy"), "--k", "0.2", "--cargo-mass", "0.002",
                 "--drive", str(ROOT / "agents" / "configs" / "drives" / "heavy_stage.yaml")]) == 2
    assert "built for another drive" in capsys.readouterr().err


def test_the_blind_benchmark_judges_the_policy_on_its_drive(drive_recipe, tmp_path, capsys):
    out = tmp_path / "blind"
    assert main(["benchmark", "--blind", "3", "--seed", "5", "--quick", "--policies", str(drive_recipe / "policy"),
                 "--out", str(out), "--workers", "1"]) == 0
    res = json.loads((out / "blind.json").read_text())
    assert res["drive"]["name"] == "drive_tiny" and res["domain"]["k"] == [0.1, 0.3]
    assert all(0.1 <= k <= 0.3 for k, _ in res["points"]) and all(0.1 <= k <= 0.3 for k in res["critical_load_kg"]["k"])
    drive = DriveDescription.load(TINY_DRIVE)
    trapezoid = open_loop_velocity(res["points"], trapezoid_action(drive), drive=drive, mark_runaway=True)
    np.testing.assert_allclose(res["trapezoid"], trapezoid, rtol=1e-12)
    assert all(b["velocity"] >= t - 1e-12 for b, t in zip(res["best"], res["trapezoid"]))  # never worse than it
    assert "on drive drive_tiny" in (out / "blind.md").read_text()
    assert main(["benchmark", "--drive", str(TINY_DRIVE), "--policies", str(drive_recipe / "policy")]) == 2
    assert "--drive needs --blind" in capsys.readouterr().err


def test_the_recipe_builds_the_drives_sensor_policy_and_the_adaptation_report_judges_it_there(drive_recipe, tmp_path):
    """``mdr-drive recipe --drive`` also builds the sensor policy of that drive: its hidden k and load over
    the drive's ranges, its friction over the default spread around the drive's pair; the adaptation report
    draws, searches and plays on the drive the sensor policy was built for."""
    from mdr_drive_agents.benchmarks import adaptation
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import drive_of
    from mdr_drive_agents.teacher.drive_table import DriveTable

    out = tmp_path / "both"
    assert main(["recipe", str(DATA / "recipe_tiny_worth.yaml"), "--drive", str(TINY_DRIVE), "--out", str(out),
                 "--teacher", str(drive_recipe / "teacher_field.npz"), "--no-progress", "--workers", "1"]) == 0
    run = json.loads((out / "sensor_policy" / "run.json").read_text())
    kwargs = run["env_kwargs"]
    assert kwargs["period"] == 5e-4 and kwargs["k"] == [0.1, 0.3] and kwargs["load_ratio"] == [0.0, 0.4]
    assert kwargs["friction_coefficient"] == pytest.approx([0.25 * 2 / 3, 0.25 * 4 / 3])
    assert kwargs["base_friction_coefficient"] == pytest.approx([0.08 * 0.7, 0.08 * 1.3])
    assert run["drive"]["name"] == "drive_tiny"
    assert DriveTable.load(out / "drive_table.npz").record["drive"]["name"] == "drive_tiny"
    policy = load_policy(out / "sensor_policy")
    drive = drive_of(policy)
    assert drive.name == "drive_tiny" and drive.period == 5e-4 and drive.nominal_friction == (0.25, 0.08)
    from mdr_drive_agents.protocol import play_drive

    told = load_policy(out / "policy")  # the same stage: its friction pair is the sensor policy's nominal one
    assert drive.stage_settings == drive_of(told).stage_settings == DriveDescription.load(TINY_DRIVE).stage_settings
    assert play_drive([told, policy]).stage_settings == drive.stage_settings
    assert PAPER_DRIVE.stage_settings == drive_of(load_policy("agents/pretrained/ppo_sensor")).stage_settings == ()
    from mdr_drive_agents.protocol import env_rollout, policy_velocity

    # a sensor policy plays at (k, load) points (the blind benchmark's) at the drive's nominal pair
    v = policy_velocity(policy, [(0.2, 0.002), (0.15, 0.001)])
    np.testing.assert_allclose(v, [env_rollout(policy, k, m)[0][-10:].mean() for k, m in ((0.2, 0.002), (0.15, 0.001))],
                               rtol=1e-9)

    res = adaptation.run(out / "sensor_policy", out / "policy", 2, 1, seed=5, out=tmp_path / "adapt", quick=True,
                         executor=adaptation.Executor(workers=1, progress=False))
    assert res["drive"]["name"] == "drive_tiny" and "on drive drive_tiny" in (tmp_path / "adapt" / "adaptation.md").read_text()
    assert all(0.1 <= d["k"] <= 0.3 and 0.25 * 2 / 3 <= d["friction_coefficient"] <= 0.25 * 4 / 3 for d in res["points"])
    trapezoid = open_loop_velocity([adaptation.hidden_point(d) for d in res["points"]], trapezoid_action(drive),
                                   drive=drive)
    np.testing.assert_allclose(res["steady_velocity_m_s"]["trapezoid"], trapezoid, rtol=1e-9)
    assert res["tuned_once_point"] == {"k": 0.2, "load_ratio": 0.2, "friction_coefficient": 0.25,
                                       "base_friction_coefficient": 0.08}
    assert main(["dense", "--policy", str(out / "sensor_policy"), "--ks", "2", "--loads", "2", "--out",
                 str(tmp_path / "dense"), "--no-progress"]) == 0
    dense = json.loads((tmp_path / "dense" / "sensor_dense.json").read_text())
    assert dense["drive"]["name"] == "drive_tiny" and {p["k"] for p in dense["points"]} == {0.1, 0.3}
    assert max(p["friction_coefficient"] for p in dense["points"]) == pytest.approx(0.25 * 4 / 3)


def test_a_reference_scores_a_policy_only_on_the_drive_it_was_run_on(drive_recipe, tmp_path):
    from mdr_drive_agents.benchmarks.reference import Reference
    from mdr_drive_agents.policy import PRETRAINED, load_policy

    assert main(["benchmark", "--blind", "2", "--seed", "6", "--quick", "--policies", str(drive_recipe / "policy"),
                 "--out", str(tmp_path / "blind"), "--workers", "1"]) == 0
    reference = Reference.load(tmp_path / "blind" / "blind.json")
    assert reference.drive.name == "drive_tiny" and reference.drive.period == 5e-4
    found = reference.score_policy(load_policy(drive_recipe / "policy"))
    res = json.loads((tmp_path / "blind" / "blind.json").read_text())
    np.testing.assert_allclose(found["velocity"], np.array(list(res["learned"].values())[0], dtype=float), rtol=1e-12)
    with pytest.raises(ValueError, match="built for another drive"):
        reference.score_policy(load_policy(PRETRAINED))  # the paper drive's policy
    paper_reference = Reference.load(DATA / "blind_tiny_a.json")
    with pytest.raises(ValueError, match="built for another drive"):
        paper_reference.score_policy(load_policy(drive_recipe / "policy"))


def test_the_example_drives_are_package_data_named_from_any_directory(tmp_path, monkeypatch):
    """``agents/configs/drives/NAME.yaml`` names the package's own example drives (installed with it:
    pyproject's package data) wherever the command runs."""
    import argparse

    from mdr_drive_agents.commands import drive_file

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "configs/drives/*.yaml" in data["mdr_drive_agents"]
    monkeypatch.chdir(tmp_path)
    drive = drive_file("agents/configs/drives/small_stage.yaml")
    assert drive.name == "small_stage" and drive.period == 1e-3
    with pytest.raises(argparse.ArgumentTypeError, match="no_such_stage.yaml"):
        drive_file("agents/configs/drives/no_such_stage.yaml")


def test_one_version_for_both_packages_and_the_command(capsys):
    import mdr_drive_agents
    import mdr_drive_env
    from mdr_drive_env.cli import main

    assert mdr_drive_agents.__version__ == mdr_drive_env.__version__ == "0.2.0"
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == "mdr-drive 0.2.0"
