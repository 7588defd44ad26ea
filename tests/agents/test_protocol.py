"""The evaluation protocol (mdr_drive_agents.protocol): open-loop and closed-loop steady velocities,
runaways and critical loads, the trapezoid."""

import numpy as np
import pytest

from mdr_drive_agents.protocol import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    open_loop_velocity,
    policy_rollout,
    trapezoid_action,
)
from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform
from mdr_drive_env.gym_envs.spaces import ActionMap


def test_trapezoid_baseline_equals_the_simulator_with_the_paper_waveform():
    points = [(0.0, 0.1), (0.2, 0.1), (0.5, 0.0)]
    v = open_loop_velocity(points, trapezoid_action())
    for (k, m), vb in zip(points, v):
        sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), "fast")
        d = [r.displacement for r in sim.run(Waveform.paper(), EVAL_PERIODS)]
        assert vb == pytest.approx(np.mean(d[-AVERAGE_PERIODS:]) / 2e-3, rel=1e-12, abs=1e-15)


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
    from mdr_drive_agents import protocol as evaluate

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


def test_policy_rollout_uses_each_points_own_load():
    class Constant:
        def __call__(self, obs):
            return np.tile(np.array([1.0, 1.0, 1.0, 0.7777778, -1.0], dtype=np.float32), (len(obs), 1))

    disp, acts, _ = policy_rollout(Constant(), [(0.0, 0.0), (0.0, 0.6)], periods=6)
    assert disp.shape == (6, 2) and acts.shape == (6, 2, 5)
    assert disp[-1, 0] > disp[-1, 1]  # the heavier load moves less
