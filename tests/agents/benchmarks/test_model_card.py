"""The model card (mdr_drive_agents.benchmarks.model_card, mdr-drive model-card)."""

import json

import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.policy import PRETRAINED  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402


def test_model_card_marks_runaways_and_quotes_blind_results(tmp_path):
    import shutil

    from mdr_drive_agents.benchmarks.model_card import ship

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


def test_the_model_card_snippet_builds_the_env_the_policy_acts_in():
    from pathlib import Path

    from mdr_drive_agents.benchmarks.model_card import snippet

    plain = {"env_id": "MDRDrive-v0", "env_kwargs": {"k": [0.0, 0.6]}}
    assert 'gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1, max_periods=30)' in snippet(Path("p"), plain)
    fine = snippet(Path("p"), {**plain, "env_kwargs": {"time_quantum": 5e-6, "z_phase_origin": 0.5}})
    assert 'gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1, max_periods=30, z_phase_origin=0.5, time_quantum=5e-06)' in fine
    assert "in 5 us steps" in fine and "phase 0 at action 0" in fine


def test_the_model_card_names_stall_probes_only_where_the_hole_rounds_had_them():
    from mdr_drive_agents.benchmarks.model_card import stall_note

    assert stall_note({"hole_rounds": 1}) == "" and stall_note({"stall_probes": 0, "stall_band": [0.9, 1.0]}) == ""
    assert stall_note({"stall_probes": 16, "stall_band": [0.9, 1.0]}) == (
        ", each with 16 probes at 0.9-1 of the teacher's stall load")


def test_the_model_card_names_the_first_rounds_extra_episodes_only_where_the_recipe_had_them():
    from mdr_drive_agents.benchmarks.model_card import jump_note

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


def test_the_model_card_command_explains_itself_and_refuses_a_folder_without_a_policy(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["model-card", "--help"])
    assert exit_.value.code == 0 and "blind.json" in capsys.readouterr().out
    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit) as exit_:
        main(["model-card", str(tmp_path / "empty"), str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "model.zip" in err and len(err.strip().splitlines()) == 1


def test_the_model_card_says_where_todays_recipe_differs_from_the_one_that_built_the_policy():
    import json

    from mdr_drive_agents.benchmarks.model_card import recipe_note
    from mdr_drive_agents.train.recipe import DEFAULT_CONFIG, load_recipe

    from mdr_drive_agents.yaml_config import read_yaml
    from tests import DATA

    config = load_recipe(DEFAULT_CONFIG).distill
    today = json.loads(json.dumps({key: getattr(config, key) for key in config.__dataclass_fields__}))
    assert recipe_note({"command": "mdr-drive train --algo ppo"}) == ""  # not distilled: nothing to compare
    assert recipe_note({"distilled_from": {"distill": today}}) == ""
    older = {**today, "hole_dagger": not today["hole_dagger"], "focus_points": 1024}
    older.pop("teacher_load_loss", None)  # a key the older recipe did not have: it counts only where today sets it
    note = recipe_note({"distilled_from": {"distill": older}})
    assert "`focus_points`, `hole_dagger`" in note and "`make train` builds another policy" in note
    worth = DATA / "recipe_tiny_worth.yaml"  # a recipe whose student is the worth network's
    assert read_yaml(worth)["student"] == "worth"
    assert "builds another kind of student" in recipe_note({"distilled_from": {"distill": today}}, worth)
    card = (PRETRAINED / "MODEL_CARD.md").read_text()
    assert "commit" not in card and "`make train` builds another policy" in card


def test_the_sensor_cards_below_trapezoid_note_says_none_plainly():
    from mdr_drive_agents.benchmarks.model_card import below_note

    none = below_note({"points_below_trapezoid": 0, "worst_difference_to_trapezoid_mm_s": 0.179}, 48)
    assert none == "this policy at none of 48 blind points; the dense check finds such points"
    some = below_note({"points_below_trapezoid": 2, "worst_difference_to_trapezoid_mm_s": -1.971}, 48)
    assert some == "this policy at 2 of 48 blind points, by up to 1.97 mm/s; the dense check finds more"
