"""Indenter waveforms: the paper's asymmetric triangle per axis (Eqs. 17-18), with a z phase.

Within one drive period the kernel receives each axis as piecewise-linear knots ``(t_i, v_i)``
with ``t_0 = 0`` and ``t_last = T``. :func:`period_knots` builds them, and makes a change of
waveform continuous at the period boundary (see its docstring).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .params import check_range, store_floats


@dataclass(frozen=True)
class AxisWaveform:
    """Asymmetric triangle on one axis: 0 -> amplitude in ``rise_time``, back to 0 in ``fall_time``.

    Attributes:
        amplitude: A_max (m), >= 0.
        rise_time: t1 (s), > 0.
        fall_time: t2 (s), > 0. The period is ``t1 + t2``.
    """

    amplitude: float
    rise_time: float
    fall_time: float

    def __post_init__(self) -> None:
        store_floats(self, "amplitude", "rise_time", "fall_time")
        check_range("AxisWaveform.amplitude", self.amplitude, 0.0, 1e-3)
        check_range("AxisWaveform.rise_time", self.rise_time, 0.0, 1.0, low_open=True)
        check_range("AxisWaveform.fall_time", self.fall_time, 0.0, 1.0, low_open=True)

    @property
    def period(self) -> float:
        """T = t1 + t2 (s)."""
        return self.rise_time + self.fall_time

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        """Displacement (m) at time(s) ``t`` (s), periodic in T (paper Eq. 18)."""
        tau = np.mod(np.asarray(t, dtype=float), self.period)
        rising = self.amplitude * tau / self.rise_time
        falling = self.amplitude * (self.period - tau) / self.fall_time
        return np.where(tau <= self.rise_time, rising, falling)


#: The paper's waveform (Fig. 2): x: 30 um, t1 = 1.9 ms, t2 = 0.1 ms; z: 6 um, 1.7 ms, 0.3 ms.
PAPER_X = AxisWaveform(amplitude=30e-6, rise_time=1.9e-3, fall_time=0.1e-3)
PAPER_Z = AxisWaveform(amplitude=6e-6, rise_time=1.7e-3, fall_time=0.3e-3)


@dataclass(frozen=True)
class Waveform:
    """The indenter's x and z waveform for one or more drive periods.

    Attributes:
        x: horizontal triangle; x(t) starts and ends every period at 0.
        z: vertical triangle; z(t) = indentation depth d(t) (m).
        z_phase: delay of the z triangle, as a fraction of T in [0, 1):
            ``z(t) = z_triangle(t - z_phase T)``. 0 is the paper's (both axes start together).
    """

    x: AxisWaveform = field(default_factory=lambda: PAPER_X)
    z: AxisWaveform = field(default_factory=lambda: PAPER_Z)
    z_phase: float = 0.0

    def __post_init__(self) -> None:
        store_floats(self, "z_phase")
        check_range("Waveform.z_phase", self.z_phase, 0.0, 1.0, high_open=True)
        if not math.isclose(self.x.period, self.z.period, rel_tol=1e-9, abs_tol=0.0):
            raise ValueError(
                f"Waveform: x period {self.x.period!r} s and z period {self.z.period!r} s must be equal"
            )

    @classmethod
    def paper(cls, period: float | None = None, x_amplitude: float | None = None,
              z_amplitude: float | None = None) -> "Waveform":
        """The paper's waveform (Fig. 2); with arguments, its shape (the rise and fall as the same
        fractions of the period, both axes starting together) at another ``period`` (s) and strokes
        ``x_amplitude``, ``z_amplitude`` (m): the trapezoid baseline of any drive. Without
        arguments it is ``PAPER_X`` and ``PAPER_Z`` exactly."""
        scale = 1.0 if period is None else float(period) / PAPER_X.period
        x = AxisWaveform(PAPER_X.amplitude if x_amplitude is None else x_amplitude,
                         PAPER_X.rise_time * scale, PAPER_X.fall_time * scale)
        z = AxisWaveform(PAPER_Z.amplitude if z_amplitude is None else z_amplitude,
                         PAPER_Z.rise_time * scale, PAPER_Z.fall_time * scale)
        return cls(x=x, z=z)

    @property
    def period(self) -> float:
        """T (s)."""
        return self.x.period

    @property
    def fastest_edge(self) -> float:
        """Shortest rise or fall time (s) over both axes."""
        return min(self.x.rise_time, self.x.fall_time, self.z.rise_time, self.z.fall_time)

    def x_at(self, t: np.ndarray | float) -> np.ndarray:
        """x(t) (m)."""
        return self.x(t)

    def z_at(self, t: np.ndarray | float) -> np.ndarray:
        """z(t) = d(t) (m), including the phase delay."""
        return self.z(np.asarray(t, dtype=float) - self.z_phase * self.period)

    @property
    def min_x_velocity(self) -> float:
        """The indenter's most negative x velocity (m/s): ``-A_x / t2``, on the fast return stroke."""
        return -self.x.amplitude / self.x.fall_time

    @property
    def max_depth(self) -> float:
        """Largest indentation (m) over a period."""
        return self.z.amplitude


@njit(cache=True)
def _triangle(t, amplitude, rise, period):
    tau = t % period
    if tau <= rise:
        return amplitude * tau / rise
    return amplitude * (period - tau) / (period - rise)


#: Most z knots of one period (:func:`knots_into`): 0, T, the two corners and the blend's end.
MAX_Z_KNOTS = 5


@njit(cache=True)
def knots_into(x_amplitude, x_rise, z_amplitude, z_rise, z_phase, period, z_start, blend_time, tx, vx, tz, vz):
    """:func:`knots_from_params` into given arrays, allocating nothing (the batched solver calls it
    from many threads at once): ``tx``, ``vx`` of size 3, ``tz``, ``vz`` of size >= ``MAX_Z_KNOTS``.
    Returns the number m of z knots (``tz[:m]``, ``vz[:m]``)."""
    tx[0] = 0.0
    tx[1] = x_rise
    tx[2] = period
    vx[0] = 0.0
    vx[1] = x_amplitude
    vx[2] = 0.0
    shift = z_phase * period
    tz[0] = 0.0
    tz[1] = period
    tz[2] = shift % period
    tz[3] = (shift + z_rise) % period
    n = 4
    if z_start >= 0.0:
        tb = blend_time if blend_time > 0.0 else min(z_rise, period - z_rise)
        tz[4] = min(tb, period)
        n = 5
    for i in range(1, n):  # sort the candidate times (insertion sort of at most 5)
        v = tz[i]
        j = i - 1
        while j >= 0 and tz[j] > v:
            tz[j + 1] = tz[j]
            j -= 1
        tz[j + 1] = v
    m = 0
    for i in range(n):  # drop duplicates (round-off of the phase shift)
        if m == 0 or tz[i] - tz[m - 1] > 1e-12 * period:
            tz[m] = tz[i]
            m += 1
    tz[m - 1] = period
    for i in range(m):
        vz[i] = _triangle(tz[i] - shift, z_amplitude, z_rise, period)
    vz[m - 1] = vz[0]  # exactly periodic
    if z_start >= 0.0 and z_start != vz[0]:
        tb = min(blend_time if blend_time > 0.0 else min(z_rise, period - z_rise), period)
        offset = z_start - vz[0]
        top = max(z_start, z_amplitude)
        for i in range(m):
            v = vz[i] + offset * max(0.0, 1.0 - tz[i] / tb)
            vz[i] = min(max(v, 0.0), top)
        vz[0] = z_start
        vz[m - 1] = _triangle(-shift, z_amplitude, z_rise, period)
    return m


@njit(cache=True)
def knots_from_params(x_amplitude, x_rise, z_amplitude, z_rise, z_phase, period, z_start, blend_time):
    """Compiled core of :func:`period_knots` from plain floats (s, m; ``z_phase`` in [0, 1)).

    ``z_start < 0`` means "no previous period" (no blending); ``blend_time <= 0`` means the new z
    triangle's shorter edge.
    """
    tx = np.empty(3)
    vx = np.empty(3)
    tz = np.empty(MAX_Z_KNOTS)
    vz = np.empty(MAX_Z_KNOTS)
    m = knots_into(x_amplitude, x_rise, z_amplitude, z_rise, z_phase, period, z_start, blend_time, tx, vx, tz, vz)
    return tx, vx, tz[:m], vz[:m]


def period_knots(waveform: Waveform, z_start: float | None = None, blend_time: float | None = None):
    """Piecewise-linear knots of one period: ``(tx, vx, tz, vz)``, float64 arrays, times in [0, T].

    x(t) is 0 at both ends of every period, so it is always continuous across periods. z(t) with
    a phase offset starts at ``z_triangle(-z_phase T)``; if the previous period ended at another
    depth ``z_start`` (a change of phase or amplitude), the difference is ramped out linearly over
    ``blend_time`` (default: the new z triangle's shorter edge):
    ``z(t) = z_new(t) + (z_start - z_new(0)) max(0, 1 - t / blend_time)``, so z is continuous and
    the extra speed is bounded by ``|z_start - z_new(0)| / blend_time``; the blended depth is
    clipped to ``[0, max(z_start, new amplitude)]``.
    """
    return knots_from_params(
        waveform.x.amplitude, waveform.x.rise_time, waveform.z.amplitude, waveform.z.rise_time, waveform.z_phase,
        waveform.period, -1.0 if z_start is None else float(z_start), -1.0 if blend_time is None else blend_time)
