"""The CMA-ES searches (mdr_drive_agents.search): fixed actions, cycles, the best drive at a point,
and critical loads by bisection."""

import numpy as np
import pytest

pytest.importorskip("cma")

from mdr_drive_agents.protocol import open_loop_velocity  # noqa: E402
from mdr_drive_agents.search import cma_optimize  # noqa: E402


def test_cma_es_on_a_tiny_budget_stays_in_the_box_and_beats_nothing_it_did_not_see():
    r = cma_optimize(0.2, 0.1, budget=24, popsize=6, seed=3)
    assert r.action.shape == (5,) and np.all(r.action >= -1.0) and np.all(r.action <= 1.0)
    assert r.evaluations <= 31  # the trapezoid + at most 5 populations of 6
    assert r.velocity == pytest.approx(open_loop_velocity([(0.2, 0.1)], r.action)[0], rel=1e-12)


def test_cma_es_over_two_action_cycles_stays_in_the_box():
    r = cma_optimize(0.3, 0.08, budget=40, popsize=8, seed=1, cycle=2, x0=np.zeros((2, 5)))
    assert r.action.shape == (2, 5) and np.all(np.abs(r.action) <= 1.0)
    assert r.velocity == pytest.approx(open_loop_velocity([(0.3, 0.08)], r.action[None])[0], rel=1e-12)


def test_a_pooled_search_starts_from_the_fastest_of_its_pool_at_the_point_and_never_loses_it():
    from mdr_drive_agents.search import PUSH_CLAMP, pooled_cycle_search

    point = (0.2, 0.05)
    slow = np.zeros((2, 5))
    pool = np.stack([slow, PUSH_CLAMP])
    v_pool = open_loop_velocity([point] * 2, pool)
    r = pooled_cycle_search(*point, pool, starts=1, budget=16, random_cycles=4, seed=2)
    assert r.action.shape == (2, 5) and np.all(np.abs(r.action) <= 1.0)
    assert r.velocity >= v_pool.max() - 1e-12  # never worse than the best of its pool
    assert r.velocity == pytest.approx(open_loop_velocity([point], r.action[None])[0], rel=1e-12)
    assert r.evaluations >= 2 + 4  # the pool and the random cycles are each played once
    again = pooled_cycle_search(*point, pool, starts=1, budget=16, random_cycles=4, seed=2)
    assert np.array_equal(again.action, r.action) and again.velocity == r.velocity  # seeded
