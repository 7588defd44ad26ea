"""Non-learning baselines: the paper's trapezoid, and a CMA-ES-optimised open-loop waveform per point.

CMA-ES searches the env's action box (the same actuator limits as the policies) for the fixed
action with the highest steady velocity at one (k, cargo mass) point, on the same simulator and
protocol as every other method (``agents.evaluate``). Each population is evaluated in one batched
call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .evaluate import ACTION_MAP, open_loop_velocity, trapezoid_action

#: Default CMA-ES budget: steady-velocity evaluations per point (each one 30 simulated periods).
CMA_BUDGET = 480
CMA_POPSIZE = 12


@dataclass(frozen=True)
class CMAResult:
    """Best fixed action found, its steady velocity (m/s) and the evaluations spent."""

    action: np.ndarray
    velocity: float
    evaluations: int


def cma_optimize(k: float, cargo_mass: float, budget: int = CMA_BUDGET, popsize: int = CMA_POPSIZE,
                 seed: int = 0, sigma0: float = 0.5) -> CMAResult:
    """Maximise the steady velocity over fixed actions in [-1, 1]^5, starting at the trapezoid."""
    import cma

    x0 = np.clip(trapezoid_action(), -0.95, 0.95)
    es = cma.CMAEvolutionStrategy(x0.tolist(), sigma0, {"bounds": [-1.0, 1.0], "popsize": popsize,
                                                         "maxfevals": budget, "seed": seed + 1, "verbose": -9})
    point = [(k, cargo_mass)]
    best_x = np.asarray(trapezoid_action(), dtype=np.float64)  # the result is never worse than the trapezoid
    best_v, evals = float(open_loop_velocity(point, best_x)[0]), 1
    while not es.stop():
        xs = np.clip(np.array(es.ask()), -1.0, 1.0)
        v = open_loop_velocity(point * len(xs), xs)
        evals += len(xs)
        es.tell(list(xs), list(-v))
        i = int(np.argmax(v))
        if v[i] > best_v:
            best_x, best_v = xs[i].copy(), float(v[i])
    return CMAResult(np.clip(best_x, -1.0, 1.0), best_v, evals)


__all__ = ["ACTION_MAP", "CMAResult", "cma_optimize", "trapezoid_action"]
