"""CMA-ES searches for open-loop drives: the best drive at a point, and the critical load of the best drive.

Every search evaluates its candidates with the evaluation protocol (``mdr_drive_agents.protocol``:
30 periods, the mean of the last 10), each CMA-ES population in one batched call, and searches the
env's action box (the same actuator limits as the policies):

* ``cma_optimize``: fixed actions (one waveform every period), or cycles of p actions played in turn;
* ``search_point``: the best drive at one (k, load) point, the better of a search over fixed actions
  and one over two-action cycles from several starts (the blind benchmark's reference, and each node
  of the teacher's grid);
* ``pooled_cycle_search``: the best two-action cycle at a point from the fastest of a pool of drives
  (other points' best drives, random cycles) there (the blind benchmark's ``strong`` reference);
* ``cycle_critical_load`` and ``fixed_critical_load``: the largest load at which the best two-action
  cycle (or fixed action) found still moves, by bisection on the load with a new search at every
  trial load (``mdr_drive_env.core.analysis.bisect_critical_load``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mdr_drive_env.core.analysis import bisect_critical_load

from .drive import PAPER_DRIVE, DriveDescription
from .protocol import TIME_QUANTUM, open_loop_velocity, trapezoid_action

#: Default CMA-ES budget: steady-velocity evaluations per point (each one 30 simulated periods).
CMA_BUDGET = 480
CMA_POPSIZE = 12
#: Initial step size of the fixed-action search (action units).
FIXED_SIGMA = 0.5
#: Start of the two-action search: a slow full forward stroke pressed to full depth at mid-period
#: ("push"), then a period with almost no x stroke and a fast full-depth press ("clamp").
PUSH_CLAMP = np.array([[1.0, 0.8, 1.0, 0.0, 1.0], [-0.87, -0.9, 1.0, -0.9, 0.8]])
#: Another start of the two-action search: a full forward stroke on x's fastest edge (5 % of the
#: period) at full depth, the contact let go right after it and pressed again slowly over the return
#: ("throw"), then the same x out of contact ("coast"). The base's friction is mu1 times the contact's
#: normal force, so out of contact the slider coasts against the load alone: at light loads such
#: cycles throw it faster than the stroke speed, a family that searches from the trapezoid, the
#: push/clamp cycle and the lighter point's drive do not reach.
THROW_COAST = np.array([[1.0, -1.0, 1.0, 1.0, -0.8], [1.0, -1.0, -1.0, 1.0, -0.8]])
#: CMA-ES evaluations of one two-action cycle search (per start), its population and step size.
CYCLE_SEARCH = {"budget": 1500, "popsize": 16, "sigma0": 0.3}
#: Bisection steps of a critical-load search.
CRITICAL_BISECTIONS = 8


@dataclass(frozen=True)
class CMAResult:
    """Best drive found, its steady velocity (m/s) and the evaluations spent."""

    action: np.ndarray
    velocity: float
    evaluations: int


def cma_optimize(k: float, cargo_mass: float, budget: int = CMA_BUDGET, popsize: int = CMA_POPSIZE,
                 seed: int = 0, sigma0: float = FIXED_SIGMA, cycle: int = 1, x0=None, friction=None,
                 time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE) -> CMAResult:
    """Maximise the steady velocity over open-loop drives in [-1, 1]^5.

    ``cycle = 1`` searches fixed actions (one waveform every period); ``cycle = p`` searches cycles
    of p actions played in turn (a 5 p dimensional search). The search starts at ``x0`` (an action
    or a (p, 5) cycle; default: the trapezoid every period), and the result is never worse than
    the trapezoid. ``action`` is (5,) for ``cycle = 1``, else (p, 5). ``friction``: (mu, mu1), the
    indenter-slider and slider-base friction coefficients (default: the paper's 0.3, 0.1).
    ``time_quantum`` (s): the env's quantum of rises and the z phase (``open_loop_velocity``);
    ``drive``: the drive searched on (default the paper's).
    """
    import cma

    start = np.tile(trapezoid_action(drive), (cycle, 1)) if x0 is None else np.reshape(np.asarray(x0, float), (cycle, 5))
    es = cma.CMAEvolutionStrategy(np.clip(start, -0.95, 0.95).ravel().tolist(), sigma0, {
        "bounds": [-1.0, 1.0], "popsize": popsize, "maxfevals": budget, "seed": seed + 1, "verbose": -9})
    point = [(k, cargo_mass) if friction is None else (k, cargo_mass, *friction)]
    best_x = np.tile(trapezoid_action(drive), (cycle, 1)).astype(np.float64)  # never worse than the trapezoid
    best_v, evals = float(open_loop_velocity(point, best_x[None], time_quantum=time_quantum, drive=drive)[0]), 1
    while not es.stop():
        xs = np.clip(np.array(es.ask()), -1.0, 1.0)
        v = open_loop_velocity(point * len(xs), xs.reshape(len(xs), cycle, 5), time_quantum=time_quantum, drive=drive)
        evals += len(xs)
        es.tell(list(xs), list(-v))
        i = int(np.argmax(v))
        if v[i] > best_v:
            best_x, best_v = xs[i].reshape(cycle, 5).copy(), float(v[i])
    best_x = np.clip(best_x, -1.0, 1.0)
    return CMAResult(best_x[0] if cycle == 1 else best_x, best_v, evals)


def best_cma_run(k: float, cargo_mass: float, starts, budget: int, popsize: int, sigma0: float, cycle: int = 1,
                 seed: int = 0, friction=None, time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE) -> CMAResult:
    """The best of CMA-ES runs from each of ``starts`` (an action, a (cycle, 5) cycle, or None for the
    trapezoid), run i seeded ``seed + i``; ``friction`` and ``time_quantum`` as :func:`cma_optimize`."""
    runs = [cma_optimize(k, cargo_mass, budget, popsize=popsize, seed=seed + i, sigma0=sigma0, cycle=cycle, x0=x0,
                         friction=friction, time_quantum=time_quantum, drive=drive)
            for i, x0 in enumerate(starts)]
    return max(runs, key=lambda r: r.velocity)


def best_cycle(k: float, cargo_mass: float, starts=(None, PUSH_CLAMP), budget: int = CYCLE_SEARCH["budget"],
               seed: int = 0, friction=None, time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE,
               sigma0: float = CYCLE_SEARCH["sigma0"]) -> CMAResult:
    """The best two-action cycle found by CMA-ES runs from each of ``starts`` (None: the trapezoid
    every period), ``CYCLE_SEARCH``'s population, ``budget`` evaluations per start and step ``sigma0``;
    ``friction`` and ``time_quantum`` as :func:`cma_optimize`."""
    return best_cma_run(k, cargo_mass, starts, budget, popsize=CYCLE_SEARCH["popsize"], sigma0=sigma0, cycle=2,
                        seed=seed, friction=friction, time_quantum=time_quantum, drive=drive)


@dataclass(frozen=True)
class PointSearch:
    """The two searches of :func:`search_point` at one point: over fixed actions and over two-action cycles."""

    fixed: CMAResult
    cycle: CMAResult

    @property
    def cycle_wins(self) -> bool:
        """Whether the best drive is the cycle (strictly faster than the best fixed action)."""
        return self.cycle.velocity > self.fixed.velocity

    @property
    def velocity(self) -> float:
        """The best drive's steady velocity (m/s), as the search measured it."""
        return self.cycle.velocity if self.cycle_wins else self.fixed.velocity

    @property
    def drive(self) -> np.ndarray:
        """The best drive as a two-action cycle (2, 5) (a fixed action: both rows equal)."""
        if self.cycle_wins:
            return np.asarray(self.cycle.action, dtype=np.float64)
        return np.tile(self.fixed.action, (2, 1))


def search_point(k: float, load: float, fixed_budget: int = CMA_BUDGET, cycle_budget: int = CYCLE_SEARCH["budget"],
                 fixed_sigma: float = FIXED_SIGMA, cycle_sigma: float = CYCLE_SEARCH["sigma0"], fixed_start=None,
                 cycle_starts=(None, PUSH_CLAMP), seed: int = 0, friction=None,
                 time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE) -> PointSearch:
    """The best drive at (k, load kg): CMA-ES over fixed actions (``fixed_budget`` evaluations, step
    ``fixed_sigma``, from ``fixed_start`` or the trapezoid) and over two-action cycles
    (``cycle_budget`` from each of ``cycle_starts``, step ``cycle_sigma``), both seeded with ``seed``;
    ``friction`` and ``time_quantum`` as :func:`cma_optimize`."""
    fixed = cma_optimize(k, load, fixed_budget, sigma0=fixed_sigma, seed=seed, x0=fixed_start, friction=friction,
                         time_quantum=time_quantum, drive=drive)
    cycle = best_cycle(k, load, cycle_starts, cycle_budget, seed=seed, friction=friction, time_quantum=time_quantum, drive=drive,
                       sigma0=cycle_sigma)
    return PointSearch(fixed, cycle)


def pooled_cycle_search(k: float, load: float, pool, starts: int, budget: int, random_cycles: int = 0, seed: int = 0,
                        friction=None, time_quantum: float = TIME_QUANTUM,
                        drive: DriveDescription = PAPER_DRIVE) -> CMAResult:
    """The best two-action cycle at (k, load kg) found from a pool of drives: each of ``pool`` (n, 2, 5)
    (drives found elsewhere, e.g. the best drives of other points) and ``random_cycles`` cycles drawn
    uniformly from the action box with ``seed`` is played at the point, and CMA-ES runs from the
    ``starts`` fastest (``budget`` evaluations each, step ``CYCLE_SEARCH``'s ``sigma0``). Returns the
    best of the pool and the runs; ``evaluations`` counts both. ``friction`` and ``time_quantum`` as
    :func:`cma_optimize`."""
    rng = np.random.default_rng([seed, 2])
    drawn = rng.uniform(-1.0, 1.0, (random_cycles, 2, 5))
    candidates = np.concatenate([np.asarray(pool, dtype=np.float64).reshape(-1, 2, 5), drawn])
    point = (k, load) if friction is None else (k, load, *friction)
    v = open_loop_velocity([point] * len(candidates), candidates, time_quantum=time_quantum, drive=drive)
    order = np.argsort(-v, kind="stable")
    run = best_cycle(k, load, [candidates[i] for i in order[:starts]], budget, seed=seed, friction=friction,
                     time_quantum=time_quantum, drive=drive)
    evaluations = len(candidates) + run.evaluations
    if v[order[0]] > run.velocity:
        return CMAResult(candidates[order[0]].copy(), float(v[order[0]]), evaluations)
    return CMAResult(run.action, run.velocity, evaluations)


def cycle_critical_load(k: float, trapezoid_critical: float, iterations: int = CRITICAL_BISECTIONS,
                        budget: int = CYCLE_SEARCH["budget"], time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE) -> tuple[float, np.ndarray]:
    """Critical load (kg) of the best two-action cycle found, by bisection on the load from the
    trapezoid's critical load up, re-optimising the cycle at every trial load (starts: the
    push/clamp cycle and the best cycle so far). The bracket's upper end starts at 1.8x the
    trapezoid's and doubles while the cycle still moves there. Returns (load, its cycle).
    ``time_quantum`` as :func:`cma_optimize`."""
    if trapezoid_critical <= 0.0:
        return 0.0, np.tile(trapezoid_action(drive), (2, 1))
    found = {}  # the best cycle at the heaviest load that moved so far

    def moves(load: float) -> bool:
        starts = (PUSH_CLAMP,) if "cycle" not in found else (PUSH_CLAMP, found["cycle"])
        trial = best_cycle(k, load, starts, budget, time_quantum=time_quantum, drive=drive)
        if trial.velocity > 0.0 or "cycle" not in found:  # the first search's cycle, even if it stalls
            found["cycle"] = trial.action
        return trial.velocity > 0.0

    bracket = bisect_critical_load(moves, trapezoid_critical, 1.8 * trapezoid_critical, iterations=iterations)
    return (0.0 if bracket is None else bracket[0]), found["cycle"]


def fixed_critical_load(k: float, high: float, budget: int = CMA_BUDGET, iterations: int = CRITICAL_BISECTIONS,
                        drive: DriveDescription = PAPER_DRIVE) -> float:
    """Critical load (kg) of the best fixed action found, by bisection on the load between 0 and
    ``high``, re-optimising the action at every trial load (0 if it does not move unloaded)."""
    bracket = bisect_critical_load(lambda load: cma_optimize(k, load, budget, drive=drive).velocity > 0.0, 0.0, high,
                                   iterations=iterations, grow=False)
    return 0.0 if bracket is None else bracket[0]


__all__ = ["CMAResult", "CMA_BUDGET", "CRITICAL_BISECTIONS", "CYCLE_SEARCH", "PUSH_CLAMP", "PointSearch",
           "best_cma_run", "best_cycle", "cma_optimize", "cycle_critical_load", "fixed_critical_load",
           "pooled_cycle_search", "search_point"]
