#!/usr/bin/env python
"""How much load can any open-loop drive move? A wide CMA-ES search near the trapezoid's stall.

For each k, at cargo masses of 1.1x and 1.3x the trapezoid's critical load, it reports the best
steady velocity found (the trapezoid counts as a candidate)

* over fixed waveforms (one action every period): CMA-ES from the trapezoid and from 4 random
  starts, 2,000 evaluations each, popsize 16;
* over cycles of two actions played in turn (period t uses action t mod 2, a 10-dimensional
  search): CMA-ES from the "push/clamp" pair of ``agents.baselines``, from the trapezoid twice and
  from a random pair, 4,000 evaluations each, popsize 20.

A closed-loop policy can play such a cycle, since it observes its previous action. Writes
results/benchmark/stall_limit.{md,json}.

    python scripts/stall_limit.py [--ks 0 0.1 0.2 0.3 0.4 0.5 0.6] [--out results/benchmark]
"""

import argparse
import time

import numpy as np
from tqdm import tqdm

from mdr_drive_agents.baselines import best_cma_run
from mdr_drive_agents.benchmark import GRID_KS, critical_loads_grid, write_report
from mdr_drive_agents.evaluate import open_loop_velocity, trapezoid_action
from mdr_drive_agents.baselines import PUSH_CLAMP


def best_drive(k: float, m: float, cycle: int, starts: list, budget: int, popsize: int, seed: int = 0):
    """Best (velocity m/s, (cycle, 5) actions) over CMA-ES runs from ``starts`` (None = the trapezoid);
    each run counts the trapezoid as a candidate."""
    best = best_cma_run(k, m, starts, budget, popsize, sigma0=0.6 if cycle == 1 else 0.4, cycle=cycle, seed=seed)
    return best.velocity, np.reshape(best.action, (cycle, 5))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ks", type=float, nargs="+", default=list(GRID_KS), help="grading exponents (-)")
    ap.add_argument("--out", default="results/benchmark", help="output folder")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    crit = critical_loads_grid(a.ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    rows = []
    for k in tqdm(a.ks, desc="CMA-ES near stall"):
        for factor in (1.1, 1.3):
            m = factor * crit[k]
            fixed = best_drive(k, m, 1, [None] + [rng.uniform(-0.9, 0.9, 5) for _ in range(4)], 2000, 16)
            pair = best_drive(k, m, 2, [PUSH_CLAMP, None] + [rng.uniform(-0.9, 0.9, (2, 5))],
                              4000, 20)
            rows.append({"k": k, "factor": factor, "cargo_mass_kg": m,
                         "trapezoid_mm_s": float(open_loop_velocity([(k, m)], trapezoid_action())[0] * 1e3),
                         "best_fixed_mm_s": fixed[0] * 1e3, "best_fixed_action": fixed[1][0].tolist(),
                         "best_pair_mm_s": pair[0] * 1e3, "best_pair_actions": pair[1].tolist()})
    lines = ["| k | load / trapezoid's critical load | cargo mass (kg) | trapezoid (mm/s) | best fixed waveform "
             "(mm/s) | best two-waveform cycle (mm/s) |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['k']:g} | {r['factor']:g} | {r['cargo_mass_kg']:.4f} | {r['trapezoid_mm_s']:.2f} | "
              f"{r['best_fixed_mm_s']:.2f} | {r['best_pair_mm_s']:.2f} |" for r in rows]
    print(write_report(a.out, "stall_limit", lines, rows, t0))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
