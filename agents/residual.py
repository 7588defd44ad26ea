"""Residual policies on top of the CMA-ES teacher: the policy corrects the teacher's drive instead of replacing it.

The teacher, played as a lookup (the drive of the teacher's point nearest to the episode's (k,
load), in the phase that follows the previous action), carries 1.29-1.52 times the trapezoid's
critical load at every k of the benchmark grid (``scripts/teacher_lookup.py``), more than the
policies cloned from it at k >= 0.3, which blur the two-waveform cycles near stall; it still has
windows where neighbouring points' drives differ (``agents.lookup_refine`` adds teacher points
there). A residual policy gets the lookup's action as 5 extra observations and plays
``clip(lookup + residual_scale * g * a, -1, 1)``: it starts as the lookup (mean a = 0) and PPO
repairs what the lookup gets wrong (residual reinforcement learning, Johannink et al. 2019;
Silver et al. 2018). ``g`` is 1, or with ``residual_gate_velocity`` the played teacher point's
velocity over it, at most 1 (``TeacherLookup.weight``): near stall the teacher's drive is played
as it is. ``residual_scale`` in the training config turns it on (with a ``cma:`` warm start;
``agents/configs/ppo_residual.yaml``); the lookup table is saved beside the model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnvWrapper

from .reward_scale import coordinates, teacher_coordinates

PREV_ACTION = slice(5, 10)  # observation entries of the previous action
LOOKUP_FILE = "teacher_lookup.npz"


def moving_teacher(data: dict) -> dict:
    """The teacher without its loaded points whose drive does not move their load (CMA-ES found
    nothing with a positive velocity there): played at a lighter load nearby, such a drive makes a
    window of stalled loads below the neighbouring drives' critical load. Observations and targets
    (row t n + i for period t of point i) keep the same layout."""
    points, velocities = np.asarray(data["points"]), np.asarray(data["velocities"])
    keep = (points[:, 1] == 0.0) | (velocities > 0.0)
    if keep.all():
        return data
    n = len(points)
    rows = np.tile(keep, len(data["obs"]) // n)
    out = {**data, "points": points[keep], "actions": np.asarray(data["actions"])[keep], "velocities": velocities[keep]}
    out.update(obs=np.asarray(data["obs"])[rows], targets=np.asarray(data["targets"])[rows])
    return out


class TeacherLookup:
    """``obs (n, 14) -> actions (n, 5)``: the nearest teacher point's drive, phase from the previous action.

    Nearest in ``agents.reward_scale.coordinates`` among the points whose drive moves their load
    (``moving_teacher``): among the loaded points for a loaded drive and among the unloaded points
    without load: the best unloaded drive glides (the
    base friction scales with the contact force, not the slider's weight) and goes backwards under
    even a tenth of the trapezoid's critical load. After a period close to the drive's first action
    it plays the second, else the first (and the first in an episode's first period, whose
    observation has no previous action)."""

    def __init__(self, xy: np.ndarray, drives: np.ndarray, velocities: np.ndarray | None = None,
                 gate_velocity: float | None = None):
        self.xy = np.asarray(xy, dtype=np.float64)  # (n, 2) coordinates of the teacher's points
        self.drives = np.asarray(drives, dtype=np.float64)  # (n, 2, 5)
        if gate_velocity is not None and (velocities is None or not gate_velocity > 0.0):
            raise ValueError(f"gate_velocity={gate_velocity!r} must be > 0 m/s and needs the teacher's velocities")
        self.velocities = None if velocities is None else np.asarray(velocities, dtype=np.float64)  # (n,) m/s
        self.gate_velocity = gate_velocity

    @classmethod
    def from_teacher(cls, data: dict, gate_velocity: float | None = None) -> "TeacherLookup":
        data = moving_teacher(data)
        return cls(teacher_coordinates(data), data["actions"], data["velocities"], gate_velocity)

    def save(self, path: str | Path) -> None:
        extra = {} if self.gate_velocity is None else {"velocities": self.velocities,
                                                       "gate_velocity": self.gate_velocity}
        np.savez_compressed(path, xy=self.xy, drives=self.drives, **extra)

    @classmethod
    def load(cls, path: str | Path) -> "TeacherLookup":
        with np.load(path) as f:
            if "gate_velocity" in f.files:
                return cls(f["xy"], f["drives"], f["velocities"], float(f["gate_velocity"]))
            return cls(f["xy"], f["drives"])

    def nearest(self, obs: np.ndarray) -> np.ndarray:
        """Index of the teacher point whose drive is played at each observation (n,)."""
        q = coordinates(np.asarray(obs))
        d = np.linalg.norm(q[:, None] - self.xy[None], axis=2)
        loaded = self.xy[:, 1] > 0.0
        if loaded.any() and (~loaded).any():  # a drive found without load is not used with one, and vice versa
            d[(q[:, 1] > 0.0)[:, None] != loaded[None, :]] = np.inf
        return np.argmin(d, axis=1)

    def play(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the lookup's actions (n, 5), ``weight``s (n, 1)), with one nearest-point search."""
        obs = np.asarray(obs)
        idx = self.nearest(obs)
        drive = self.drives[idx]
        prev = obs[:, PREV_ACTION]
        after_first = np.abs(prev - drive[:, 0]).sum(1) < np.abs(prev - drive[:, 1]).sum(1)
        after_first &= np.abs(prev).sum(1) > 0
        action = np.where(after_first[:, None], drive[:, 1], drive[:, 0]).astype(np.float32)
        return action, self._weight_of(idx)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.play(obs)[0]

    def weight(self, obs: np.ndarray) -> np.ndarray:
        """How much of the residual is played (n, 1): 1, or with a ``gate_velocity`` the played teacher
        point's velocity / ``gate_velocity``, clipped to [0, 1]. Near stall the slider moves hundreds
        of times slower than unloaded, the reward hardly tells a right drive from one 0.02 off, and
        PPO's residual drifts (it lost 1-2 % of the lookup's critical load at k >= 0.4); the gate
        keeps the teacher's drive there and lets PPO change the drives that move fast."""
        return self.play(obs)[1]

    def _weight_of(self, idx: np.ndarray) -> np.ndarray:
        if self.gate_velocity is None:
            return np.ones((len(idx), 1))
        return np.clip(self.velocities[idx] / self.gate_velocity, 0.0, 1.0)[:, None]


def augment(obs: np.ndarray, lookup: TeacherLookup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(observations with the lookup's action appended (n, 19), the lookup's action (n, 5), the
    residual's weight (n, 1), ``TeacherLookup.weight``)."""
    base, weight = lookup.play(obs)
    return np.concatenate([obs, base], axis=1).astype(np.float32), base, weight


def env_action(base: np.ndarray, residual: np.ndarray, scale) -> np.ndarray:
    """The action played: the lookup's plus ``scale`` (a number, or (n, 1) per env) times the residual,
    clipped to the box."""
    return np.clip(base + scale * np.clip(residual, -1.0, 1.0), -1.0, 1.0).astype(np.float32)


def residual_data(data: dict, lookup: TeacherLookup, scale: float) -> dict:
    """The teacher's (observation, action) pairs in the residual policy's terms: augmented
    observations and the residual that turns the lookup's action into the teacher's (clipped; 0
    where the gate plays none of the residual)."""
    obs, base, weight = augment(np.asarray(data["obs"]), lookup)
    w = scale * weight
    diff = np.asarray(data["targets"]) - base
    targets = np.where(w > 0.0, np.clip(diff / np.maximum(w, 1e-12), -1.0, 1.0), 0.0).astype(np.float32)
    return {**data, "obs": obs, "targets": targets}


class TeacherResidual(VecEnvWrapper):
    """SB3 VecEnv wrapper: observations gain the lookup's action, actions are residuals on it."""

    def __init__(self, venv, lookup: TeacherLookup, scale: float):
        if not scale > 0.0:
            raise ValueError(f"residual_scale={scale!r} must be > 0")
        low = np.concatenate([venv.observation_space.low, -np.ones(5, np.float32)])
        high = np.concatenate([venv.observation_space.high, np.ones(5, np.float32)])
        super().__init__(venv, observation_space=spaces.Box(low, high, dtype=np.float32))
        self.lookup, self.scale = lookup, float(scale)
        self._base = self._weight = None

    def _augment(self, obs: np.ndarray) -> np.ndarray:
        obs, self._base, self._weight = augment(obs, self.lookup)
        return obs

    def reset(self) -> np.ndarray:
        return self._augment(self.venv.reset())

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(env_action(self._base, actions, self.scale * self._weight))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = augment(info["terminal_observation"][None], self.lookup)[0][0]
        return self._augment(obs), rewards, dones, infos
