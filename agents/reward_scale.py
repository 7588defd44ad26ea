"""Rewards in units of the best open-loop drive's velocity at each episode's (k, load).

A generalist policy sees every (k, load) in one batch, and near the critical load the slider moves
hundreds of times slower than unloaded: at k = 0.6, the best cycle found makes 0.035 mm/s at 1.25
times the trapezoid's critical load, and a push period 0.05 off its best z rise fraction costs
0.028 mm/s of it (``scripts/cycle_limit.py``), a return difference of 0.1 over a 50-period episode,
where an unloaded episode returns about 65. PPO hardly sees whether its drive near stall is right.

``TeacherRewardFactor`` gives every episode one factor, by which ``agents.vec_env.BatchedVecEnv``
multiplies all its rewards: ``REFERENCE_VELOCITY / max(v_teacher(k, load), floor)``, where
``v_teacher`` is the CMA-ES teacher's steady velocity (``agents/teacher.py``) interpolated at the
episode's k and load (observation entries 10 and 11, read when the episode starts). It is off by
default; ``teacher_velocity_floor`` in the training config (with a ``cma:`` warm start) turns it
on. A positive constant per episode leaves the best drive of every (k, load) unchanged; it only
changes how much each episode weighs in the policy gradient. The floor caps the factor (loads no
drive moves get the floor's), and the env's reward floor is applied again after scaling.
"""

from __future__ import annotations

import numpy as np

#: Velocity (m/s) that maps to a factor of 1: about the trapezoid's unloaded velocity.
REFERENCE_VELOCITY = 15e-3
#: Observation entries of k and of the load / (mu F_ref), and their length scales for interpolation.
K_ENTRY, LOAD_ENTRY = 10, 11
K_SCALE, LOAD_SCALE = 0.05, 0.02


def coordinates(obs: np.ndarray) -> np.ndarray:
    """(n, 2) coordinates (k / K_SCALE, load ratio / LOAD_SCALE) of observations (n, 14): the metric in
    which the teacher's points are neighbours (here, in the teacher's exchange and in its lookup)."""
    obs = np.asarray(obs)
    return np.c_[obs[:, K_ENTRY] / K_SCALE, obs[:, LOAD_ENTRY] / LOAD_SCALE]


def teacher_coordinates(data: dict) -> np.ndarray:
    """``coordinates`` of the teacher's points, from its rollouts' first observations (rows 0 ... n - 1)."""
    return coordinates(np.asarray(data["obs"])[:len(data["points"])])


class TeacherVelocity:
    """The teacher's steady velocity (m/s, >= 0) at any (k, load ratio), by inverse-distance weighting
    of its ``neighbours`` nearest points in (k / K_SCALE, load ratio / LOAD_SCALE)."""

    def __init__(self, data: dict, neighbours: int = 4):
        n = len(data["points"])
        self.xy = teacher_coordinates(data)
        self.velocity = np.maximum(np.asarray(data["velocities"], dtype=np.float64), 0.0)
        self.neighbours = min(neighbours, n)

    def __call__(self, k, load_ratio) -> np.ndarray:
        q = np.c_[np.atleast_1d(k) / K_SCALE, np.atleast_1d(load_ratio) / LOAD_SCALE]
        d = np.linalg.norm(q[:, None, :] - self.xy[None, :, :], axis=2)
        idx = np.argsort(d, axis=1)[:, :self.neighbours]
        w = 1.0 / np.maximum(np.take_along_axis(d, idx, axis=1), 1e-9) ** 2
        return (w * self.velocity[idx]).sum(axis=1) / w.sum(axis=1)


class TeacherRewardFactor:
    """``obs -> REFERENCE_VELOCITY / max(v_teacher, floor)`` per env, from episodes' first observations.

    Args:
        data: the teacher (``agents.teacher.build``'s dict or its .npz).
        floor: smallest velocity (m/s) the factor divides by; caps the factor.
    """

    def __init__(self, data: dict, floor: float):
        if not floor > 0.0:
            raise ValueError(f"floor={floor!r} must be > 0 m/s")
        self.teacher = TeacherVelocity(data)
        self.floor = float(floor)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        v = self.teacher(obs[:, K_ENTRY], obs[:, LOAD_ENTRY])
        return (REFERENCE_VELOCITY / np.maximum(v, self.floor)).astype(np.float32)
