"""A curriculum over the load for ``mdr-drive train`` (the ``load_curriculum`` key): episodes start
light and grow heavier, as the teacher found its heavy-load drives by continuation from light ones.

With ``load_curriculum: f`` (0 < f <= 1), the upper end of the training env's load-ratio range grows
linearly from a quarter of the way up the range to its full value over the first fraction ``f`` of
the run's steps; the rest of the run draws from the whole range.
"""

from __future__ import annotations

#: Where the upper end of the load range starts, as a fraction of the way up the range.
START_FRACTION = 0.25


def load_range_at(progress: float, full: tuple[float, float], fraction: float) -> tuple[float, float]:
    """The load-ratio range at ``progress`` (0 ... 1 of the run) of a curriculum over ``fraction`` of
    it, ``full`` the whole range."""
    low, high = full
    grown = 1.0 if fraction <= 0 else min(1.0, START_FRACTION + (1.0 - START_FRACTION) * progress / fraction)
    return low, low + (high - low) * grown


def load_curriculum_callback(fraction: float, total_steps: int):
    """An SB3 callback that sets the training env's load range before each rollout (the env must be
    ``BatchedVecEnv``'s, under any wrappers)."""
    from stable_baselines3.common.callbacks import BaseCallback

    from ..vec_env import BatchedVecEnv

    class LoadCurriculum(BaseCallback):
        def _on_training_start(self) -> None:
            env = self.model.get_env()
            while not isinstance(env, BatchedVecEnv):
                if not hasattr(env, "venv"):
                    raise ValueError("load_curriculum needs the batched env: the full observation without load steps")
                env = env.venv
            self.env, self.full = env, env.load_ratio_range
            if self.full is None:
                raise ValueError("load_curriculum needs a load_ratio range in env_kwargs (not a cargo_mass range)")
            self._on_rollout_start()

        def _on_rollout_start(self) -> None:
            self.env.set_load_ratio_range(*load_range_at(self.num_timesteps / total_steps, self.full, fraction))

        def _on_step(self) -> bool:
            return True

    return LoadCurriculum()


__all__ = ["START_FRACTION", "load_curriculum_callback", "load_range_at"]
