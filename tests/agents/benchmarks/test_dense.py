"""The dense check (mdr_drive_agents.benchmarks.dense, mdr-drive dense) and the count it shares with the
blind benchmark (targets.below_trapezoid)."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks.dense import worst_text  # noqa: E402
from mdr_drive_agents.benchmarks.targets import below_trapezoid  # noqa: E402
from mdr_drive_agents.policy import PRETRAINED  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402


def test_below_the_trapezoid_is_counted_where_either_moves_and_a_runaway_is_slowest():
    trap = np.array([1e-3, 1e-3, -1e-3, -1e-3, 1e-3, np.nan])
    learned = np.array([0.96e-3, 0.9e-3, -2e-3, 0.5e-3, np.nan, -1e-3])
    below, gap, _ = below_trapezoid(trap, learned)
    # within 0.05 mm/s; 0.1 below; neither moves; faster; a runaway where the trapezoid moves; the trapezoid runs away
    assert below.tolist() == [False, True, False, False, True, False]
    assert gap[4] == -np.inf
    assert worst_text(below, gap).startswith("a runaway") and worst_text(below, gap).endswith("-0.10 mm/s")
    assert worst_text(below & np.isfinite(gap), gap) == "-0.10 mm/s"
    assert worst_text(np.isinf(gap), gap).endswith("worst without: none")
    assert worst_text(np.zeros(6, bool), gap) == "none below"


def test_the_dense_check_writes_its_files_once_and_its_counts_agree(tmp_path, capsys):
    import csv
    import json

    policy = str(PRETRAINED)
    out = tmp_path / "dense"
    assert main(["dense", "--policy", policy, "--ks", "3", "--loads", "4", "--out", str(out), "--no-progress"]) == 0
    res = json.loads((out / "dense.json").read_text())
    assert len(res["k"]) == 3 and len(res["policy_m_s"]) == 12 and res["load_fraction"][-1] == pytest.approx(1.25)
    rows = list(csv.DictReader(open(out / "below.csv")))
    assert f"**{len(rows)}**" in (out / "dense.md").read_text() and (out / "below_trapezoid.png").stat().st_size > 0
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import policy_velocity

    point = (res["k"][1], res["load_fraction"][2] * res["trapezoid_critical_kg"][1])
    assert res["policy_m_s"][6] == pytest.approx(policy_velocity(load_policy(policy), [point])[0], abs=1e-8)
    capsys.readouterr()
    assert main(["dense", "--policy", policy, "--ks", "3", "--loads", "4", "--out", str(out)]) == 2  # not replaced
    err = capsys.readouterr().err                                                                       # silently
    assert "--force" in err and len(err.strip().splitlines()) == 1
