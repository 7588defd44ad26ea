"""Steady-state mean velocity and critical load of the drive."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .params import DriveParams, Numerics
from .simulator import DriveSimulator
from .waveform import Waveform

#: The paper's rule: skip 5 periods, average the slider velocity over the 6th.
PAPER_SKIP_PERIODS = 5


@dataclass(frozen=True)
class SteadyVelocity:
    """Mean slider velocity in the periodic state.

    Attributes:
        velocity: mean velocity (m/s) over the averaging window.
        periods_run: periods simulated.
        settled: whether the settling criterion was met (always True for the paper rule).
        period_velocities: per-period mean velocities (m/s) of the whole run.
    """

    velocity: float
    periods_run: int
    settled: bool
    period_velocities: np.ndarray


def steady_velocity(
    params: DriveParams,
    waveform: Waveform | None = None,
    numerics: Numerics | str = "default",
    rule: str = "paper",
    window: int = 2,
    rtol: float = 1e-3,
    atol: float = 1e-6,
    max_periods: int = 60,
) -> SteadyVelocity:
    """Steady-state mean slider velocity (m/s).

    Rules:
        ``"paper"``: skip 5 periods, average over the 6th (the paper's Fig. 5).
        ``"settled"``: run until the mean velocities over two consecutive windows of ``window``
            periods agree to ``rtol * |v| + atol`` (m/s); a window of 2 averages out the
            period-doubled stick-slip states. Returns the last window's mean; ``settled=False``
            if ``max_periods`` was reached first.
    """
    waveform = waveform or Waveform.paper()
    sim = DriveSimulator(params, numerics, max_depth=max(waveform.max_depth, 1e-9))
    if rule == "paper":
        v = np.array([r.mean_velocity for r in sim.run(waveform, PAPER_SKIP_PERIODS + 1)])
        return SteadyVelocity(float(v[-1]), v.size, True, v)
    if rule != "settled":
        raise ValueError(f"rule={rule!r} is not one of ['paper', 'settled']")
    if window < 1:
        raise ValueError(f"window={window!r} is outside the allowed range [1, inf)")
    v: list[float] = []
    while len(v) < max_periods:
        v.append(sim.step(waveform).mean_velocity)
        if len(v) >= max(2 * window, PAPER_SKIP_PERIODS + window):
            last = float(np.mean(v[-window:]))
            before = float(np.mean(v[-2 * window : -window]))
            if abs(last - before) <= rtol * abs(last) + atol:
                return SteadyVelocity(last, len(v), True, np.array(v))
    return SteadyVelocity(float(np.mean(v[-window:])), len(v), False, np.array(v))


@dataclass(frozen=True)
class CriticalLoad:
    """Largest cargo mass for which the steady mean velocity is still positive.

    Attributes:
        cargo_mass: the critical mass m_c (kg), within ``tolerance``.
        load_force: m_c g (N).
        bracket: (moves, stalls): masses (kg) with positive and non-positive velocity.
        evaluations: number of steady-velocity evaluations.
    """

    cargo_mass: float
    load_force: float
    bracket: tuple[float, float]
    evaluations: int


def critical_load(
    params: DriveParams,
    waveform: Waveform | None = None,
    numerics: Numerics | str = "default",
    rule: str = "paper",
    tolerance: float = 1e-3,
    upper_guess: float = 1.0,
    max_mass: float = 100.0,
) -> CriticalLoad:
    """Critical cargo mass (kg) by bisection on the sign of the steady velocity.

    Assumes the velocity decreases with the load (true for every case of the paper). The
    bracket starts at ``[0, upper_guess]`` and doubles the upper end until the drive stalls.
    Returns 0 if the drive does not move even without load.
    """
    if not tolerance > 0:
        raise ValueError(f"tolerance={tolerance!r} is outside the allowed range (0, inf)")
    evaluations = 0

    def moves(m: float) -> bool:
        nonlocal evaluations
        evaluations += 1
        return steady_velocity(params.with_cargo_mass(m), waveform, numerics, rule).velocity > 0.0

    if not moves(0.0):
        return CriticalLoad(0.0, 0.0, (0.0, 0.0), evaluations)
    lo, hi = 0.0, upper_guess
    while moves(hi):
        lo, hi = hi, 2.0 * hi
        if hi > max_mass:
            raise ValueError(f"the drive still moves at {lo!r} kg; raise max_mass={max_mass!r}")
    while hi - lo > tolerance:
        mid = 0.5 * (lo + hi)
        if moves(mid):
            lo = mid
        else:
            hi = mid
    g = params.drive.gravity
    return CriticalLoad(lo, lo * g, (lo, hi), evaluations)
