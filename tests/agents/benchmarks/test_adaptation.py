"""The sensor policy's report (mdr_drive_agents.benchmarks.adaptation, mdr-drive adaptation), CI-sized."""

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks import adaptation  # noqa: E402


def test_the_adaptation_report_runs_in_quick_mode(tmp_path):
    from mdr_drive_env.sweep import Executor

    res = adaptation.run(adaptation.SENSOR_POLICY, adaptation.FULL_POLICY, 2, 2, seed=5, out=tmp_path, quick=True,
                         executor=Executor(workers=1, progress=False))
    assert set(res["statistics"]) == set(adaptation.DRIVES)
    assert all(0.0 <= d["k"] <= 0.6 and 0.2 <= d["friction_coefficient"] <= 0.4 for d in res["points"])
    assert all(np.asarray(res["load_step_velocity_m_s"][d]).shape == (2, adaptation.STEP_EPISODE_PERIODS)
               for d in adaptation.DRIVES)
    for name in ("adaptation.json", "adaptation.md", "points.csv", "load_steps.csv", "adaptation_load_steps.png",
                 "adaptation_tracking.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert res["points"] == adaptation.draw_hidden(2, 5)  # the draws follow the seed
    reach = np.asarray(res["load_step_reachable_m_s"])
    assert reach.shape == (2,) and res["load_step_candidates"] == 3 * 256  # the table's rows held, and its cycles
    for d in adaptation.DRIVES:  # the bound is at least what each drive itself reached
        own = [adaptation.recovery_window(v) for v in res["load_step_velocity_m_s"][d]]
        assert np.all(reach >= np.array(own) - 1e-12)
        r = res["load_step_recovery"][d]
        assert r["recoverable_recovered_within"] <= r["recoverable_scored"] <= r["episodes_scored"]

    again = adaptation.run([adaptation.SENSOR_POLICY, adaptation.FULL_POLICY], adaptation.FULL_POLICY, 2, 1, seed=5,
                           out=tmp_path / "again", quick=True,
                           reuse=tmp_path / "adaptation.json")  # other policies judged on the same searches
    assert again["best_search"] == json.loads((tmp_path / "adaptation.json").read_text())["best_search"]
    assert again["drives"][:2] == ["sensor policy (trace)", "sensor policy (encoder)"]  # each labelled by its tier
    assert set(again["statistics"]) == set(again["drives"]) and again["drives"][2:] == list(adaptation.BASELINES)
    assert "sensor_policy_trace_m_s" in (tmp_path / "again" / "points.csv").read_text().splitlines()[0]
    assert again["search_reused_from"] == str(tmp_path / "adaptation.json")
    with pytest.raises(ValueError, match="--reuse-search .* seed"):
        adaptation.run(adaptation.SENSOR_POLICY, adaptation.FULL_POLICY, 2, 1, seed=6, out=tmp_path / "other", quick=True,
                       reuse=tmp_path / "adaptation.json")

    from mdr_drive_agents.benchmarks.model_card import ship_sensor

    card = ship_sensor(adaptation.SENSOR_POLICY, tmp_path / "shipped", tmp_path / "again" / "adaptation.json").read_text()
    assert 'This policy is the\nrow "sensor policy (trace)"' in card and "`trace` tier" in card
    assert "| sensor policy (encoder) |" in card  # the report's other drives beside it
    assert "(of those some drive could recover)" in card
    with pytest.raises(ValueError, match="none of the sensor policies"):
        ship_sensor("agents/pretrained/ppo_generalist", tmp_path / "other", tmp_path / "again" / "adaptation.json")
    assert not (tmp_path / "other").exists()  # refused before anything is copied


def test_sensor_policies_of_one_tier_are_told_apart_by_folder():
    from types import SimpleNamespace

    def policy(folder, tier):
        return SimpleNamespace(folder=folder, play_kwargs={} if tier == "encoder" else {"sensor_tier": tier})

    assert adaptation.drive_labels([policy("a/x", "trace")]) == list(adaptation.DRIVES)
    labels = adaptation.drive_labels([policy("a/x", "trace"), policy("b/y", "trace"), policy("c/z", "encoder")])
    assert labels[:3] == ["sensor policy (trace, x)", "sensor policy (trace, y)", "sensor policy (encoder)"]
    with pytest.raises(ValueError, match="not told apart"):
        adaptation.drive_labels([policy("a/x", "trace"), policy("b/x", "trace")])


def test_replot_redraws_the_shipped_report_from_its_json_alone(tmp_path):
    import shutil

    from mdr_drive_env.cli import main

    from tests import ROOT

    shutil.copy(ROOT / "results" / "adaptation" / "adaptation.json", tmp_path)
    assert main(["adaptation", "--seed", "1", "--out", str(tmp_path), "--replot"]) == 0
    assert (tmp_path / "adaptation.md").read_text() == (ROOT / "results" / "adaptation" / "adaptation.md").read_text()
    assert (tmp_path / "adaptation_load_steps.png").stat().st_size > 10_000
