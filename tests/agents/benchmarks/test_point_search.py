"""The benchmarks' searches as sweep tasks (agents/benchmarks/point_search.py), at tiny budgets."""

import dataclasses

import numpy as np

from mdr_drive_agents.benchmarks.point_search import (PointTask, PooledTask, ScanTask, best_drive, cycle_scan_task,
                                                      pooled_drive)
from mdr_drive_agents.drive import PAPER_DRIVE
from mdr_drive_agents.protocol import open_loop_velocity, trapezoid_action
from mdr_drive_env.sweep import task_key


def test_a_task_is_fingerprinted_by_everything_it_holds():
    task = PointTask(0.2, 0.05, 24, 32)
    assert task.drive == PAPER_DRIVE and task.friction is None and task.point == (0.2, 0.05)
    assert task_key(task) == task_key(PointTask(0.2, 0.05, 24, 32))  # a stored result is found again
    light = PAPER_DRIVE.with_settings(slider_mass=0.02)
    for changed in (dataclasses.replace(task, drive=light), dataclasses.replace(task, time_quantum=5e-6),
                    dataclasses.replace(task, friction=(0.3, 0.1)), dataclasses.replace(task, cycle_budget=33)):
        assert task_key(changed) != task_key(task)  # ... and never for another search
    assert PointTask(0.2, 0.05, 24, 32, (0.25, 0.08)).point == (0.2, 0.05, 0.25, 0.08)


def test_a_points_best_drive_is_played_again_as_it_is_recorded():
    task = PointTask(0.3, 0.02, 24, 32, friction=(0.3, 0.1))
    found = best_drive(task)
    assert found["evaluations"] > 0 and found["kind"] in ("fixed action", "two-action cycle")
    replay = open_loop_velocity([task.point], np.asarray(found["action"]).reshape(1, -1, 5))[0]
    assert found["velocity"] == replay
    assert found["velocity"] == max(found["fixed_velocity"], found["cycle_velocity"])


def test_a_strong_round_keeps_the_points_own_drive_unless_it_finds_a_faster_one():
    pool = np.tile(trapezoid_action(), (1, 2, 1)).astype(np.float64)
    own = {"velocity": 1.0, "kind": "fixed action", "action": trapezoid_action().tolist(), "evaluations": 7}
    task = PooledTask(0.2, 0.0, pool, starts=1, budget=16, random_cycles=4, seed=0, own=own)
    kept = pooled_drive(task)  # nothing moves at 1 m/s
    assert kept["action"] == own["action"] and kept["velocity"] == 1.0 and kept["evaluations"] > 7
    taken = pooled_drive(dataclasses.replace(task, own={**own, "velocity": float("nan")}))  # a runaway is beaten
    assert taken["kind"] == "two-action cycle" and np.isfinite(taken["velocity"])
    assert np.asarray(taken["action"]).shape == (2, 5)


def test_the_scan_of_a_k_where_the_trapezoid_stalls_unloaded_is_zero():
    assert cycle_scan_task(ScanTask(0.3, 0.0, iterations=1, budget=16)) == 0.0
