"""Steady-state mean velocity and critical load of the drive, and the state a run ended in.

A run of a fixed waveform ends in one of three states (:data:`MOTION_STATES`):

``"settled"``
    periodic motion: for some p <= ``window``, every period velocity of the last p periods
    equals the one p periods before to ``rtol |v| + atol`` (so a state that alternates between
    two period velocities is settled with ``window = 2``, but a decaying alternation is not). Its velocity is a steady velocity (it may be negative: the load drags
    the slider back at a steady rate).
``"settling"``
    still in its transient when the run ended: the number is not a steady velocity.
``"runaway"``
    the load accelerates the slider backwards without bound (possible because the model's moving
    mass is the 50 g slider and its base friction ``mu1 F_z`` vanishes with the contact). The mean
    velocity grows with the run length, so it is never reported as a velocity. Detected by any
    of three conditions (:func:`is_runaway`); the first two are sufficient by themselves:

    1. the load exceeds ``(mu + mu1) max F_z``, the most the contact and the base can ever push
       forward;
    2. the slider moved backwards faster than the indenter's fastest backward stroke in the last
       two periods and is still speeding up: the contact then slips forward all period, the
       forces no longer depend on the slider, and the load wins every period by the same amount;
    3. on the way there: the mean velocity over windows of ``window`` periods is negative and has
       fallen in each of the last three windows by more than the settling tolerance, without the
       falls shrinking (a transient's falls shrink geometrically; a runaway's stay constant).
"""

from __future__ import annotations

from dataclasses import dataclass

import math

import numpy as np

from .params import DriveParams, Numerics
from .simulator import DriveSimulator
from .waveform import Waveform

#: The paper's rule: skip 5 periods, average the slider velocity over the 6th.
PAPER_SKIP_PERIODS = 5
#: What a run of a fixed waveform can end in (module docstring).
MOTION_STATES = ("settled", "settling", "runaway")


def is_runaway(period_velocities, indenter_min_velocity, load_margin, window: int = 2, rtol: float = 1e-3,
               atol: float = 1e-6):
    """Whether the load runs away with the slider (the three conditions of the module docstring).

    Args:
        period_velocities: mean slider velocity (m/s) of each period, oldest first: shape
            (periods,) for one run, or (periods, n) for n runs (then the result has shape (n,)).
        indenter_min_velocity: the indenter's most negative x velocity (m/s) over a period.
        load_margin: ``(mu + mu1) max F_z - F_m`` (N) of the last period (scalar or (n,)).
        window, rtol, atol: the windows (periods) and the settling tolerance (-, m/s) of condition 3.
    """
    v = np.asarray(period_velocities, dtype=float)
    result = np.asarray(load_margin) < 0.0
    if v.shape[0] >= 2:
        past_the_stroke = (v[-1] < indenter_min_velocity) & (v[-2] < indenter_min_velocity)
        result = result | (past_the_stroke & (v[-1] < v[-2]))
    if v.shape[0] >= 4 * window:
        end = v.shape[0]
        means = np.stack([v[end - (i + 1) * window:end - i * window].mean(axis=0)
                          for i in range(3, -1, -1)])  # the last four windows, oldest first
        falls = -np.diff(means, axis=0)
        tolerance = rtol * np.abs(means[-1]) + atol
        steady_fall = np.all(falls > tolerance, axis=0) & (falls[-1] >= 0.9 * falls[0])
        result = result | ((means[-1] < 0.0) & steady_fall)
    return result


def motion_state(period_velocities, indenter_min_velocity: float, load_margin: float = np.inf, window: int = 2,
                 rtol: float = 1e-3, atol: float = 1e-6) -> str:
    """The state a run ended in: ``"settled"``, ``"settling"`` or ``"runaway"`` (module docstring).

    Args:
        period_velocities: mean slider velocity (m/s) of each period of the run, in order.
        indenter_min_velocity: the indenter's most negative x velocity (m/s) over a period
            (``-A_x / t2`` for the triangle).
        load_margin: ``(mu + mu1) max F_z - F_m`` (N) of the last period; negative means the load
            beats every force that can push the slider forward.
        window, rtol, atol: the settling test (periods, -, m/s).
    """
    v = np.asarray(period_velocities, dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError("period_velocities must be a non-empty 1D sequence")
    if bool(is_runaway(v, indenter_min_velocity, load_margin, window, rtol, atol)):
        return "runaway"
    for p in range(1, window + 1):  # periodic with a period of p drive periods, for some p <= window
        if v.size >= 2 * p:
            last, before = v[-p:], v[-2 * p:-p]
            if np.max(np.abs(last - before)) <= rtol * abs(last.mean()) + atol:
                return "settled"
    return "settling"


@dataclass(frozen=True)
class SteadyVelocity:
    """Mean slider velocity of a run and the state the run ended in.

    Attributes:
        velocity: mean velocity (m/s) over the averaging window (the 6th period for the paper
            rule, the last ``window`` periods for the settled rule). A steady velocity only when
            ``state == "settled"``; for ``"runaway"`` it grows with the run length.
        periods_run: periods simulated.
        state: ``"settled"``, ``"settling"`` or ``"runaway"`` (:func:`motion_state`).
        period_velocities: per-period mean velocities (m/s) of the whole run.
    """

    velocity: float
    periods_run: int
    state: str
    period_velocities: np.ndarray

    @property
    def settled(self) -> bool:
        """True when the run ended in periodic motion."""
        return self.state == "settled"


def steady_velocity(
    params: DriveParams,
    waveform: Waveform | None = None,
    numerics: Numerics | str = "fast",
    rule: str = "settled",
    window: int = 2,
    rtol: float = 1e-3,
    atol: float = 1e-6,
    max_periods: int = 100,
) -> SteadyVelocity:
    """Mean slider velocity (m/s) of a fixed waveform, and the state the run ended in.

    Rules:
        ``"settled"`` (default): run until the motion is periodic with a period of p <= ``window``
            drive periods (each of the last p period velocities within ``rtol * |v| + atol``
            (m/s) of the one p periods earlier; a window of 2 admits alternating states), or
            until a runaway is detected, or ``max_periods`` (then ``state="settling"``). Returns
            the last window's mean.
        ``"paper"``: skip 5 periods, average over the 6th (the paper's Fig. 5). The state is what
            those 6 periods show (the same tests on the 6 periods), so a transient sampled at
            period 6 says ``"settling"``.
    """
    waveform = waveform or Waveform.paper()
    if rule not in ("paper", "settled"):
        raise ValueError(f"rule={rule!r} is not one of ['paper', 'settled']")
    if not (isinstance(window, (int, np.integer)) and window >= 1):
        raise ValueError(f"window={window!r} is outside the allowed range [1, inf)")
    sim = DriveSimulator(params, numerics, max_depth=max(waveform.max_depth, 1e-9))
    friction = params.contact.friction_coefficient + params.contact.base_friction_coefficient
    v_min = waveform.min_x_velocity
    v: list[float] = []

    def state_now(result) -> str:
        margin = friction * result.peak_normal_force - params.drive.load
        return motion_state(v, v_min, margin, window, rtol, atol)

    if rule == "paper":
        results = sim.run(waveform, PAPER_SKIP_PERIODS + 1)
        v = [r.mean_velocity for r in results]
        return SteadyVelocity(v[-1], len(v), state_now(results[-1]), np.array(v))
    state = "settling"
    while len(v) < max_periods:
        result = sim.step(waveform)
        v.append(result.mean_velocity)
        if len(v) >= PAPER_SKIP_PERIODS + window:
            state = state_now(result)
            if state != "settling":
                break
    return SteadyVelocity(float(np.mean(v[-window:])), len(v), state, np.array(v))


@dataclass(frozen=True)
class CriticalLoad:
    """Largest cargo mass for which the drive still moves the slider forward.

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


def bisect_critical_load(moves, low: float, high: float, tolerance: float | None = None,
                         iterations: int | None = None, grow: bool = True,
                         max_load: float = math.inf) -> tuple[float, float] | None:
    """The bracket (moves, stalls) of the largest load at which ``moves(load)`` is True, by bisection.

    None if the drive does not move at ``low``. With ``grow``, the upper end doubles while the drive
    still moves there (``ValueError`` once it passes ``max_load``); then the bracket is halved
    ``iterations`` times, or until it is at most ``tolerance`` wide. Assumes the drive moves below
    its critical load and stalls above it. ``moves`` may keep state (a search that starts from the
    drive found at the last load that moved): it is called at increasing loads while the bracket
    grows, then at each midpoint in turn."""
    if not moves(low):
        return None
    if grow:
        while moves(high):
            low, high = high, 2.0 * high
            if high > max_load:
                raise ValueError(f"the drive still moves at {low!r} kg; raise max_mass={max_load!r}")
    steps = 0
    while (tolerance is not None and high - low > tolerance) or (iterations is not None and steps < iterations):
        mid = 0.5 * (low + high)
        if moves(mid):
            low = mid
        else:
            high = mid
        steps += 1
    return low, high


def critical_load(
    params: DriveParams,
    waveform: Waveform | None = None,
    numerics: Numerics | str = "fast",
    rule: str = "settled",
    tolerance: float = 1e-3,
    upper_guess: float = 1.0,
    max_mass: float = 100.0,
) -> CriticalLoad:
    """Critical cargo mass (kg) by bisection on the sign of the mean velocity.

    A load moves the drive when its mean velocity (``rule``) is positive and the run did not run
    away. Assumes the velocity decreases with the load (true for every case of the paper). The
    bracket starts at ``[0, upper_guess]`` and doubles the upper end until the drive stalls.
    Returns 0 if the drive does not move even without load.
    """
    if not tolerance > 0:
        raise ValueError(f"tolerance={tolerance!r} is outside the allowed range (0, inf)")
    evaluations = 0

    def moves(m: float) -> bool:
        nonlocal evaluations
        evaluations += 1
        sv = steady_velocity(params.with_cargo_mass(m), waveform, numerics, rule)
        return sv.state != "runaway" and sv.velocity > 0.0

    bracket = bisect_critical_load(moves, 0.0, upper_guess, tolerance=tolerance, max_load=max_mass)
    if bracket is None:
        return CriticalLoad(0.0, 0.0, (0.0, 0.0), evaluations)
    lo, hi = bracket
    g = params.drive.gravity
    return CriticalLoad(lo, lo * g, (lo, hi), evaluations)
