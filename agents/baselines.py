"""Non-learning baselines: the paper's trapezoid, and a CMA-ES-optimised open-loop waveform per point.

CMA-ES searches the env's action box (the same actuator limits as the policies) for the fixed
action with the highest steady velocity at one (k, cargo mass) point, on the same simulator and
protocol as every other method (``agents.evaluate``). Each population is evaluated in one batched
call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .evaluate import ACTION_MAP, TIME_QUANTUM, open_loop_velocity, trapezoid_action

#: Default CMA-ES budget: steady-velocity evaluations per point (each one 30 simulated periods).
CMA_BUDGET = 480
CMA_POPSIZE = 12
#: Start of the two-action search: a slow full forward stroke pressed to full depth at mid-period
#: ("push"), then a period with almost no x stroke and a fast full-depth press ("clamp").
PUSH_CLAMP = np.array([[1.0, 0.8, 1.0, 0.0, 1.0], [-0.87, -0.9, 1.0, -0.9, 0.8]])
#: CMA-ES evaluations of one two-action cycle search (per start), its population and step size.
CYCLE_SEARCH = {"budget": 1500, "popsize": 16, "sigma0": 0.3}


@dataclass(frozen=True)
class CMAResult:
    """Best fixed action found, its steady velocity (m/s) and the evaluations spent."""

    action: np.ndarray
    velocity: float
    evaluations: int


def cma_optimize(k: float, cargo_mass: float, budget: int = CMA_BUDGET, popsize: int = CMA_POPSIZE,
                 seed: int = 0, sigma0: float = 0.5, cycle: int = 1, x0=None, friction=None,
                 time_quantum: float = TIME_QUANTUM) -> CMAResult:
    """Maximise the steady velocity over open-loop drives in [-1, 1]^5.

    ``cycle = 1`` searches fixed actions (one waveform every period); ``cycle = p`` searches cycles
    of p actions played in turn (a 5 p dimensional search). The search starts at ``x0`` (an action
    or a (p, 5) cycle; default: the trapezoid every period), and the result is never worse than
    the trapezoid. ``action`` is (5,) for ``cycle = 1``, else (p, 5). ``friction``: (mu, mu1), the
    indenter-slider and slider-base friction coefficients (default: the paper's 0.3, 0.1).
    ``time_quantum`` (s): the env's quantum of rises and the z phase (``open_loop_velocity``).
    """
    import cma

    start = np.tile(trapezoid_action(), (cycle, 1)) if x0 is None else np.reshape(np.asarray(x0, float), (cycle, 5))
    es = cma.CMAEvolutionStrategy(np.clip(start, -0.95, 0.95).ravel().tolist(), sigma0, {
        "bounds": [-1.0, 1.0], "popsize": popsize, "maxfevals": budget, "seed": seed + 1, "verbose": -9})
    point = [(k, cargo_mass) if friction is None else (k, cargo_mass, *friction)]
    best_x = np.tile(trapezoid_action(), (cycle, 1)).astype(np.float64)  # never worse than the trapezoid
    best_v, evals = float(open_loop_velocity(point, best_x[None], time_quantum=time_quantum)[0]), 1
    while not es.stop():
        xs = np.clip(np.array(es.ask()), -1.0, 1.0)
        v = open_loop_velocity(point * len(xs), xs.reshape(len(xs), cycle, 5), time_quantum=time_quantum)
        evals += len(xs)
        es.tell(list(xs), list(-v))
        i = int(np.argmax(v))
        if v[i] > best_v:
            best_x, best_v = xs[i].reshape(cycle, 5).copy(), float(v[i])
    best_x = np.clip(best_x, -1.0, 1.0)
    return CMAResult(best_x[0] if cycle == 1 else best_x, best_v, evals)


def best_cma_run(k: float, cargo_mass: float, starts, budget: int, popsize: int, sigma0: float, cycle: int = 1,
                 seed: int = 0, friction=None, time_quantum: float = TIME_QUANTUM) -> CMAResult:
    """The best of CMA-ES runs from each of ``starts`` (an action, a (cycle, 5) cycle, or None for the
    trapezoid), run i seeded ``seed + i``; ``friction`` and ``time_quantum`` as :func:`cma_optimize`."""
    runs = [cma_optimize(k, cargo_mass, budget, popsize=popsize, seed=seed + i, sigma0=sigma0, cycle=cycle, x0=x0,
                         friction=friction, time_quantum=time_quantum)
            for i, x0 in enumerate(starts)]
    return max(runs, key=lambda r: r.velocity)


def best_cycle(k: float, cargo_mass: float, starts=(None, PUSH_CLAMP), budget: int = CYCLE_SEARCH["budget"],
               seed: int = 0, friction=None, time_quantum: float = TIME_QUANTUM) -> CMAResult:
    """The best two-action cycle found by CMA-ES runs from each of ``starts`` (None: the trapezoid
    every period), ``CYCLE_SEARCH`` settings, ``budget`` evaluations per start; ``friction`` and
    ``time_quantum`` as :func:`cma_optimize`."""
    return best_cma_run(k, cargo_mass, starts, budget, popsize=CYCLE_SEARCH["popsize"],
                        sigma0=CYCLE_SEARCH["sigma0"], cycle=2, seed=seed, friction=friction, time_quantum=time_quantum)


def cycle_critical_load(k: float, trapezoid_critical: float, iterations: int = 8,
                        budget: int = CYCLE_SEARCH["budget"], time_quantum: float = TIME_QUANTUM) -> tuple[float, np.ndarray]:
    """Critical load (kg) of the best two-action cycle found, by bisection on the load from the
    trapezoid's critical load up, re-optimising the cycle at every trial load (starts: the
    push/clamp cycle and the best cycle so far). The bracket's upper end starts at 1.8x the
    trapezoid's and doubles while the cycle still moves there. Returns (load, its cycle).
    ``time_quantum`` as :func:`cma_optimize`."""
    lo = trapezoid_critical
    if lo <= 0.0:
        return 0.0, np.tile(trapezoid_action(), (2, 1))
    best = best_cycle(k, lo, (PUSH_CLAMP,), budget, time_quantum=time_quantum)
    if best.velocity <= 0.0:  # the trapezoid itself moves here, so a search never ends below it
        return 0.0, best.action
    cycle, hi = best.action, 1.8 * lo
    while (trial := best_cycle(k, hi, (PUSH_CLAMP, cycle), budget, time_quantum=time_quantum)).velocity > 0.0:
        lo, cycle, hi = hi, trial.action, 2.0 * hi
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        trial = best_cycle(k, mid, (PUSH_CLAMP, cycle), budget, time_quantum=time_quantum)
        if trial.velocity > 0.0:
            lo, cycle = mid, trial.action
        else:
            hi = mid
    return lo, cycle


__all__ = ["ACTION_MAP", "CMAResult", "CYCLE_SEARCH", "PUSH_CLAMP", "best_cma_run", "best_cycle", "cma_optimize",
           "cycle_critical_load", "trapezoid_action"]
