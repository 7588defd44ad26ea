"""The blind benchmark (agents/blind.py) in its quick mode, and its statistics on known numbers."""

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks import blind  # noqa: E402
from mdr_drive_agents.policy import PRETRAINED  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402


def test_points_are_drawn_from_the_training_domain_by_the_seed():
    points, crit = blind.draw_points(8, seed=3)
    again, _ = blind.draw_points(8, seed=3)
    other, _ = blind.draw_points(8, seed=4)
    assert points == again and points != other
    for (k, m), c in zip(points, crit):
        assert 0.0 <= k <= 0.6 and 0.0 <= m <= 1.25 * c
    assert np.all(crit > 0)


def test_a_drawn_scan_has_one_k_per_equal_cell_by_the_seed():
    even = blind.scan_k_values(4)
    assert even == [0.0, 0.2, 0.4, 0.6]
    drawn = blind.scan_k_values(4, seed=3)
    assert drawn == blind.scan_k_values(4, seed=3) and drawn != blind.scan_k_values(4, seed=4)
    for i, k in enumerate(drawn):  # cell i of [0, 0.6] is [0.15 i, 0.15 (i + 1)]
        assert 0.15 * i <= k <= 0.15 * (i + 1)
    assert drawn != even
    assert np.allclose(blind.in_k_cells([0.5, 0.5, 0.5, 0.5]), [0.075, 0.225, 0.375, 0.525])  # the cells' midpoints
    assert np.allclose(blind.in_k_cells([0.0, 1.0]), [0.0, 0.6])


def test_a_drawn_scan_leaves_the_points_is_recorded_and_a_reused_search_must_have_scanned_alike(tmp_path, monkeypatch, capsys):
    first = tmp_path / "first"
    res = blind.run([str(PRETRAINED)], 2, seed=5, out=first, quick=True, workers=1, scan_draw=True)
    assert res["scan"] == blind.DRAWN_SCAN and res["critical_load_kg"]["k"] == blind.scan_k_values(3, seed=5)
    assert [tuple(p) for p in res["points"]] == blind.draw_points(2, seed=5)[0]  # the scan's own stream: same points
    assert "drawn with the seed" in (first / "blind.md").read_text()
    monkeypatch.setattr(blind, "best_drive", lambda args: pytest.fail("searched again"))
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: pytest.fail("searched again"))
    assert main(["benchmark", "--blind", "2", "--seed", "5", "--quick", "--scan-draw", "--policies", str(PRETRAINED),
                 "--reuse-search", str(first / "blind.json"), "--out", str(tmp_path / "second")]) == 0
    assert main(["benchmark", "--blind", "2", "--seed", "5", "--quick", "--policies", str(PRETRAINED),
                 "--reuse-search", str(first / "blind.json"), "--out", str(tmp_path / "third")]) == 2
    assert "its scan's k values are drawn with the seed" in capsys.readouterr().err


def test_the_search_runs_at_the_time_quantum_the_policies_act_at_and_mixed_quanta_are_refused(tmp_path, monkeypatch):
    import shutil

    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import open_loop_velocity

    fine, coarse = tmp_path / "fine", tmp_path / "coarse"
    for folder, quantum in ((fine, 5e-6), (coarse, None)):
        shutil.copytree(PRETRAINED, folder)
        run = json.loads((folder / "run.json").read_text())
        run["env_kwargs"].pop("time_quantum", None)
        if quantum:
            run["env_kwargs"]["time_quantum"] = quantum
        (folder / "run.json").write_text(json.dumps(run))
    assert load_policy(fine).play_kwargs["time_quantum"] == 5e-6  # evaluation plays it in that env
    searched, scanned = [], []
    monkeypatch.setattr(blind, "best_drive", lambda args: searched.append(args) or {"velocity": 1e-3, "kind": "fixed action"})
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: scanned.append(args) or 2.0 * args.trapezoid_critical)
    res = blind.run([str(fine)], 2, seed=5, out=tmp_path / "a", quick=True, workers=1)
    assert res["search"]["time_quantum_s"] == 5e-6
    assert all(a.time_quantum == 5e-6 for a in searched + scanned) and len(searched) == 2
    with pytest.raises(ValueError, match="different time quanta"):
        blind.run([str(fine), str(coarse)], 2, seed=5, out=tmp_path / "b", quick=True, workers=1)
    # a drive between two 10 us quanta of its rise plays a waveform of its own at 5 us, one on them does not
    on = np.array([[0.5, 0.2 + 2.0 / 180, 0.8, 0.1, 0.3]])
    off = on + np.array([[0.0, 0.8 / 180, 0.0, 0.0, 0.0]])  # 0.4 of a 10 us quantum: the same 10 us rise
    point = [(0.2, 0.1)]
    assert open_loop_velocity(point, off)[0] == open_loop_velocity(point, on)[0]
    assert open_loop_velocity(point, off, time_quantum=5e-6)[0] != open_loop_velocity(point, on, time_quantum=5e-6)[0]


def test_statistics_on_known_numbers():
    trap = np.array([10e-3, 5e-3, -1e-3, np.nan, 1e-3])
    best = np.array([20e-3, 10e-3, 4e-3, 1e-3, 1.5e-3])
    learned = np.array([18e-3, 4.9e-3, 2e-3, np.nan, 1.0e-3])
    crit = {"trapezoid": [1.0, 0.5], "best cycle": [1.5, 0.6], "policy": [1.5, 0.57]}
    s = blind.statistics(trap, best, learned, crit, [0.0, 0.3])
    assert s["points_below_trapezoid"] == 1  # 4.9 against 5.0 mm/s; 1.0 against 1.0 is not below
    assert s["worst_difference_to_trapezoid_mm_s"] == pytest.approx(-0.1)
    assert s["points_scored"] == 3  # the best drive moves >= 2 mm/s at the first three points only
    assert s["fraction_of_best_mean"] == pytest.approx(np.mean([0.9, 0.49, 0.5]))
    assert s["fraction_of_best_min"] == pytest.approx(0.49)
    assert s["points_under_fraction_target"] == 2  # 0.49 and 0.5 are under 0.85, 0.9 is not
    assert s["critical_load_over_best_cycle"] == pytest.approx([1.0, 0.95])
    assert s["critical_load_over_best_cycle_min"] == pytest.approx(0.95)
    assert s["k_values_at_critical_load_target"] == 1  # 1.0 reaches 0.97, 0.95 does not
    assert s["critical_load_over_trapezoid"] == pytest.approx([1.5, 1.14])
    # normalised score where the best beats the trapezoid by >= 2 mm/s: (18-10)/10, (4.9-5)/5, (2+1)/5
    scores = [0.8, -0.02, 0.6]
    assert s["normalized_score"]["scores"] == 3 and s["normalized_score"]["mean"][0] == pytest.approx(np.mean(scores))


def test_quick_blind_benchmark_writes_its_report(tmp_path, capsys):
    out = tmp_path / "blind"
    assert main(["benchmark", "--blind", "3", "--seed", "11", "--quick", "--workers", "1",
                 "--policies", str(PRETRAINED), "--out", str(out)]) == 0
    res = json.loads((out / "blind.json").read_text())
    assert res["seed"] == 11 and len(res["points"]) == 3 and len(res["critical_load_kg"]["k"]) == 3
    for b, t in zip(res["best"], res["trapezoid"]):  # the search starts from the trapezoid: never worse
        assert t is None or b["velocity"] >= t - 1e-12
    for i, k in enumerate(res["critical_load_kg"]["k"]):  # the best cycle is never below the trapezoid
        assert res["critical_load_kg"]["best cycle"][i] >= res["critical_load_kg"]["trapezoid"][i]
    stats = res["statistics"][str(PRETRAINED)]
    assert {"points_below_trapezoid", "fraction_of_best_mean", "critical_load_over_best_cycle_min"} <= set(stats)
    for name in ("blind.md", "points.csv", "critical_loads.csv", "critical_load_vs_k.png", "fraction_of_best.png"):
        assert (out / name).stat().st_size > 100, name
    assert "Blind benchmark, seed 11" in capsys.readouterr().out
    missed = blind.missed_targets(stats)  # the report names the targets this policy missed (on 3 points)
    assert f"targets missed: {', '.join(missed) or 'none'}" in (out / "blind.md").read_text()
    assert "normalised score (0 the trapezoid, 1 the best drive" in (out / "blind.md").read_text()


def test_blind_needs_a_seed_and_a_seed_needs_blind(capsys):
    assert main(["benchmark", "--blind", "3"]) == 2
    assert "--blind needs --seed" in capsys.readouterr().err
    assert main(["benchmark", "--seed", "3"]) == 2
    assert "give --blind N too" in capsys.readouterr().err


def test_ctrl_c_keeps_the_finished_searches_and_resume_runs_only_the_rest(tmp_path, monkeypatch):
    calls = []
    real = blind.best_drive

    def interrupted(args):
        calls.append(args)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(args)

    monkeypatch.setattr(blind, "best_drive", interrupted)
    with pytest.raises(KeyboardInterrupt):
        blind.run([], 4, seed=2, out=tmp_path / "a", quick=True, workers=1)
    assert len(list((tmp_path / "a" / ".tasks" / "best_drive").glob("*.json"))) == 2
    calls.clear()
    monkeypatch.setattr(blind, "best_drive", lambda args: calls.append(args) or real(args))
    resumed = blind.run([], 4, seed=2, out=tmp_path / "a", quick=True, workers=1, resume=True)
    assert len(calls) == 2  # the two searches the interrupt left, not the two it kept
    assert not (tmp_path / "a" / ".tasks").exists()
    fresh = blind.run([], 4, seed=2, out=tmp_path / "b", quick=True, workers=1)
    assert resumed["best"] == fresh["best"] and resumed["critical_load_kg"] == fresh["critical_load_kg"]


def test_a_second_run_reuses_the_searches_of_the_first(tmp_path, monkeypatch, capsys):
    first = tmp_path / "first"
    blind.run([str(PRETRAINED)], 3, seed=5, out=first, quick=True, workers=1)
    monkeypatch.setattr(blind, "best_drive", lambda args: pytest.fail("searched again"))
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: pytest.fail("searched again"))
    assert main(["benchmark", "--blind", "3", "--seed", "5", "--quick", "--workers", "1", "--policies",
                 str(PRETRAINED), "--reuse-search", str(first / "blind.json"), "--out", str(tmp_path / "second")]) == 0
    a = json.loads((first / "blind.json").read_text())
    b = json.loads((tmp_path / "second" / "blind.json").read_text())
    for key in ("points", "trapezoid", "best", "learned", "critical_load_kg", "statistics"):
        assert a[key] == b[key], key
    assert main(["benchmark", "--blind", "3", "--seed", "6", "--quick", "--reuse-search", str(first / "blind.json"),
                 "--out", str(tmp_path / "third")]) == 2
    assert "its seed 5 is not this run's 6" in capsys.readouterr().err


def test_velocities_read_back_from_json_keep_a_runaway_as_nan():
    import json

    from mdr_drive_env.files import json_safe, nan_array

    stored = json.loads(json.dumps(json_safe(np.array([1e-3, np.nan, -2e-3]))))  # NaN (a runaway) is stored as null
    assert stored == [1e-3, None, -2e-3]
    back = nan_array(stored)
    assert back.dtype == float and np.isnan(back[1]) and back[[0, 2]].tolist() == [1e-3, -2e-3]


def test_the_strong_reference_keeps_every_points_drive_or_a_faster_one_and_says_so(tmp_path, monkeypatch):
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: 1.5 * args.trapezoid_critical)  # the scan is not what is tested
    standard = blind.run([str(PRETRAINED)], 3, seed=5, out=tmp_path / "standard", quick=True, workers=1)
    strong = blind.run([str(PRETRAINED)], 3, seed=5, out=tmp_path / "strong", quick=True, workers=1, reference="strong")
    assert "pooled_rounds" not in standard["search"] and strong["search"]["pooled_rounds"] == blind.QUICK_STRONG
    assert strong["points"] == standard["points"]
    for a, b in zip(standard["best"], strong["best"]):
        assert b["velocity"] >= a["velocity"] - 1e-12 and b["evaluations"] > a["evaluations"]
    assert "the strong reference" in (tmp_path / "strong" / "blind.md").read_text()
    with pytest.raises(ValueError, match="--reuse-search .*its search"):  # another search: not reusable
        blind.run([str(PRETRAINED)], 3, seed=5, out=tmp_path / "again", quick=True, workers=1,
                  reuse=tmp_path / "standard" / "blind.json", reference="strong")
    with pytest.raises(ValueError, match="reference='best' is not one of"):
        blind.run([str(PRETRAINED)], 3, seed=5, out=tmp_path / "bad", quick=True, workers=1, reference="best")


def test_scan_ks_0_runs_the_points_alone_without_a_critical_load_scan(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: pytest.fail("scanned"))
    out = tmp_path / "b"
    assert main(["benchmark", "--blind", "2", "--seed", "5", "--quick", "--scan-ks", "0", "--policies",
                 str(PRETRAINED), "--out", str(out)]) == 0
    res = json.loads((out / "blind.json").read_text())
    assert res["critical_load_kg"]["k"] == [] and len(res["points"]) == 2
    stats = res["statistics"][str(PRETRAINED)]
    assert stats["critical_load_over_best_cycle_min"] is None and "critical load" not in blind.missed_targets(stats)
    text = (out / "blind.md").read_text()
    assert "No critical-load scan (--scan-ks 0)" in text and "critical load: not scanned" in text
    assert (out / "fraction_of_best.png").exists() and not (out / "critical_load_vs_k.png").exists()
    with pytest.raises(SystemExit) as exit_:
        main(["benchmark", "--blind", "2", "--seed", "5", "--scan-ks", "-1"])
    assert exit_.value.code == 2 and "--scan-ks: -1 is outside the allowed range [0, inf]" in capsys.readouterr().err
