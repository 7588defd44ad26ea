"""The sensor observation's memory: the last periods' measurements and actions (spaces.SensorLayout)."""

from __future__ import annotations

import numpy as np

from .spaces import ActionMap, SensorLayout


class SensorHistory:
    """The last ``layout.history`` periods, newest first, as the sensor observation."""

    def __init__(self, layout: SensorLayout):
        self.layout = layout
        self.measured = np.zeros((layout.history, len(layout.per_period)))
        self.actions = np.zeros((layout.history, ActionMap.SIZE))

    def reset(self) -> None:
        """Nothing measured yet: zeros, as the full observation after reset."""
        self.measured[:] = 0.0
        self.actions[:] = 0.0

    def push(self, displacement: float, mean_velocity: float, end_velocity: float, peak_fx: float, peak_fz: float,
             action: np.ndarray, reward_scale: float, period: float) -> None:
        """Add one period: SI values (m, m/s, N) and the action played (clipped to the box)."""
        self.measured[1:] = self.measured[:-1]
        self.actions[1:] = self.actions[:-1]
        v_scale = reward_scale / period
        row = [displacement / reward_scale, mean_velocity / v_scale, end_velocity / v_scale]
        if self.layout.forces:
            row += [peak_fx / SensorLayout.FORCE_SCALES[0], peak_fz / SensorLayout.FORCE_SCALES[1]]
        self.measured[0] = row
        self.actions[0] = action

    def observation(self, episode_fraction: float) -> np.ndarray:
        """The observation (float32, clipped to the layout's bounds)."""
        obs = np.concatenate([self.measured.ravel(), self.actions.ravel(), [episode_fraction]])
        return np.minimum(np.maximum(obs, self.layout.low), self.layout.high).astype(np.float32)
