"""A learning curve: a live model's steady velocity at fixed points every so many steps (the
evaluation protocol of ``mdr_drive_agents.protocol``: 30 periods closed loop, the mean of the last 10,
runaways marked)."""

from __future__ import annotations

import time

import numpy as np

from ..policy import Policy
from ..protocol import policy_velocity


def live_policy(model, algo: str, env_kwargs: dict, hyperparameters: dict | None = None) -> Policy:
    """A model being trained as a ``Policy`` of the protocol: its training env's observation
    normalisation (the current statistics, not updated by playing), the env keywords it acts in and
    its hyperparameters (a two-period cycle's ``action_cycle``)."""
    from stable_baselines3.common.vec_env import VecNormalize

    venv = model.get_env()
    normalize = venv.normalize_obs if isinstance(venv, VecNormalize) and venv.norm_obs else None
    return Policy(model, normalize, run={"algo": algo, "env_kwargs": dict(env_kwargs),
                                         "hyperparameters": dict(hyperparameters or {})})


def model_velocity(model, algo: str, env_kwargs: dict, points, hyperparameters: dict | None = None) -> np.ndarray:
    """Steady velocities (m/s; NaN a runaway) of a live model at ``points`` ((k, cargo mass), ...)."""
    return policy_velocity(live_policy(model, algo, env_kwargs, hyperparameters), list(points), mark_runaway=True)


def curve_steps(total: int, count: int) -> list[int]:
    """The steps a curve of ``count`` evaluations over ``total`` steps is taken at: evenly spaced, the
    last at ``total``."""
    return sorted({max(1, round(total * (i + 1) / count)) for i in range(count)})


def learning_curve_callback(algo: str, env_kwargs: dict, points, at_steps: list[int],
                            hyperparameters: dict | None = None):
    """An SB3 callback that plays the model at ``points`` when its step count first reaches each of
    ``at_steps`` (and at the end of training if it ends short of the last); ``.curve`` is then
    [(steps, seconds of training so far, evaluations excluded, velocities), ...]."""
    from stable_baselines3.common.callbacks import BaseCallback

    class LearningCurve(BaseCallback):
        def __init__(self):
            super().__init__()
            self.pending = sorted(at_steps)
            self.curve: list[tuple[int, float, np.ndarray]] = []
            self.start = self.evaluating = 0.0

        def _on_training_start(self) -> None:
            self.start, self.evaluating = time.perf_counter(), 0.0

        def _evaluate(self) -> None:
            t = time.perf_counter()
            v = model_velocity(self.model, algo, env_kwargs, points, hyperparameters)
            self.curve.append((int(self.num_timesteps), round(t - self.start - self.evaluating, 3), v))
            self.evaluating += time.perf_counter() - t

        def _on_step(self) -> bool:
            if not self.pending or self.num_timesteps < self.pending[0]:
                return True
            while self.pending and self.num_timesteps >= self.pending[0]:
                self.pending.pop(0)
            self._evaluate()
            return True

        def _on_training_end(self) -> None:  # the last point, when the run ends short of it
            if self.pending and (not self.curve or self.curve[-1][0] != self.num_timesteps):
                self._evaluate()
                self.pending = []

    return LearningCurve()


__all__ = ["curve_steps", "learning_curve_callback", "live_policy", "model_velocity"]
