"""The told-load worth policy (mdr_drive_agents.student.told): its library, its points, its fit, and the
SB3 policy it is written as."""

from __future__ import annotations

import numpy as np
import pytest

from mdr_drive_agents.policy import load_policy
from mdr_drive_agents.protocol import trapezoid_action
from mdr_drive_agents.student.network import save_student
from mdr_drive_agents.student.told import WorthConfig, field_library, fit_told, pick_quality, told_observations, told_points
from mdr_drive_env.sweep import Executor
from tests.agents.fields import synthetic_field

TINY = WorthConfig(points=12, stall_points=4, arch=(16,), steps=30, batch=8, validation_points=6, torch_threads=1)
ENV = {"k": [0.0, 0.6], "load_ratio": [0.0, 0.55], "max_periods": 10, "time_quantum": 5e-6}


def test_the_library_is_the_trapezoid_then_each_distinct_field_drive_once():
    field = synthetic_field()
    field.drives[1, 1] = field.drives[0, 0]  # a drive two nodes share is one drive of the library
    library = field_library(field)
    assert np.array_equal(library.drives[0], np.tile(trapezoid_action(), (2, 1)))
    assert len(library.drives) == 4 * 5 - 1 + 1
    assert len(np.unique(library.drives.reshape(len(library.drives), -1), axis=0)) == len(library.drives)
    field_drives = library.drives[1:]  # the trapezoid as the benchmarks play it; the field's on the quanta's centres
    centred = field.drive.action_map().quantum_centre(field_drives.reshape(-1, 5))
    assert np.array_equal(centred.reshape(field_drives.shape), field_drives)


def test_told_points_are_seeded_and_counted():
    field = synthetic_field()
    a, b = told_points(field, TINY, 3), told_points(field, TINY, 3)
    assert a == b and len(a) == 16 and a != told_points(field, TINY, 4)
    assert all(0.0 <= k <= 0.6 and m >= 0.0 for k, m in a)


def test_pick_quality_counts_fractions_of_the_best_and_points_below_the_trapezoid():
    v = np.array([[0.010, 0.020, 0.005], [0.004, 0.001, 0.002], [0.0005, 0.0001, 0.0002]])
    q = pick_quality(v, np.array([1, 1, 0]))  # the third point moves < 2 mm/s: not scored as a fraction
    assert q["fraction_of_library_best_mean"] == pytest.approx((1.0 + 0.25) / 2)
    assert q["fraction_of_library_best_min"] == pytest.approx(0.25)
    assert q["points_below_trapezoid"] == 1


def test_the_network_reads_k_and_the_load_only():
    obs = told_observations([(0.1, 0.02), (0.1, 0.02), (0.3, 0.0)], ENV)
    assert obs.shape == (3, 14) and obs.dtype == np.float32
    assert np.array_equal(obs[0], obs[1]) and not np.array_equal(obs[0], obs[2])


def test_fit_told_writes_one_sb3_policy_that_picks_as_the_network(tmp_path):
    field = synthetic_field()
    student, library, record = fit_told(field, TINY, 0, ENV, Executor(workers=1, progress=False), progress=False)
    assert record["drives"] == len(library.drives) and record["rows"] == 2 * len(library.drives)
    assert record["points"] == 16 and set(record["wall_time_s"]) == {"values", "fit", "total"}
    assert np.isfinite(record["loss"]) and record["loss"] > 0.0
    assert set(record["validation_points"]) == set(record["labelled_points"])  # judged on points never fitted
    save_student(student, tmp_path / "policy", {"algo": "ppo", "seed": 0, "env_id": "MDRDrive-v0", "env_kwargs": ENV})
    policy = load_policy(tmp_path / "policy")
    env = policy.make_env(k=0.2, cargo_mass=0.01)
    obs, _ = env.reset(seed=0)
    played = []
    for _ in range(6):  # a cycle's two rows in turn: the drive's rows, never a row of another drive half-way
        row = int(policy.predict(obs))
        played.append(row)
        obs, *_ = env.step(row)
    assert all(0 <= r < len(library.rows) for r in played)
    drive = played[-1] // 2
    assert {r // 2 for r in played[1:]} == {drive}


def test_worth_config_names_a_bad_value():
    with pytest.raises(ValueError, match="top_weight"):
        WorthConfig(top_weight=-1.0)
    with pytest.raises(ValueError, match="arch"):
        WorthConfig(arch=())
    with pytest.raises(ValueError, match="stall_points"):
        WorthConfig(stall_points=-1)
