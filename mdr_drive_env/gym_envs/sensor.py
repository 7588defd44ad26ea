"""The sensor observation: the tiers of sensors a drive may have, and the memory of the last periods'
measurements and actions (spaces.SensorLayout)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.params import check_range
from .spaces import ActionMap, SensorLayout

#: The sensor tiers, from the least to the most a drive measures.
SENSOR_TIERS = ("encoder", "trace", "self-sensing")
#: Position samples per period of the ``trace`` tier: a laboratory interferometer or capacitive
#: sensor at about 20 kHz takes 40 samples in the 2 ms period (an integrated optical encoder at
#: about 1 kHz would take two).
DEFAULT_TRACE_SAMPLES = 40
#: Position noise of each sample (m), Gaussian: a laboratory interferometer's few nanometres.
DEFAULT_ENCODER_NOISE = 2e-9
#: Noise of the self-sensed peak forces, Gaussian, relative to the force: piezo self-sensing (the
#: drive's own charge) is documented to about 1-2 %.
DEFAULT_FORCE_NOISE = 0.02


@dataclass(frozen=True)
class SensorTier:
    """What the drive's sensors measure each period (``MDRDriveEnv(sensor_tier=...)``).

    Attributes:
        name: ``"encoder"``: the position encoder's per-period summaries (displacement, mean and end
            velocity), noise-free, as an integrated encoder reports them; ``"trace"``: also
            ``trace_samples`` position samples through the period, each with Gaussian noise
            ``encoder_noise`` (m); ``"self-sensing"``: the trace and the peak tangential and normal
            contact forces the piezo senses from its own charge, each with Gaussian noise
            ``force_noise`` times the force (-).
        trace_samples: position samples per period, in [1, 1000] (at most the period's time steps).
        encoder_noise: standard deviation of each position sample (m), in [0, 1e-6].
        force_noise: relative standard deviation of each sensed force (-), in [0, 1].
    """

    name: str = "encoder"
    trace_samples: int = DEFAULT_TRACE_SAMPLES
    encoder_noise: float = DEFAULT_ENCODER_NOISE
    force_noise: float = DEFAULT_FORCE_NOISE

    def __post_init__(self) -> None:
        if self.name not in SENSOR_TIERS:
            raise ValueError(f"sensor_tier={self.name!r} is not one of {list(SENSOR_TIERS)}")
        n = self.trace_samples
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 1000:
            raise ValueError(f"trace_samples={n!r} is outside the allowed range [1, 1000]")
        check_range("encoder_noise", self.encoder_noise, 0.0, 1e-6)
        check_range("force_noise", self.force_noise, 0.0, 1.0)

    @property
    def traced(self) -> bool:
        """True when the tier samples the position through the period."""
        return self.name != "encoder"

    @property
    def noisy(self) -> bool:
        """True when the tier's measurements carry noise (drawn from the env's seeded stream)."""
        return self.traced and (self.encoder_noise > 0 or (self.name == "self-sensing" and self.force_noise > 0))


def sample_positions(trace: np.ndarray, displacement: float, period: float, samples: int) -> np.ndarray:
    """The slider's position (m) at ``samples`` evenly spaced times of the period a ``trace`` (rows of
    ``kernel.TRACE_COLUMNS``, one per time step) covers, the last at its end, relative to its
    position at the period's start (its end minus ``displacement``)."""
    t, x = trace[:, 0], trace[:, 3]
    times = t[-1] - period + period * np.arange(1, samples + 1) / samples
    return np.interp(times, t, x) - (x[-1] - displacement)


class SensorHistory:
    """The last ``layout.history`` periods, newest first, as the sensor observation of ``tier``."""

    def __init__(self, layout: SensorLayout, tier: SensorTier | None = None):
        self.layout, self.tier = layout, tier or SensorTier()
        self.measured = np.zeros((layout.history, len(layout.per_period)))
        self.actions = np.zeros((layout.history, ActionMap.SIZE))

    def reset(self) -> None:
        """Nothing measured yet: zeros, as the full observation after reset."""
        self.measured[:] = 0.0
        self.actions[:] = 0.0

    def push(self, displacement: float, mean_velocity: float, end_velocity: float, peak_fx: float, peak_fz: float,
             action: np.ndarray, reward_scale: float, period: float, positions: np.ndarray | None = None,
             rng: np.random.Generator | None = None) -> None:
        """Add one period: SI values (m, m/s, N), the action played (clipped to the box) and, for a
        traced tier, the positions through it (m, ``sample_positions``); ``rng`` draws the tier's
        noise (needed when it has any)."""
        self.measured[1:] = self.measured[:-1]
        self.actions[1:] = self.actions[:-1]
        v_scale = reward_scale / period
        row = [displacement / reward_scale, mean_velocity / v_scale, end_velocity / v_scale]
        if self.layout.forces:
            forces = np.array([peak_fx, peak_fz])
            if self.tier.name == "self-sensing" and self.tier.force_noise > 0:
                forces = np.maximum(forces * (1.0 + rng.normal(0.0, self.tier.force_noise, 2)), 0.0)
            row += list(forces / SensorLayout.FORCE_SCALES)
        if self.layout.trace_samples:
            if self.tier.encoder_noise > 0:
                positions = positions + rng.normal(0.0, self.tier.encoder_noise, positions.shape)
            row += list(positions / reward_scale)
        self.measured[0] = row
        self.actions[0] = action

    def observation(self, episode_fraction: float) -> np.ndarray:
        """The observation (float32, clipped to the layout's bounds)."""
        obs = np.concatenate([self.measured.ravel(), self.actions.ravel(), [episode_fraction]])
        return np.minimum(np.maximum(obs, self.layout.low), self.layout.high).astype(np.float32)


__all__ = ["DEFAULT_ENCODER_NOISE", "DEFAULT_FORCE_NOISE", "DEFAULT_TRACE_SAMPLES", "SENSOR_TIERS", "SensorHistory",
           "SensorTier", "sample_positions"]
