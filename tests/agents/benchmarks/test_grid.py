"""The fixed-grid benchmark (mdr_drive_agents.benchmarks.grid, mdr-drive benchmark) at CI size."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.protocol import open_loop_velocity, trapezoid_action  # noqa: E402
from mdr_drive_agents.train.sb3 import train  # noqa: E402


def test_quick_benchmark_writes_tables_plots_and_a_consistent_summary(tmp_path):
    from mdr_drive_agents.benchmarks.grid import QUICK_KS, QUICK_MASSES, run

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
