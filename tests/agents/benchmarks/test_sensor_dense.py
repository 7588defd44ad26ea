"""The sensor policy's dense check (mdr_drive_agents.benchmarks.sensor_dense, mdr-drive dense on a sensor policy)."""

import json

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks import sensor_dense  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402

SENSOR = "agents/pretrained/ppo_sensor"


def test_the_grid_spans_the_sensor_envs_hidden_ranges():
    points = sensor_dense.grid(3, 2)
    assert len(points) == 3 * 2 * 9
    assert {p["k"] for p in points} == {0.0, 0.3, 0.6} and {p["load_ratio"] for p in points} == {0.0, 0.4}
    assert {(p["friction_coefficient"], p["base_friction_coefficient"]) for p in points} == set(sensor_dense.frictions())
    assert set(sensor_dense.frictions()) == {(mu, mu1) for mu in (0.2, 0.3, 0.4) for mu1 in (0.07, 0.1, 0.13)}


def test_mdr_drive_dense_checks_a_sensor_policy_over_its_hidden_values(tmp_path, capsys):
    assert main(["dense", "--policy", SENSOR, "--ks", "2", "--loads", "2", "--out", str(tmp_path), "--no-progress"]) == 0
    text = capsys.readouterr().out
    res = json.loads((tmp_path / "sensor_dense.json").read_text())
    assert len(res["points"]) == len(res["policy_m_s"]) == 36 and "36 points" in text
    learned, trap = np.array(res["policy_m_s"]), np.array(res["trapezoid_m_s"])
    below = int(((learned < trap - 5e-5) & ((learned > 0) | (trap > 0))).sum())
    assert f"(where either moves): **{below}**" in text  # the count is the statistic's
    back = int(((learned < trap - 5e-5) & (learned <= 0) & (trap <= 0)).sum())
    assert f"slides back faster than the trapezoid by more than 0.05 mm/s: **{back}**" in text
    assert len((tmp_path / "below.csv").read_text().splitlines()) >= below + 1
    # the trapezoid's column is the trapezoid played at each point's hidden values
    from mdr_drive_agents.benchmarks.adaptation import play

    p, m = res["points"][5], res["cargo_mass_kg"][5]
    v, _, _ = play("trapezoid", {"trapezoid": None}, {**p, "cargo_mass": m}, 30)
    assert trap[5] == pytest.approx(v[-10:].mean(), abs=1e-7)
    assert main(["dense", "--policy", SENSOR, "--ks", "2", "--loads", "2", "--out", str(tmp_path)]) == 2  # no overwrite


def test_a_full_observation_policy_is_not_a_sensor_policy():
    with pytest.raises(ValueError, match="not a sensor policy"):
        sensor_dense.run("agents/pretrained/ppo_generalist", 2, 2, "unused", "test", progress=False)
