"""``mdr-drive evaluate``, the interface other tools call: one point, paired points, critical loads."""

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.demo import PRETRAINED  # noqa: E402
from mdr_drive_agents.evaluate import critical_loads_grid, open_loop_velocity, trapezoid_action  # noqa: E402
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
    expected = critical_loads_grid([0.3], lambda pts: open_loop_velocity(pts, trapezoid_action()))[0.3]
    assert record["critical_load_trapezoid"] == expected and 0.05 < expected < 0.1  # kg (0.070 by bisection)
    # the policy moves its critical load forward and the next grid load not
    from mdr_drive_agents.evaluate import Policy, policy_velocity

    v = policy_velocity(Policy(POLICY), [(0.3, record["critical_load_learned"])])
    assert v[0] > 0


def test_warns_outside_the_trained_range(capsys):
    code, out, err = _run(["--k", "0.7", "--cargo-mass", "0.0", "--json"], capsys)
    assert code == 0 and "outside the trained range [0, 0.6]" in err
    assert np.isfinite(json.loads(out)["trapezoid_mean_velocity"])


def test_policies_are_named_by_what_they_are_not_by_paths(tmp_path):
    from mdr_drive_agents.evaluate import policy_label

    assert policy_label(PRETRAINED) == "shipped policy"
    run = tmp_path / "deep" / "folder" / "ppo_s3"
    run.mkdir(parents=True)
    (run / "run.json").write_text(json.dumps({"algo": "ppo", "seed": 3}))
    assert policy_label(run) == "PPO seed 3 (ppo_s3)" and str(tmp_path) not in policy_label(run)


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


def test_model_card_marks_runaways_and_quotes_blind_results(tmp_path):
    import shutil

    from mdr_drive_agents.model_card import ship

    card_dir = tmp_path / "card"
    shutil.copytree(PRETRAINED, card_dir)
    blind_json = tmp_path / "blind.json"
    blind_json.write_text(json.dumps({"n": 24, "seed": 99, "statistics": {card_dir.as_posix(): {
        "points_below_trapezoid": 0, "points_scored": 20, "fraction_of_best_mean": 0.885,
        "fraction_of_best_min": 0.327, "critical_load_over_best_cycle": [0.937, 1.0],
        "critical_load_over_best_cycle_min": 0.937, "critical_load_over_trapezoid": [1.188, 1.526]}}}))
    text = ship(card_dir, card_dir, blind_json).read_text()  # in place: nothing to copy
    assert "runaway (runaway)" in text and "-1170" not in text  # k = 0.2, 0.4 kg runs away
    assert "--seed SEED" in text and "SEED = 99" in text and "## Limits" in text
    assert "| 99 | 0 | 0.885 | 0.327 (? of 20) | 0.937 (1 of 2) | 1.188-1.526 |" in text  # a file without the count
    assert "hole rounds: 1, each with 2,048 probes at 0.75-1.02 of the teacher's stall load" in text  # the shipped recipe's
    second = tmp_path / "blind2.json"
    res = json.loads(blind_json.read_text())
    res["seed"] = 100
    res["statistics"][card_dir.as_posix()]["points_under_fraction_target"] = 1
    second.write_text(json.dumps(res))
    text = ship(card_dir, card_dir, [blind_json, second]).read_text()  # one row per report seed
    assert text.count("## Blind results") == 1 and "SEED = 99, 100" in text
    assert "| 100 | 0 | 0.885 | 0.327 (1 of 20) | 0.937 (1 of 2) |" in text
    assert "All four targets met on 0 of 2 report seeds: a fresh seed passes with probability about\n0.00 (95 % Wilson interval 0.00-0.66)." in text
    assert ship(card_dir, card_dir).read_text().count("## Blind results") == 0
    # results that ran the policy from its build folder are quoted when it is shipped from there
    shipped = tmp_path / "shipped"
    assert "SEED = 99, 100" in ship(card_dir, shipped, [blind_json, second]).read_text()
    with pytest.raises(ValueError, match="do not all name the policy"):
        ship(shipped, tmp_path / "elsewhere", [blind_json])
    # ... or from a copy of the same network (a rebuild), named and checked; never another network's
    rebuilt = tmp_path / "rebuilt"
    shutil.copytree(card_dir, rebuilt)
    assert "SEED = 99, 100" in ship(rebuilt, tmp_path / "third", [blind_json, second], ran_from=card_dir).read_text()
    other = tmp_path / "other"
    shutil.copytree(PRETRAINED.parent / "ppo_sensor" / "teacher", other)
    with pytest.raises(ValueError, match="is not the same network"):
        ship(other, tmp_path / "fourth", [blind_json], ran_from=card_dir)
    assert not (tmp_path / "fourth").exists()  # refused before anything is copied


def test_evaluate_reports_the_last_waveform_as_the_policys_env_quantises_it():
    import numpy as np

    from mdr_drive_agents.evaluate_cli import _velocity_record

    action = np.array([0.5, 0.2 + 2.8 / 180, 0.8, 0.1, 0.3])  # 0.4 of a 10 us quantum past a centre
    rise = [_velocity_record(0.2, 0.1, "as-specified", 1e-3, 1e-3, action, q)["learned_waveform_last_period"]["x_rise_time"]
            for q in (1e-5, 5e-6)]
    assert abs(rise[1] - rise[0]) == pytest.approx(5e-6)


def test_the_model_card_snippet_builds_the_env_the_policy_acts_in():
    from pathlib import Path

    from mdr_drive_agents.model_card import snippet

    plain = {"env_id": "MDRDrive-v0", "env_kwargs": {"k": [0.0, 0.6]}}
    assert 'gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1)' in snippet(Path("p"), plain)
    fine = snippet(Path("p"), {**plain, "env_kwargs": {"time_quantum": 5e-6, "z_phase_origin": 0.5}})
    assert 'gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1, z_phase_origin=0.5, time_quantum=5e-06)' in fine
    assert "in 5 us steps" in fine and "phase 0 at action 0" in fine


def test_the_model_card_names_stall_probes_only_where_the_hole_rounds_had_them():
    from mdr_drive_agents.model_card import stall_note

    assert stall_note({"hole_rounds": 1}) == "" and stall_note({"stall_probes": 0, "stall_band": [0.9, 1.0]}) == ""
    assert stall_note({"stall_probes": 16, "stall_band": [0.9, 1.0]}) == (
        ", each with 16 probes at 0.9-1 of the teacher's stall load")


def test_the_model_card_names_the_first_rounds_extra_episodes_only_where_the_recipe_had_them():
    from mdr_drive_agents.model_card import jump_note

    d = {"jump_levels": 5, "focus_points": 1024, "focus_k": [0.22, 0.34], "quantum_centres": True}
    history = [{"round": 0, "jump_points": 6764}]
    assert jump_note({"distill": d, "history": history}) == (
        " and 6,764 more bisecting where its drive jumps (5 levels), 1,024 more at k = 0.22-0.34,"
        " labels at the centres of their time quanta")
    assert jump_note({"distill": {**d, "focus_points": 0}, "history": history}) == (
        " and 6,764 more bisecting where its drive jumps (5 levels), labels at the centres of their time quanta")
    inner = {**d, "inner_focus_points": 1024, "inner_focus_k": [0.23, 0.28]}
    assert "1,024 more at k = 0.22-0.34, 1,024 more at k = 0.23-0.28," in jump_note({"distill": inner, "history": history})
    assert jump_note({"distill": {}}) == ""


def test_the_model_cards_blind_record_repeats_each_command_and_counts_the_seeds_that_meet_every_target(tmp_path):
    from mdr_drive_agents.blind import DRAWN_SCAN, EVEN_SCAN
    from mdr_drive_agents.blind_record import blind_record

    clean = {"points_below_trapezoid": 0, "points_scored": 20, "fraction_of_best_mean": 1.1,
             "fraction_of_best_min": 0.9, "points_under_fraction_target": 0,
             "critical_load_over_best_cycle": [0.99, 1.0], "critical_load_over_best_cycle_min": 0.99,
             "k_values_at_critical_load_target": 2, "critical_load_over_trapezoid": [1.2, 1.5]}
    short = {**clean, "fraction_of_best_min": 0.84, "points_under_fraction_target": 1}
    low_crit = {**clean, "critical_load_over_best_cycle": [0.9696, 1.0], "critical_load_over_best_cycle_min": 0.9696}
    files = []
    for seed, scan, stats in ((97, DRAWN_SCAN, clean), (98, DRAWN_SCAN, short), (99, EVEN_SCAN, clean), (100, None, clean),
                              (101, None, low_crit)):
        res = {"n": 24, "seed": seed, "policies": ["P"], "statistics": {"P": stats}, **({"scan": scan} if scan else {})}
        files.append(tmp_path / f"{seed}.json")
        files[-1].write_text(json.dumps(res))
    text = blind_record(files, "P")
    assert "`mdr-drive benchmark --blind 24 --seed SEED --scan-draw --policies P` with SEED = 97, 98" in text
    assert "`mdr-drive benchmark --blind 24 --seed SEED --policies P` with SEED = 99, 100, 101" in text
    # a miss by less than the third decimal is printed with the digits that show it
    assert "| 101 | 0 | 1.100 | 0.900 (0 of 20) | 0.9696 (1 of 2) | 1.200-1.500 | critical load |" in text
    assert "| 98 | 0 | 1.100 | 0.840 (1 of 20) | 0.990 (2 of 2) | 1.200-1.500 | fraction of the best: minimum |" in text
    assert "| 97 | 0 | 1.100 | 0.900 (0 of 20) | 0.990 (2 of 2) | 1.200-1.500 | none |" in text
    assert ("All four targets met on 3 of 5 report seeds: a fresh seed passes with probability about\n"
            "0.60 (95 % Wilson interval 0.23-0.88).") in text


def test_the_pass_rates_wilson_interval_has_its_closed_forms_and_refuses_impossible_counts():
    from mdr_drive_agents.blind_record import wilson_interval

    z2 = 1.96 ** 2
    assert wilson_interval(0, 10) == (0.0, pytest.approx(z2 / (10 + z2)))  # no pass: [0, z^2 / (n + z^2)]
    assert wilson_interval(10, 10) == (pytest.approx(10 / (10 + z2)), 1.0)
    low, high = wilson_interval(13, 18)
    assert low < 13 / 18 < high and high - low < wilson_interval(3, 4)[1] - wilson_interval(3, 4)[0]
    for passed, n in ((5, 4), (-1, 4), (0, 0)):
        with pytest.raises(ValueError, match=f"passed={passed} of n={n}"):
            wilson_interval(passed, n)


def test_missed_targets_names_each_target_a_policy_misses():
    from mdr_drive_agents.blind import missed_targets

    met = {"points_below_trapezoid": 0, "fraction_of_best_mean": 0.95, "fraction_of_best_min": 0.85,
           "critical_load_over_best_cycle_min": 0.97}
    assert missed_targets(met) == []
    assert missed_targets({**met, "fraction_of_best_mean": None, "critical_load_over_best_cycle_min": None}) == []
    assert missed_targets({"points_below_trapezoid": 1, "fraction_of_best_mean": 0.949, "fraction_of_best_min": 0.849,
                           "critical_load_over_best_cycle_min": 0.969}) == [
        "below the trapezoid", "fraction of the best: mean", "fraction of the best: minimum", "critical load"]


def test_the_model_card_command_explains_itself_and_refuses_a_folder_without_a_policy(tmp_path, capsys):
    from mdr_drive_agents.model_card import main

    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0 and "blind.json" in capsys.readouterr().out
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit) as exit_:
        main([str(tmp_path / "empty"), str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "model.zip" in err and len(err.strip().splitlines()) == 1
