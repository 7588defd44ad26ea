"""agents/: training, resume, evaluation and the baselines of the waveform benchmark."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("cma")

from mdr_drive_agents.baselines import cma_optimize  # noqa: E402
from mdr_drive_agents.evaluate import (  # noqa: E402
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    Policy,
    open_loop_velocity,
    policy_rollout,
    trapezoid_action,
)
from mdr_drive_agents.train import train  # noqa: E402
from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform  # noqa: E402
from mdr_drive_env.gym_envs.spaces import ActionMap  # noqa: E402


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_writes_model_stats_tensorboard_and_resumes(algo, tmp_path):
    out = tmp_path / algo
    kw = dict(n_envs=4, eval_freq=200, checkpoint_freq=200, progress_bar=False)
    first = train(algo, steps=256, seed=0, out=out, **kw)
    assert first["total_timesteps"] >= 256
    for name in ("model.zip", "vecnormalize.pkl", "run.json", "evaluations.npz"):
        assert (out / name).exists(), name
    assert list((out / "tb").rglob("events.out.tfevents*"))
    assert list((out / "checkpoints").glob("*vecnormalize*.pkl"))
    record = json.loads((out / "run.json").read_text())
    assert record["seed"] == 0 and record["versions"]["torch"].startswith("2.13")
    # a 256-step run can take well under 0.1 s on a fast machine: the record keeps milliseconds
    assert isinstance(record["wall_time_s"], float) and record["wall_time_s"] >= 0
    assert np.isfinite(record["steps_per_s_this_run"])
    resumed = train(resume=out, steps=128, **kw)
    assert resumed["total_timesteps"] >= first["total_timesteps"] + 128
    assert resumed["resumes"] == 1
    policy = Policy(out)
    v = open_loop_velocity([(0.2, 0.1)], policy(np.zeros((1, 14), dtype=np.float32)))
    assert np.isfinite(v).all()


def test_evaluate_cli_prints_finite_velocities(tmp_path):
    out = tmp_path / "ppo"
    train("ppo", steps=128, seed=1, out=out, n_envs=4, eval_freq=10_000, progress_bar=False)
    res = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "evaluate", "--policy", str(out), "--k", "0.2",
                          "--cargo-mass", "0.1", "--json"], capture_output=True, text=True, check=True)
    data = json.loads(res.stdout)
    assert np.isfinite(data["learned_mean_velocity"]) and np.isfinite(data["trapezoid_mean_velocity"])
    assert set(data["learned_waveform_last_period"]) >= {"x_amplitude", "z_amplitude", "z_phase"}


def test_trapezoid_baseline_equals_the_simulator_with_the_paper_waveform():
    points = [(0.0, 0.1), (0.2, 0.1), (0.5, 0.0)]
    v = open_loop_velocity(points, trapezoid_action())
    for (k, m), vb in zip(points, v):
        sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), "fast")
        d = [r.displacement for r in sim.run(Waveform.paper(), EVAL_PERIODS)]
        assert vb == pytest.approx(np.mean(d[-AVERAGE_PERIODS:]) / 2e-3, rel=1e-12, abs=1e-15)


def test_cma_es_on_a_tiny_budget_stays_in_the_box_and_beats_nothing_it_did_not_see():
    r = cma_optimize(0.2, 0.1, budget=24, popsize=6, seed=3)
    assert r.action.shape == (5,) and np.all(r.action >= -1.0) and np.all(r.action <= 1.0)
    assert r.evaluations <= 31  # the trapezoid + at most 5 populations of 6
    assert r.velocity == pytest.approx(open_loop_velocity([(0.2, 0.1)], r.action)[0], rel=1e-12)


def test_a_cycle_of_two_actions_alternates_the_waveforms_period_by_period():
    a = trapezoid_action()
    b = np.array([-0.8, -0.9, 1.0, -0.9, 0.8])
    points = [(0.1, 0.2), (0.3, 0.05)]
    # a cycle of one action repeated is that fixed action
    np.testing.assert_array_equal(open_loop_velocity(points, np.tile(a, (2, 2, 1))), open_loop_velocity(points, a))
    # (a, b) in turn is the simulator run with a, b, a, b, ...
    v = open_loop_velocity(points, np.stack([a, b])[None].repeat(2, axis=0))
    amap = ActionMap()
    for (k, m), vb in zip(points, v):
        sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), "fast")
        d = [sim.step(amap.to_waveform((a, b)[t % 2])).displacement for t in range(EVAL_PERIODS)]
        assert vb == pytest.approx(np.mean(d[-AVERAGE_PERIODS:]) / 2e-3, rel=1e-12, abs=1e-15)


def test_repeated_drives_are_simulated_once_with_the_results_of_simulating_each(monkeypatch):
    """open_loop_displacements simulates a drive repeated at the same point (the same waveforms once
    quantised) once and copies its results: equal bit for bit to playing each drive in a batch of its
    own, the runaway flags too, and the displacements in C order (means over periods as before)."""
    from mdr_drive_agents import evaluate

    rng = np.random.default_rng(7)
    drives = rng.uniform(-1.0, 1.0, (3, 2, 5))
    nudged = drives[0].copy()
    nudged[:, 1] += 1e-9  # the same rise quantum: the same waveforms as drives[0]
    points = [(0.2, 0.05), (0.2, 0.05), (0.45, 0.3), (0.2, 0.05), (0.45, 0.3), (0.2, 0.05), (0.0, 0.0)]
    actions = np.stack([drives[0], drives[1], drives[2], drives[0], drives[2], nudged, drives[0]])
    sizes = []
    original = evaluate.BatchedDriveSimulator

    def counting(n, *args, **kwargs):
        sizes.append(n)
        return original(n, *args, **kwargs)

    monkeypatch.setattr(evaluate, "BatchedDriveSimulator", counting)
    disp, runaway = evaluate.open_loop_displacements(points, actions)
    assert sizes == [4]  # (0.2, 0.05) x drives 0 and 1, (0.45, 0.3) x drive 2, (0, 0) x drive 0
    assert disp.flags["C_CONTIGUOUS"] and disp.shape == (EVAL_PERIODS, len(points))
    for i, (point, action) in enumerate(zip(points, actions)):
        alone, alone_runaway = evaluate.open_loop_displacements([point], action[None])
        np.testing.assert_array_equal(disp[:, i], alone[:, 0])
        assert runaway[i] == alone_runaway[0]
    v = open_loop_velocity(points, actions)
    assert v[0] == v[3] == v[5] and v[2] == v[4] and v[0] != v[6]


def test_cma_es_over_two_action_cycles_stays_in_the_box():
    r = cma_optimize(0.3, 0.08, budget=40, popsize=8, seed=1, cycle=2, x0=np.zeros((2, 5)))
    assert r.action.shape == (2, 5) and np.all(np.abs(r.action) <= 1.0)
    assert r.velocity == pytest.approx(open_loop_velocity([(0.3, 0.08)], r.action[None])[0], rel=1e-12)


def test_policy_rollout_uses_each_points_own_load():
    class Constant:
        def __call__(self, obs):
            return np.tile(np.array([1.0, 1.0, 1.0, 0.7777778, -1.0], dtype=np.float32), (len(obs), 1))

    disp, acts, _ = policy_rollout(Constant(), [(0.0, 0.0), (0.0, 0.6)], periods=6)
    assert disp.shape == (6, 2) and acts.shape == (6, 2, 5)
    assert disp[-1, 0] > disp[-1, 1]  # the heavier load moves less


def test_rl_zoo_trains_with_the_shipped_config(tmp_path):
    pytest.importorskip("rl_zoo3")

    conf = Path(__file__).parents[1] / "agents" / "configs" / "ppo.yaml"
    res = subprocess.run([sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "MDRDrive-v0",
                          "--gym-packages", "mdr_drive_env", "-n", "300", "-conf", str(conf), "--log-folder",
                          str(tmp_path), "--eval-freq", "-1", "--env-kwargs", "k:(0.0,0.6)", "load_ratio:(0.0,0.6)",
                          "reward_floor:-2.0"], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert list(tmp_path.rglob("MDRDrive-v0.zip")) and list(tmp_path.rglob("vecnormalize.pkl"))


def test_quick_benchmark_writes_tables_plots_and_a_consistent_summary(tmp_path):
    from mdr_drive_agents.benchmark import QUICK_KS, QUICK_MASSES, run

    policy = tmp_path / "ppo"
    train("ppo", steps=64, seed=0, out=policy, n_envs=4, eval_freq=10_000, progress_bar=False)
    res = run([str(policy)], out=tmp_path / "bench", quick=True, cma_budget=24)
    for name in ("velocities.csv", "benchmark.json", "benchmark.md", "velocity_vs_k.png", "velocity_vs_load.png",
                 "critical_load_vs_k.png", "heatmap_learned_minus_trapezoid.png", "learned_waveforms.png"):
        assert (tmp_path / "bench" / name).stat().st_size > 0, name
    points = [(k, m) for k in QUICK_KS for m in QUICK_MASSES]
    assert res["points"] == points
    np.testing.assert_allclose(res["trapezoid"], open_loop_velocity(points, trapezoid_action()), rtol=1e-12)
    assert all(c >= t for c, t in zip(res["cma_es"], res["trapezoid"]))  # CMA-ES never reports worse
    assert np.asarray(res["learned_last_two_actions"][str(policy)]).shape == (len(points), 2, 5)
    crit = res["critical_load_kg"]
    assert set(crit) == {"trapezoid", "cma-es", str(policy)}
    assert all(v >= 0.0 for c in crit.values() for v in c.values())


def _script(name: str):
    import importlib.util

    path = Path(__file__).parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cycle_limit_reports_a_critical_load_and_the_sensitivity_of_every_action_component(tmp_path):
    cycle_limit = _script("cycle_limit")
    assert cycle_limit.main(["--ks", "0.3", "--iterations", "1", "--out", str(tmp_path)]) == 0
    (row,) = json.loads((tmp_path / "cycle_limit.json").read_text())
    ratio = row["cycle_critical_kg"] / row["trapezoid_critical_kg"]
    assert np.isclose(ratio, 1.0) or np.isclose(ratio, 1.4)  # one bisection step in [1.0, 1.8]
    assert np.asarray(row["cycle"]).shape == (2, 5) and np.all(np.abs(row["cycle"]) <= 1.0)
    assert len(row["sensitivity_at_1.25_mm_s"]) == 10 and "clamp z_phase" in row["sensitivity_at_1.25_mm_s"]


def test_teacher_sensitivity_script_counts_points_and_rejects_a_bad_sigma(capsys):
    """scripts/teacher_sensitivity.py (cited by docs/results.md) on a few points of the shipped teacher."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "scripts"))
    from teacher_sensitivity import main

    assert main(["--n", "3", "--seed", "5", "--draws", "1", "--sigma", "0.05"]) == 0
    out = capsys.readouterr().out.splitlines()
    moving = int(out[0].split("; ")[1].split()[0])
    row = out[-1].strip("| ").split(" | ")
    assert row[0] == "0.05" and 0 <= int(row[1]) <= moving and 0 <= int(row[2]) <= int(row[1])
    with pytest.raises(SystemExit):
        main(["--seed", "5", "--sigma", "0"])
