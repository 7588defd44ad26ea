"""Load-step scoring of the adaptation report (``benchmarks.adaptation``): whether a drive is back to
``RECOVERY_FRACTION`` of its steady velocity at the new load within ``RECOVERY_PERIODS`` periods, and
whether any drive could be.

The second matters because some steps cannot be recovered in 5 periods whatever is played: after a
step down from a load at which the slider stalls, its velocity ramps up over more than ten periods
under every drive. ``fastest_recovery`` bounds what is reachable: from the state the full-observation
policy leaves at the step, each candidate drive (each row of a sensor policy's table held, and each
two-action cycle of it) is played on, and the highest velocity over the two recovery periods is kept.
A step is *recoverable* for a drive where that bound reaches ``RECOVERY_FRACTION`` of the drive's own
steady velocity. It is a bound over the candidates held from the step, not over every sequence of
actions.
"""

from __future__ import annotations

import copy

import numpy as np

from ..protocol import AVERAGE_PERIODS, actions_of, drive_of, rollout_env
from .targets import MOVING_THRESHOLD

STEP_PERIOD = 20
STEP_EPISODE_PERIODS = 40
RECOVERY_PERIODS = 5
RECOVERY_FRACTION = 0.9


def recovery_window(v: np.ndarray) -> float:
    """The mean velocity (m/s) of periods ``STEP_PERIOD + RECOVERY_PERIODS`` and the one after (0-based)
    of one load-step run's velocities ``v`` (a two-action cycle's pair)."""
    start = STEP_PERIOD + RECOVERY_PERIODS
    return float(np.mean(v[start:start + 2]))


def recovery(v: np.ndarray) -> tuple[float, float | None, bool | None]:
    """(steady velocity at the new load m/s, periods to reach ``RECOVERY_FRACTION`` of it (2-period
    mean), recovered within ``RECOVERY_PERIODS``) of one load-step run's velocities; None where the
    steady velocity is below ``MOVING_THRESHOLD``."""
    steady = float(np.mean(v[-AVERAGE_PERIODS:]))  # the episode's last periods
    if steady < MOVING_THRESHOLD:
        return steady, None, None
    pair = (v[STEP_PERIOD:-1] + v[STEP_PERIOD + 1:]) / 2.0
    reached = np.flatnonzero(pair >= RECOVERY_FRACTION * steady)
    periods = float(reached[0]) if reached.size else float("inf")
    return steady, periods, bool(recovery_window(v) >= RECOVERY_FRACTION * steady)


def candidate_drives(codebook: np.ndarray | None) -> np.ndarray:
    """The drives ``fastest_recovery`` tries, (n, 2, 5) Box actions: each row of ``codebook`` (N, 5) held,
    and each pair of rows (2 i, 2 i + 1) as a two-action cycle (a ``teacher.DriveTable``'s drives); none
    without a codebook."""
    if codebook is None:
        return np.zeros((0, 2, 5))
    rows = np.asarray(codebook, dtype=np.float64)
    held = np.repeat(rows[:, None, :], 2, axis=1)
    cycles = rows[:len(rows) // 2 * 2].reshape(-1, 2, 5)
    return np.concatenate([held, cycles])


def fastest_recovery(drives: np.ndarray, full_policy, d: dict) -> float:
    """The highest ``recovery_window`` velocity (m/s) any of ``drives`` (n, 2, 5) reaches when played from
    the step on, from the state ``full_policy`` (told the hidden values) leaves at the step of the
    load-step episode ``d`` (a ``draw_hidden`` draw with ``step_cargo_mass``); -inf without drives."""
    step = (STEP_PERIOD, d["step_cargo_mass"])
    env, obs = rollout_env(full_policy, d["k"], d["cargo_mass"], STEP_EPISODE_PERIODS, step,
                           drive=drive_of(full_policy), friction_coefficient=d["friction_coefficient"],
                           base_friction_coefficient=d["base_friction_coefficient"])
    act = actions_of(full_policy)
    for _ in range(STEP_PERIOD):
        obs, *_ = env.step(np.asarray(act(obs[None]), dtype=np.float32).reshape(5))
    best = -np.inf
    for pair in np.asarray(drives, dtype=np.float32):
        branch = copy.deepcopy(env)
        v = [branch.step(pair[t % 2])[4]["mean_velocity"] for t in range(RECOVERY_PERIODS + 2)]
        best = max(best, recovery_window(np.concatenate([np.zeros(STEP_PERIOD), v])))
    return float(best)


def recovery_record(series: np.ndarray, steps: list[dict], reach: np.ndarray) -> dict:
    """One drive's load-step figures from its velocities ``series`` (episodes, periods) m/s at the
    load-step episodes ``steps``, ``reach`` (episodes,) m/s the reachable bound there (``fastest_recovery``,
    already raised to every drive's own ``recovery_window``)."""
    rec = [recovery(v) for v in series]
    scored = [r for r in rec if r[2] is not None]
    up = [r for r, d in zip(rec, steps) if r[2] is not None and d["step_cargo_mass"] > d["cargo_mass"]]
    recoverable = [r for r, bound in zip(rec, reach) if r[2] is not None and bound >= RECOVERY_FRACTION * r[0]]
    return {
        "episodes_scored": len(scored),
        "recovered_within": int(sum(r[2] for r in scored)),
        "upward_steps_scored": len(up),
        "upward_recovered_within": int(sum(r[2] for r in up)),
        "recoverable_scored": len(recoverable),
        "recoverable_recovered_within": int(sum(r[2] for r in recoverable)),
        "share_recovered": float(np.mean([r[2] for r in scored])) if scored else None,
        "median_periods_to_recover": float(np.median([r[1] for r in scored])) if scored else None,
        "stalled_after_step": int(sum(r[0] <= 0.0 for r in rec)),
    }


__all__ = ["RECOVERY_FRACTION", "RECOVERY_PERIODS", "STEP_EPISODE_PERIODS", "STEP_PERIOD",
           "candidate_drives", "fastest_recovery", "recovery", "recovery_record", "recovery_window"]
