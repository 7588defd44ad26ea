"""Residual policies on top of the CMA-ES teacher: the policy corrects the teacher's drive instead of replacing it.

The teacher, played as a lookup (the drive of the teacher's point nearest to the episode's (k,
load), in the phase that follows the previous action), carries 1.29-1.52 times the trapezoid's
critical load at every k of the benchmark grid (``scripts/teacher_lookup.py``), more than the
policies cloned from it at k >= 0.3, which blur the two-waveform cycles near stall; it still has
windows where neighbouring points' drives differ. A residual policy gets the lookup's
action as 5 extra observations and plays ``clip(lookup + residual_scale * a, -1, 1)``: it starts
as the lookup (mean a = 0) and PPO repairs what the lookup gets wrong (residual reinforcement
learning, Johannink et al. 2019; Silver et al. 2018). ``residual_scale`` in the training config
turns it on (with a ``cma:`` warm start); the lookup table is saved beside the model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnvWrapper

from .reward_scale import coordinates, teacher_coordinates

PREV_ACTION = slice(5, 10)  # observation entries of the previous action
LOOKUP_FILE = "teacher_lookup.npz"


class TeacherLookup:
    """``obs (n, 14) -> actions (n, 5)``: the nearest teacher point's drive, phase from the previous action.

    Nearest in ``agents.reward_scale.coordinates``, among the teacher's loaded points for a
    loaded drive and among its unloaded points without load: the best unloaded drive glides (the
    base friction scales with the contact force, not the slider's weight) and goes backwards under
    even a tenth of the trapezoid's critical load. After a period close to the drive's first action
    it plays the second, else the first (and the first in an episode's first period, whose
    observation has no previous action)."""

    def __init__(self, xy: np.ndarray, drives: np.ndarray):
        self.xy = np.asarray(xy, dtype=np.float64)  # (n, 2) coordinates of the teacher's points
        self.drives = np.asarray(drives, dtype=np.float64)  # (n, 2, 5)

    @classmethod
    def from_teacher(cls, data: dict) -> "TeacherLookup":
        return cls(teacher_coordinates(data), data["actions"])

    def save(self, path: str | Path) -> None:
        np.savez_compressed(path, xy=self.xy, drives=self.drives)

    @classmethod
    def load(cls, path: str | Path) -> "TeacherLookup":
        with np.load(path) as f:
            return cls(f["xy"], f["drives"])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs)
        q = coordinates(obs)
        d = np.linalg.norm(q[:, None] - self.xy[None], axis=2)
        loaded = self.xy[:, 1] > 0.0
        if loaded.any() and (~loaded).any():  # a drive found without load is not used with one, and vice versa
            d[(q[:, 1] > 0.0)[:, None] != loaded[None, :]] = np.inf
        drive = self.drives[np.argmin(d, axis=1)]
        prev = obs[:, PREV_ACTION]
        after_first = np.abs(prev - drive[:, 0]).sum(1) < np.abs(prev - drive[:, 1]).sum(1)
        after_first &= np.abs(prev).sum(1) > 0
        return np.where(after_first[:, None], drive[:, 1], drive[:, 0]).astype(np.float32)


def augment(obs: np.ndarray, lookup: TeacherLookup) -> tuple[np.ndarray, np.ndarray]:
    """(observations with the lookup's action appended (n, 19), the lookup's action (n, 5))."""
    base = lookup(obs)
    return np.concatenate([obs, base], axis=1).astype(np.float32), base


def env_action(base: np.ndarray, residual: np.ndarray, scale: float) -> np.ndarray:
    """The action played: the lookup's plus ``scale`` times the residual, clipped to the box."""
    return np.clip(base + scale * np.clip(residual, -1.0, 1.0), -1.0, 1.0).astype(np.float32)


def residual_data(data: dict, lookup: TeacherLookup, scale: float) -> dict:
    """The teacher's (observation, action) pairs in the residual policy's terms: augmented
    observations and the residual that turns the lookup's action into the teacher's (clipped)."""
    obs, base = augment(np.asarray(data["obs"]), lookup)
    targets = np.clip((np.asarray(data["targets"]) - base) / scale, -1.0, 1.0).astype(np.float32)
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
        self._base = None

    def reset(self) -> np.ndarray:
        obs, self._base = augment(self.venv.reset(), self.lookup)
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(env_action(self._base, actions, self.scale))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = augment(info["terminal_observation"][None], self.lookup)[0][0]
        obs, self._base = augment(obs, self.lookup)
        return obs, rewards, dones, infos
