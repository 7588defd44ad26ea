#!/usr/bin/env python
"""Is a 1.3x critical load reachable with any fixed waveform? A wide CMA-ES search near stall.

For each k, at cargo masses of 1.1x and 1.3x the trapezoid's critical load, it runs CMA-ES from the
trapezoid and from 4 random starts (2,000 evaluations each, popsize 16) over the env's action box
and reports the best steady velocity found (the trapezoid counts as a candidate). Writes results/benchmark/stall_limit.{md,json}.

    python scripts/stall_limit.py [--ks 0 0.1 0.2 0.3] [--out results/benchmark]
"""

import argparse
import json
import time
from pathlib import Path

import cma
import numpy as np
from tqdm import tqdm

from agents.benchmark import critical_loads_grid
from agents.evaluate import open_loop_velocity, trapezoid_action


def best_fixed_waveform(k: float, m: float, restarts: int = 4, budget: int = 2000, seed: int = 0) -> float:
    rng = np.random.default_rng(seed)
    starts = [np.clip(trapezoid_action(), -0.95, 0.95)] + [rng.uniform(-0.9, 0.9, 5) for _ in range(restarts)]
    best = float(open_loop_velocity([(k, m)], trapezoid_action())[0])  # the trapezoid is a candidate too
    for x0 in starts:
        es = cma.CMAEvolutionStrategy(list(x0), 0.6, {"bounds": [-1, 1], "popsize": 16, "maxfevals": budget,
                                                       "verbose": -9, "seed": int(rng.integers(1 << 30))})
        while not es.stop():
            xs = np.clip(np.array(es.ask()), -1, 1)
            v = open_loop_velocity([(k, m)] * len(xs), xs)
            es.tell(list(xs), list(-v))
            best = max(best, float(v.max()))
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ks", type=float, nargs="+", default=[0.0, 0.1, 0.2, 0.3], help="grading exponents (-)")
    ap.add_argument("--out", default="results/benchmark", help="output folder")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    crit = critical_loads_grid(a.ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    rows = []
    for k in tqdm(a.ks, desc="CMA-ES near stall"):
        for factor in (1.1, 1.3):
            m = factor * crit[k]
            rows.append({"k": k, "factor": factor, "cargo_mass_kg": m,
                         "trapezoid_mm_s": float(open_loop_velocity([(k, m)], trapezoid_action())[0] * 1e3),
                         "best_fixed_mm_s": best_fixed_waveform(k, m) * 1e3})
    lines = ["| k | load / trapezoid's critical load | cargo mass (kg) | trapezoid (mm/s) | best fixed waveform, "
             "5 x 2000 CMA-ES evaluations (mm/s) |", "|---|---|---|---|---|"]
    lines += [f"| {r['k']:g} | {r['factor']:g} | {r['cargo_mass_kg']:.4f} | {r['trapezoid_mm_s']:.2f} | "
              f"{r['best_fixed_mm_s']:.2f} |" for r in rows]
    text = "\n".join(lines) + f"\n\nwall time {time.perf_counter() - t0:.0f} s\n"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "stall_limit.md").write_text(text)
    (out / "stall_limit.json").write_text(json.dumps(rows, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
