"""Action and observation spaces of MDRDrive: the action <-> waveform map and the observation layout."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core.params import check_range
from ..core.simulator import MIN_STEPS_PER_EDGE
from ..core.waveform import AxisWaveform, Waveform


def sample_range(name: str, value, low: float, high: float, high_open: bool = False) -> tuple[float, float]:
    """A float or a (low, high) pair as a validated (low, high) range for uniform sampling."""
    pair = tuple(value) if isinstance(value, (tuple, list, np.ndarray)) else (value, value)
    if len(pair) != 2:
        raise ValueError(f"{name}={value!r} must be a float or a (low, high) pair")
    for v in pair:
        check_range(name, float(v) if isinstance(v, (int, float, np.floating)) else v, low, high, high_open=high_open)
    if pair[0] > pair[1]:
        raise ValueError(f"{name}={value!r}: low must not exceed high")
    return float(pair[0]), float(pair[1])


def load_action_codebook(value) -> np.ndarray | None:
    """``MDRDrive-v0``'s ``action_codebook`` as a validated (N, 5) float64 table of Box actions, or None.

    ``value``: None, an array-like of N >= 2 rows of 5 finite actions in [-1, 1], or the path (str or
    ``os.PathLike``) of a ``.npy`` file holding one. Raises ``ValueError`` naming ``action_codebook``."""
    if value is None:
        return None
    import os

    if isinstance(value, (str, os.PathLike)):
        try:
            value = np.load(value, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise ValueError(f"action_codebook={str(value)!r} is not a readable .npy file ({type(e).__name__}: {e})") \
                from None
    try:
        table = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("action_codebook must be an (N, 5) array of actions, N >= 2, or a .npy file of one") from None
    if table.ndim != 2 or table.shape[1] != ActionMap.SIZE or len(table) < 2:
        raise ValueError(f"action_codebook of shape {table.shape} must have shape (N, {ActionMap.SIZE}), N >= 2")
    if not np.all(np.isfinite(table)) or np.abs(table).max() > 1.0:
        raise ValueError("action_codebook entries must be finite and in the allowed range [-1, 1]")
    table.setflags(write=False)
    return table


def codebook_rows(table: np.ndarray, indices) -> np.ndarray:
    """The Box actions (..., 5) that codebook ``indices`` (integers, any shape) select, as float32 like
    every action of the Box space (so a codebook index plays exactly what its row played as a Box
    action plays); ``ValueError`` for an index that is not an integer in [0, N)."""
    idx = np.asarray(indices)
    shown = idx.tolist()
    if idx.dtype.kind not in "iu":
        as_int = idx.astype(np.int64) if idx.dtype.kind == "f" and np.all(np.isfinite(idx)) else None
        if as_int is None or np.any(as_int != idx):
            raise ValueError(f"codebook action {shown!r} is not an integer index")
        idx = as_int
    if idx.size and (idx.min() < 0 or idx.max() >= len(table)):
        raise ValueError(f"codebook action {shown!r} is outside the allowed range [0, {len(table) - 1}]")
    return table[idx].astype(np.float32)


def shortest_edge(period: float, min_rise_fraction: float, max_rise_fraction: float) -> float:
    """The shortest rise or fall (s) an action box with these rise fractions allows on ``period`` (s)."""
    return min(min_rise_fraction, 1.0 - max_rise_fraction) * period


@dataclass(frozen=True)
class ActionMap:
    """Affine map of an action in [-1, 1]^5 to the next period's waveform (SI units).

    Rise fractions and the z phase are quantised to ``time_quantum`` (s) so every corner falls on
    a time step; times are rounded to 1e-12 s so the paper's waveform is reproduced exactly.

    The z phase is periodic: its action entry covers one period, from ``z_phase_origin`` (a fraction
    of the period, at action -1) round to the same phase again at +1. Where the box's two ends meet
    no waveform changes, but an action does jump from +1 to -1; ``z_phase_origin`` moves that seam
    (0, the default: the paper's phase 0 at both ends; 0.5: phase 0 at action 0, the seam half a
    period away). It is quantised to ``time_quantum`` as the phase is.
    """

    period: float = 2e-3
    x_amplitude_max: float = 30e-6
    z_amplitude_max: float = 6e-6
    min_rise_fraction: float = 0.05
    max_rise_fraction: float = 0.95
    time_step: float = 1e-6
    time_quantum: float = 1e-5
    z_phase_origin: float = 0.0

    SIZE = 5
    NAMES = ("x_amplitude", "x_rise_fraction", "z_amplitude", "z_rise_fraction", "z_phase")

    def __post_init__(self) -> None:
        check_range("x_amplitude_max", self.x_amplitude_max, 0.0, 1e-3, low_open=True)
        check_range("z_amplitude_max", self.z_amplitude_max, 0.0, 1e-3, low_open=True)
        check_range("min_rise_fraction", self.min_rise_fraction, 0.0, 0.5, low_open=True)
        check_range("max_rise_fraction", self.max_rise_fraction, self.min_rise_fraction, 1.0, high_open=True)
        check_range("period", self.period, 0.0, 1.0, low_open=True)
        check_range("z_phase_origin", self.z_phase_origin, 0.0, 1.0, high_open=True)
        check_range("time_quantum", self.time_quantum, 0.0, self.period, low_open=True)
        if not _divides(self.time_step, self.time_quantum):
            raise ValueError(f"time_quantum={self.time_quantum!r} must be a multiple of the numerics time step "
                             f"{self.time_step!r} s")
        if not _divides(self.time_quantum, self.period):
            raise ValueError(f"period={self.period!r} must be a multiple of time_quantum={self.time_quantum!r} s")
        edge = shortest_edge(self.period, self.min_rise_fraction, self.max_rise_fraction)
        if edge < MIN_STEPS_PER_EDGE * self.time_step * (1 - 1e-9):
            raise ValueError(f"min_rise_fraction/max_rise_fraction allow an edge of {edge!r} s, "
                             f"shorter than {MIN_STEPS_PER_EDGE} time steps of {self.time_step!r} s")
        n = self.quanta
        rise = [round(i * self.time_quantum, 12) for i in range(n + 1)]
        # derived constants of the map, computed once (to_params runs every env step)
        object.__setattr__(self, "_grid", (
            n, math.ceil(self.min_rise_fraction * n - 1e-9), math.floor(self.max_rise_fraction * n + 1e-9),
            self.max_rise_fraction - self.min_rise_fraction, rise, [round(self.period - r, 12) for r in rise],
            np.array(rise), int(round(self.z_phase_origin * n))))

    @property
    def quanta(self) -> int:
        """Time quanta per period."""
        return int(round(self.period / self.time_quantum))

    @property
    def steps_per_period(self) -> int:
        return int(round(self.period / self.time_step))

    def to_params(self, action) -> WaveformParams:
        """The waveform an action selects, as plain floats (SI units); clips to the box.

        Raises ``ValueError`` for a non-finite action or one of the wrong size.
        """
        values = np.asarray(action, dtype=np.float64).reshape(-1).tolist()
        if len(values) != self.SIZE:
            raise ValueError(f"action must have {self.SIZE} entries, got {len(values)}")
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"action {values} is not finite")
        u0, u1, u2, u3, u4 = ((min(max(v, -1.0), 1.0) + 1.0) / 2.0 for v in values)  # each in [0, 1]
        n, lo, hi, span, rise, fall, _, origin = self._grid
        ix = min(max(round((self.min_rise_fraction + u1 * span) * n), lo), hi)  # rise time in quanta
        iz = min(max(round((self.min_rise_fraction + u3 * span) * n), lo), hi)
        phase = ((int(round(u4 * n)) + origin) % n) / n
        return WaveformParams(u0 * self.x_amplitude_max, rise[ix], fall[ix], u2 * self.z_amplitude_max, rise[iz],
                              fall[iz], phase, self.period)

    def to_params_batch(self, actions) -> np.ndarray:
        """:meth:`to_params` of each row of ``actions`` (n, 5), vectorised and bit for bit equal, as an
        (n, 5) array: x amplitude (m), x rise time (s), z amplitude (m), z rise time (s), z phase (-).

        Raises ``ValueError`` if any action is not finite or a row has the wrong size.
        """
        a = np.asarray(actions, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != self.SIZE:
            raise ValueError(f"actions must have shape (n, {self.SIZE}), got {a.shape}")
        if a.shape[0] <= 4:  # a few rows: the scalar map is cheaper than a dozen NumPy calls
            return np.array([[p.x_amplitude, p.x_rise_time, p.z_amplitude, p.z_rise_time, p.z_phase]
                             for p in map(self.to_params, a)]).reshape(-1, 5)
        if not np.isfinite(a).all():
            raise ValueError(f"actions {a[~np.isfinite(a).all(axis=1)].tolist()} are not finite")
        u = (np.minimum(np.maximum(a, -1.0), 1.0) + 1.0) / 2.0  # np.clip, without its overhead
        n, *_, rise_table, origin = self._grid
        out = np.empty((a.shape[0], 5))
        out[:, 0] = u[:, 0] * self.x_amplitude_max
        out[:, 1] = rise_table[self._rise_quanta(u[:, 1])]
        out[:, 2] = u[:, 2] * self.z_amplitude_max
        out[:, 3] = rise_table[self._rise_quanta(u[:, 3])]
        out[:, 4] = ((np.rint(u[:, 4] * n).astype(np.int64) + origin) % n) / n
        return out

    def _rise_quanta(self, u: np.ndarray) -> np.ndarray:
        """The rise time in quanta (int64 array) that rise entries ``u`` in [0, 1] select, vectorised
        (``to_params`` rounds the same way, one action at a time)."""
        n, lo, hi, span, *_ = self._grid
        return np.minimum(np.maximum(np.rint((self.min_rise_fraction + u * span) * n), lo), hi).astype(np.int64)

    def quantum_centre(self, actions) -> np.ndarray:
        """Each action (..., 5) moved to the centre of the time quantum its rise fractions and z
        phase select, clipped to the box: the same waveform (``to_params`` is unchanged), with the
        most room for an error on either side. A rise entry in the first or last quantum becomes -1 or
        +1 (that quantum reaches the box's edge, and past the edge the action is clipped back to it),
        and so does a z phase in the quantum at the seam. Amplitudes are only clipped."""
        a = np.minimum(np.maximum(np.asarray(actions, dtype=np.float64), -1.0), 1.0)
        out = a.copy()
        u = (a + 1.0) / 2.0
        n, lo, hi, span, *_ = self._grid
        for entry in (1, 3):  # rise fractions
            index = self._rise_quanta(u[..., entry])
            centre = 2.0 * (index / n - self.min_rise_fraction) / span - 1.0
            out[..., entry] = np.where(index <= lo, -1.0, np.where(index >= hi, 1.0, centre))
        out[..., 4] = 2.0 * np.rint(u[..., 4] * n) / n - 1.0  # z phase: quantum 0 at -1, quantum n at +1
        return out

    def to_waveform(self, action) -> Waveform:
        """The waveform an action selects, as a validated :class:`Waveform`."""
        p = self.to_params(action)
        return Waveform(x=AxisWaveform(p.x_amplitude, p.x_rise_time, p.x_fall_time),
                        z=AxisWaveform(p.z_amplitude, p.z_rise_time, p.z_fall_time), z_phase=p.z_phase)

    def to_action(self, waveform: Waveform) -> np.ndarray:
        """The action that selects ``waveform`` (inverse of :meth:`to_waveform` on the grid)."""
        span = self.max_rise_fraction - self.min_rise_fraction
        n, *_, origin = self._grid
        u = np.array([
            waveform.x.amplitude / self.x_amplitude_max,
            (waveform.x.rise_time / waveform.period - self.min_rise_fraction) / span,
            waveform.z.amplitude / self.z_amplitude_max,
            (waveform.z.rise_time / waveform.period - self.min_rise_fraction) / span,
            (waveform.z_phase - origin / n) % 1.0,
        ])
        if np.any(u < -1e-9) or np.any(u > 1 + 1e-9):
            raise ValueError(f"waveform {waveform} lies outside the action box")
        return np.clip(2.0 * u - 1.0, -1.0, 1.0).astype(np.float32)

    def effort(self, x_amplitude, z_amplitude):
        """Electrical-energy proxy in [0, 1]: mean squared stroke relative to the actuator limits
        (amplitudes in m, floats or arrays)."""
        return 0.5 * ((x_amplitude / self.x_amplitude_max) ** 2 + (z_amplitude / self.z_amplitude_max) ** 2)


def shift_phase_origin(actions, from_origin: float, to_origin: float) -> np.ndarray:
    """``actions`` (..., 5) of an :class:`ActionMap` with ``z_phase_origin`` ``from_origin`` as the
    actions that select the same waveforms under ``to_origin`` (only the z phase entry changes)."""
    out = np.array(actions, dtype=np.float64)
    if from_origin == to_origin:
        return out
    u = (np.clip(out[..., 4], -1.0, 1.0) + 1.0) / 2.0
    out[..., 4] = 2.0 * ((u + from_origin - to_origin) % 1.0) - 1.0
    return out


class WaveformParams(NamedTuple):
    """One period's waveform as plain floats: amplitudes (m), rise/fall times (s), z phase (-), T (s)."""

    x_amplitude: float
    x_rise_time: float
    x_fall_time: float
    z_amplitude: float
    z_rise_time: float
    z_fall_time: float
    z_phase: float
    period: float


def _divides(small: float, big: float) -> bool:
    n = big / small
    return round(n) >= 1 and abs(n - round(n)) < 1e-6 * n


class ObservationLayout:
    """Names and bounds of the observation entries (see the env docstring for units and scales)."""

    NAMES = ("displacement", "mean_velocity", "end_velocity", "peak_tangential_force", "peak_normal_force",
             "prev_x_amplitude", "prev_x_rise_fraction", "prev_z_amplitude", "prev_z_rise_fraction",
             "prev_z_phase", "k", "load_over_friction", "load_over_10N", "episode_fraction")

    low = np.array([-100, -100, -100, 0, 0, -1, -1, -1, -1, -1, 0, 0, 0, 0], dtype=np.float32)
    high = np.array([100, 100, 100, 2, 2, 1, 1, 1, 1, 1, 1, 100, 100, 1], dtype=np.float32)
    #: Where each group of entries sits (read entries by name, never by hard-coded index).
    structure = {"dynamics": slice(0, 5), "previous_action": slice(5, 10), "k": slice(10, 11),
                 "load_over_friction": slice(11, 12), "load_over_10N": slice(12, 13),
                 "episode_fraction": slice(13, 14)}

    @classmethod
    def build(cls, dynamics, prev_action, k, load, friction_ref, episode_fraction) -> np.ndarray:
        """Observations of a batch, (n, 14) float32, clipped to the bounds.

        Args:
            dynamics: (n, 5): displacement, mean velocity, end velocity (already divided by their
                scales) and peak F_x / (mu F_ref), peak F_z / F_ref.
            prev_action: (n, 5) previous actions.
            k, load, friction_ref, episode_fraction: (n,) grading exponent, load F_m (N),
                ``mu F_ref`` (N), periods elapsed / max_periods.
        """
        obs = np.empty((len(k), cls.low.size))
        obs[:, :5] = dynamics
        obs[:, 5:10] = prev_action
        obs[:, 10] = k
        obs[:, 11] = load / friction_ref
        obs[:, 12] = load / 10.0
        obs[:, 13] = episode_fraction
        np.minimum(np.maximum(obs, cls.low, out=obs), cls.high, out=obs)  # np.clip, without its overhead
        return obs.astype(np.float32)


class PrivilegedLayout(ObservationLayout):
    """The full observation and the episode's friction ratio mu1 / mu (slider-base over
    indenter-slider), bounds [0, 10]: what a teacher is told when friction is drawn per episode. The
    full observation holds the load over mu F_ref, on which a drive depends at a given ratio, but not
    the ratio, which moves the best drive much; mu itself follows from the load entries and k, and
    the slider's motion does not tell mu and mu1 apart beyond their ratio (docs/adaptation.md)."""

    NAMES = ObservationLayout.NAMES + ("friction_ratio",)
    low = np.concatenate([ObservationLayout.low, np.zeros(1, dtype=np.float32)])
    high = np.concatenate([ObservationLayout.high, np.full(1, 10.0, dtype=np.float32)])
    structure = {**ObservationLayout.structure, "friction_ratio": slice(14, 15)}

    @staticmethod
    def ratio(friction) -> np.ndarray:
        """mu1 / mu of ``friction`` (..., 2) (mu, mu1), clipped to the entry's bounds [0, 10]."""
        friction = np.asarray(friction, dtype=np.float64)
        mu, mu1 = friction[..., 0], friction[..., 1]
        return np.clip(mu1 / np.maximum(mu, 1e-12), 0.0, 10.0)

    @classmethod
    def build(cls, dynamics, prev_action, k, load, friction_ref, episode_fraction, friction=None) -> np.ndarray:
        """:meth:`ObservationLayout.build`, then the ratio mu1 / mu of ``friction`` (n, 2): mu and mu1
        of each drive (-)."""
        full = ObservationLayout.build(dynamics, prev_action, k, load, friction_ref, episode_fraction)
        return np.concatenate([full, cls.ratio(friction)[:, None].astype(np.float32)], axis=1)


class SensorLayout:
    """The sensor observation: only what sensors on the drive measure, ``history`` periods deep
    (newest first), the actions that produced it, and the elapsed episode fraction.

    Per period: displacement / reward_scale, mean velocity and end velocity / (reward_scale / T),
    bounds [-100, 100]; with ``forces`` also the peak F_x / 10 N and peak F_z / 100 N (fixed scales:
    a scale from the contact would reveal k), bounds [0, 100]; with ``trace_samples`` N > 0 also the
    slider's position at N evenly spaced times of the period (the last at its end), relative to its
    position at the period's start, / reward_scale, bounds [-100, 100]. Then the 5 action entries of
    each of the ``history`` periods, [-1, 1]; last the fraction of the episode elapsed, [0, 1].
    """

    MEASURED = ("displacement", "mean_velocity", "end_velocity")
    FORCES = ("peak_tangential_force", "peak_normal_force")
    FORCE_SCALES = (10.0, 100.0)  # N

    def __init__(self, history: int, forces: bool = False, trace_samples: int = 0):
        if isinstance(history, bool) or not isinstance(history, (int, np.integer)) or not 1 <= history <= 64:
            raise ValueError(f"history={history!r} is outside the allowed range [1, 64]")
        if isinstance(trace_samples, bool) or not isinstance(trace_samples, (int, np.integer)) or trace_samples < 0:
            raise ValueError(f"trace_samples={trace_samples!r} is outside the allowed range [0, inf)")
        self.history, self.forces, self.trace_samples = int(history), bool(forces), int(trace_samples)
        positions = tuple(f"position_{i}/{self.trace_samples}" for i in range(1, self.trace_samples + 1))
        self.per_period = self.MEASURED + (self.FORCES if self.forces else ()) + positions
        names, low, high = [], [], []
        for lag in range(self.history):
            for name in self.per_period:
                names.append(f"{name}[t-{lag}]")
                low.append(0.0 if name in self.FORCES else -100.0)
                high.append(100.0)
        for lag in range(self.history):
            names += [f"{name}[t-{lag}]" for name in ActionMap.NAMES]
            low += [-1.0] * ActionMap.SIZE
            high += [1.0] * ActionMap.SIZE
        names.append("episode_fraction")
        low.append(0.0)
        high.append(1.0)
        self.names = tuple(names)
        self.low = np.array(low, dtype=np.float32)
        self.high = np.array(high, dtype=np.float32)

    @property
    def structure(self) -> dict[str, slice]:
        """Where each group of entries sits: ``measured`` (history x per-period entries, newest
        first; ``per_period`` names them), ``actions`` (history x 5), ``episode_fraction``."""
        m = self.history * len(self.per_period)
        a = self.history * ActionMap.SIZE
        return {"measured": slice(0, m), "actions": slice(m, m + a), "episode_fraction": slice(m + a, m + a + 1)}
