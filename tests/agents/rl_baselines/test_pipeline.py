"""mdr-drive rl-baselines at CI size: the search, the seeds, the scores and the outputs, and a resume
that reuses every finished run."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("optuna")
pytest.importorskip("sb3_contrib")

from mdr_drive_agents.rl_baselines.config import Agent, BaselinesConfig  # noqa: E402
from mdr_drive_agents.rl_baselines.curve import curve_steps  # noqa: E402
from mdr_drive_agents.benchmarks.reference import Reference  # noqa: E402
from mdr_drive_agents.yaml_config import from_yaml  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402
from tests import ROOT  # noqa: E402

DATA = ROOT / "tests" / "data"
TINY = DATA / "rl_baselines_tiny.yaml"


def test_the_config_refuses_bad_values_naming_them():
    with pytest.raises(ValueError, match="algo='dqn' is not one of"):
        Agent("dqn", 100)
    with pytest.raises(ValueError, match=r"steps=0 is outside the allowed range \[1, inf\)"):
        Agent("ppo", 0)
    with pytest.raises(ValueError, match=r"tune_steps=0 is outside the allowed range \[1, inf\)"):
        Agent("ppo", 10, tune_trials=2)
    good = dict(agents=(Agent("ppo", 10),), seeds=(1,), validation_record="a.json", report_records=("b.json",))
    BaselinesConfig(**good)
    with pytest.raises(ValueError, match="a.json is the validation record"):
        BaselinesConfig(**{**good, "report_records": ("a.json",)})
    with pytest.raises(ValueError, match="each once"):
        BaselinesConfig(**{**good, "seeds": (1, 1)})
    with pytest.raises(ValueError, match="each name once"):
        BaselinesConfig(**{**good, "agents": (Agent("ppo", 10), Agent("ppo", 20))})
    BaselinesConfig(**{**good, "agents": (Agent("ppo", 10), Agent("ppo", 20, name="PPO, warm start"))})
    with pytest.raises(ValueError, match="warm_start='teacher' is not one of"):
        Agent("ppo", 10, warm_start="teacher")
    shipped = from_yaml(BaselinesConfig, ROOT / "agents" / "configs" / "rl_baselines.yaml")
    assert len(shipped.seeds) >= 5 and {a.algo for a in shipped.agents} == {"ppo", "sac", "td3", "recurrent_ppo"}


def test_curve_steps_are_evenly_spaced_and_end_at_the_total():
    assert curve_steps(1000, 4) == [250, 500, 750, 1000]
    assert curve_steps(3, 8) == [1, 2, 3]


def test_the_tiny_pipeline_resumes_after_ctrl_c_and_writes_its_outputs(tmp_path, monkeypatch, capsys):
    import mdr_drive_agents.rl_baselines.runner as runner

    monkeypatch.chdir(ROOT)
    out, runs = tmp_path / "out", tmp_path / "runs"
    argv = ["rl-baselines", str(TINY), "--out", str(out), "--runs", str(runs), "--workers", "1", "--no-progress"]
    run_task, calls = runner.run_task, []

    def counted(task, stop_at=None):
        calls.append(task["folder"])
        if len(calls) == stop_at:
            raise KeyboardInterrupt
        return run_task(task)

    # 10 runs: 2 search trials of PPO, then 4 agents x 2 seeds; Ctrl-C in the 5th
    monkeypatch.setattr(runner, "run_task", lambda task: counted(task, stop_at=5))
    assert main(argv) == 130
    assert "continue with --resume" in capsys.readouterr().err
    assert main(argv) == 2  # the folder holds an unfinished run
    assert "is not empty" in capsys.readouterr().err
    calls.clear()
    monkeypatch.setattr(runner, "run_task", counted)
    ship = tmp_path / "pretrained"
    (ship / "sac_plain").mkdir(parents=True)  # an earlier plain policy: replaced only with --force
    assert main(argv + ["--resume", "--ship", str(ship)]) == 2
    assert "add --force" in capsys.readouterr().err
    assert main(argv + ["--resume", "--ship", str(ship), "--force"]) == 0
    assert len(calls) == 6  # only the runs that were missing

    for name in ("benchmark.md", "curves.png", "results.json", "run.json", "hyperparameters/ppo.yaml"):
        assert (out / name).exists(), name
    assert not (out / ".tasks").exists()
    table = (out / "benchmark.md").read_text()
    for row in ("| PPO | 512 | 2 x 256 |", "| TD3 | 300 | none |", "| RecurrentPPO | 256 |",
                "| TD3, warm start | 300 | none |", "| trapezoid", "| `agents/pretrained/ppo_generalist` (as its"):
        assert row in table
    (out / "benchmark.md").unlink()
    before = (out / "results.json").read_text()
    assert main(["rl-baselines", str(TINY), "--out", str(out), "--report"]) == 0  # redrawn, nothing trained
    assert (out / "benchmark.md").read_text() == table and (out / "results.json").read_text() == before
    results = json.loads((out / "results.json").read_text())
    assert [r["seed"] for r in results["runs"]["PPO"]] == [1, 2]
    assert len(results["searches"]["PPO"]["trials"]) == 2
    ref = Reference.load(DATA / "blind_tiny_b.json")
    scored = int((ref.best - ref.trapezoid >= 2e-3).sum())
    assert results["summaries"]["TD3"]["score"]["scores"] == 2 * scored  # two seeds x the scored points
    curve = results["runs"]["TD3"][0]
    assert len(curve["steps"]) == 2 and curve["steps"][-1] >= 300  # 8 envs: steps come in eights
    assert len(curve["velocities"][0]) == 12  # the validation points, then the report points
    tuned = yaml.safe_load((out / "hyperparameters" / "ppo.yaml").read_text())
    assert tuned["MDRDrive-v0"]["env_kwargs"]["time_quantum"] == 5e-6 and tuned["warm_start"] == "none"
    best = json.loads((out / "run.json").read_text())["best_run"]
    assert (runs / Path(best["folder"]).parent.name / f"s{best['seed']}" / "model.zip").exists()
    warm = json.loads((runs / "td3_warm_start" / "s1" / "run.json").read_text())
    assert warm["hyperparameters"]["warm_start"] == "trapezoid" and warm["env_kwargs"]["max_periods"] == 20
    assert warm["hyperparameters"]["action_cycle"] == 2 and warm["hyperparameters"]["reward_baseline"] == "trapezoid"
    shipped = [p.name for p in ship.iterdir()]
    assert shipped == [f"{best['algo']}_plain"]
    card = (ship / shipped[0] / "MODEL_CARD.md").read_text()
    assert "no\nteacher, no table of drives," in card and f"training seed {best['seed']}" in card
    from mdr_drive_agents.policy import load_policy

    assert np.isfinite(load_policy(ship / shipped[0]).play(k=0.2, cargo_mass=0.05, periods=3)).all()
    # its blind record, quoted in its card: only a record that judged the shipped folder
    folder = (ship / shipped[0]).as_posix()
    assert main(["benchmark", "--blind", "3", "--seed", "5", "--quick", "--policies", folder, "--out",
                 str(tmp_path / "rec"), "--workers", "1"]) == 0
    report = ["rl-baselines", str(TINY), "--out", str(out), "--report", "--ship", str(ship), "--force", "--records"]
    assert main(report + [str(DATA / "blind_tiny_b.json")]) == 2
    assert "did not judge" in capsys.readouterr().err
    assert main(report + [str(tmp_path / "rec" / "blind.json")]) == 0
    assert "## Blind results" in (ship / shipped[0] / "MODEL_CARD.md").read_text()
    # the tuned file is a config of mdr-drive train
    assert main(["train", "--config", str(out / "hyperparameters" / "ppo.yaml"), "--algo", "ppo", "--steps", "64",
                 "--out", str(tmp_path / "again"), "--no-progress"]) == 0


def test_the_plain_card_counts_the_loads_the_policy_drops_where_the_trapezoid_carries_them(tmp_path):
    import math

    from mdr_drive_agents.rl_baselines.card import dropped_load_note, dropped_loads

    res = {"points": [[0.1, 0.2], [0.2, 0.1], [0.3, 0.05], [0.4, 0.02], [0.5, 0.01]],
           "trapezoid": [2e-3, 0.0, None, -1e-3, 3e-3],  # m/s; None: the trapezoid lets it run away
           "learned": {"p": [None, -1e-3, None, None, 4e-3]}}
    found = dropped_loads([res], "p")  # a runaway under the trapezoid, or its own backward drive, is not dropped
    assert [(k, m) for k, m, *_ in found] == [(0.1, 0.2), (0.2, 0.1)] and math.isnan(found[0][3])
    path = tmp_path / "blind.json"
    path.write_text(json.dumps(res))
    note = dropped_load_note([path], "p")
    assert "At 2 of its record's 5 points" in note and "(1 points)" in note
    assert "at worst k = 0.100, m = 0.2000 kg: the trapezoid 2.00 mm/s, this policy a runaway" in note
    res["learned"]["p"] = [3e-3, 1e-3, None, None, 4e-3]
    path.write_text(json.dumps(res))
    assert dropped_load_note([path], "p") == "* It never drops a load the trapezoid carries on its record's 5 points.\n"
    assert dropped_load_note([], "p") == ""
