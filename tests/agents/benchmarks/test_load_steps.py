"""Load-step scoring (mdr_drive_agents.benchmarks.load_steps): recovery, and what any drive could reach."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks import load_steps  # noqa: E402
from mdr_drive_agents.benchmarks.load_steps import (RECOVERY_PERIODS, STEP_EPISODE_PERIODS,  # noqa: E402
                                                    STEP_PERIOD)


def test_recovery_counts_the_periods_to_nine_tenths_of_the_new_steady_velocity():
    v = np.full(STEP_EPISODE_PERIODS, 10e-3)
    v[STEP_PERIOD:STEP_PERIOD + 3] = 1e-3  # three slow periods after the step, then back at 10 mm/s
    steady, periods, ok = load_steps.recovery(v)
    assert steady == pytest.approx(10e-3) and periods == 3 and ok
    v[STEP_PERIOD:STEP_PERIOD + 7] = 1e-3  # seven slow periods: too late
    assert load_steps.recovery(v)[2] is False
    assert load_steps.recovery(np.zeros_like(v))[1:] == (None, None)  # nothing to recover to


def test_a_two_action_cycle_is_judged_by_the_mean_of_its_pair():
    v = np.tile([16e-3, 4e-3], STEP_EPISODE_PERIODS // 2)  # a cycle averaging 10 mm/s
    assert load_steps.recovery_window(v) == pytest.approx(10e-3)
    assert load_steps.recovery(v)[2] is True


def test_a_step_counts_as_recoverable_only_where_the_bound_reaches_the_drives_own_steady_velocity():
    ramp = np.full(STEP_EPISODE_PERIODS, 20e-3)
    ramp[STEP_PERIOD:] = np.minimum(np.arange(STEP_EPISODE_PERIODS - STEP_PERIOD) * 1e-3, 20e-3)  # slow ramp
    quick = np.full(STEP_EPISODE_PERIODS, 20e-3)
    steps = [{"cargo_mass": 0.1, "step_cargo_mass": 0.05}, {"cargo_mass": 0.05, "step_cargo_mass": 0.1}]
    reach = np.array([8e-3, 20e-3])  # nothing could recover the first step in time
    record = load_steps.recovery_record(np.array([ramp, quick]), steps, reach)
    assert (record["episodes_scored"], record["recovered_within"]) == (2, 1)
    assert (record["recoverable_scored"], record["recoverable_recovered_within"]) == (1, 1)
    assert (record["upward_steps_scored"], record["upward_recovered_within"]) == (1, 1)


def test_candidate_drives_hold_each_row_and_cycle_each_pair():
    rows = np.linspace(-1, 1, 4 * 5).reshape(4, 5)
    drives = load_steps.candidate_drives(rows)
    assert drives.shape == (4 + 2, 2, 5)
    assert np.array_equal(drives[1], [rows[1], rows[1]]) and np.array_equal(drives[5], rows[2:4])
    assert load_steps.candidate_drives(None).shape == (0, 2, 5)


class _Switch:
    """The full-observation policy until the step, then ``action`` every period."""

    def __init__(self, policy, action):
        self.policy, self.action, self.calls = policy, np.asarray(action, dtype=np.float32), 0
        self.play_kwargs, self.run = policy.play_kwargs, policy.run

    def reset(self):
        self.calls = 0

    def act(self, obs):
        self.calls += 1
        return self.policy.act(obs) if self.calls <= STEP_PERIOD else self.action[None]


def test_fastest_recovery_is_the_best_candidate_played_on_from_the_full_policys_state_at_the_step():
    from mdr_drive_agents.benchmarks.adaptation import FULL_POLICY
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import draw_hidden, env_rollout

    full = load_policy(FULL_POLICY)
    d = draw_hidden(1, 3, step_period=STEP_PERIOD)[0]
    rows = np.array([[0.4, -0.2, 0.1, 0.3, 0.0], [-0.5, 0.6, -0.3, 0.2, 0.1]])
    held = load_steps.candidate_drives(rows)[:2]
    friction = {key: d[key] for key in ("friction_coefficient", "base_friction_coefficient")}
    by_hand = [load_steps.recovery_window(env_rollout(_Switch(full, r), d["k"], d["cargo_mass"], STEP_EPISODE_PERIODS,
                                                      (STEP_PERIOD, d["step_cargo_mass"]), **friction)[0])
               for r in rows]
    assert load_steps.fastest_recovery(held, full, d) == pytest.approx(max(by_hand), rel=1e-9, abs=1e-12)
    assert load_steps.fastest_recovery(held[:0], full, d) == -np.inf
    assert STEP_PERIOD + RECOVERY_PERIODS + 2 <= STEP_EPISODE_PERIODS
