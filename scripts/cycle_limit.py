#!/usr/bin/env python
"""The critical load of the best two-waveform cycle, and how precisely a drive must play it.

For each k, a bisection on the cargo mass from the trapezoid's critical load up (the upper end
starts at 1.8x and doubles while the cycle still moves there; ``agents.baselines.cycle_critical_load``):
at every trial load CMA-ES searches two-action cycles (period t uses action t mod 2; 1,500
evaluations, popsize 16, from the "push/clamp" pair and from the best cycle of the previous trial)
and the load counts as moved if the best steady velocity found is > 0.
The result is the largest load any drive found here moves, as a multiple of the trapezoid's
critical load: the reference for the learned policies' critical loads (a policy that plays the
best cycle exactly reaches it; a fixed waveform cannot pass about 1.0x at k >= 0.2, see
``stall_limit.py``).

Then, at 1.25x the trapezoid's critical load, the velocity lost when one component of that
cycle's actions moves by -0.05 or +0.05 (action units; the box is [-1, 1]) with the others held:
how far a policy may stray from the optimum before its margin is gone. Writes
results/benchmark/cycle_limit.{md,json}.

    python scripts/cycle_limit.py [--ks 0 0.1 0.2 0.3 0.4 0.5 0.6] [--iterations 8] [--out results/benchmark]
"""

import argparse
import time

import numpy as np
from tqdm import tqdm

from mdr_drive_agents.baselines import cycle_critical_load
from mdr_drive_agents.benchmark import GRID_KS, critical_loads_grid, write_report
from mdr_drive_agents.evaluate import ACTION_MAP, open_loop_velocity, trapezoid_action

#: Action perturbation of the sensitivity table (action units).
DELTA = 0.05


def sensitivity(k: float, m: float, cycle: np.ndarray) -> dict[str, list[float]]:
    """Velocity change (mm/s) per perturbed component: {"push x_amplitude": [at -DELTA, at +DELTA], ...}."""
    names = [f"{period} {name}" for period in ("push", "clamp") for name in ACTION_MAP.NAMES]
    trials = []
    for i in range(2):
        for j in range(5):
            for d in (-DELTA, DELTA):
                c = cycle.copy()
                c[i, j] = np.clip(c[i, j] + d, -1.0, 1.0)
                trials.append(c)
    base = open_loop_velocity([(k, m)], cycle[None])[0]
    v = open_loop_velocity([(k, m)] * len(trials), np.array(trials))
    dv = ((v - base) * 1e3).reshape(10, 2)
    return {name: dv[i].tolist() for i, name in enumerate(names)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ks", type=float, nargs="+", default=list(GRID_KS), help="grading exponents (-)")
    ap.add_argument("--iterations", type=int, default=8, help="bisection steps per k (-)")
    ap.add_argument("--out", default="results/benchmark", help="output folder")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    crit = critical_loads_grid(a.ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    rows = []
    for k in tqdm(a.ks, desc="cycle critical load"):
        m, cycle = cycle_critical_load(k, crit[k], a.iterations)
        m125 = 1.25 * crit[k]
        v125 = float(open_loop_velocity([(k, m125)], cycle[None])[0])
        rows.append({"k": k, "trapezoid_critical_kg": crit[k], "cycle_critical_kg": m,
                     "ratio": m / crit[k] if crit[k] > 0 else float("nan"), "cycle": cycle.tolist(),
                     "velocity_at_1.25_mm_s": v125 * 1e3, "sensitivity_at_1.25_mm_s": sensitivity(k, m125, cycle)})
    lines = [f"Critical load of the best two-waveform cycle found (bisection, {a.iterations} steps in "
             "1.0-1.8x the trapezoid's; CMA-ES at every trial load):", "",
             "| k | trapezoid (kg) | best cycle (kg) | ratio | cycle velocity at 1.25x (mm/s) |",
             "|---|---|---|---|---|"]
    lines += [f"| {r['k']:g} | {r['trapezoid_critical_kg']:.4f} | {r['cycle_critical_kg']:.4f} | {r['ratio']:.3f} | "
              f"{r['velocity_at_1.25_mm_s']:.3f} |" for r in rows]
    names = list(rows[0]["sensitivity_at_1.25_mm_s"])
    lines += ["", f"Velocity change (mm/s) at 1.25x when one action component of that cycle moves by "
              f"-{DELTA:g} / +{DELTA:g} (clipped to the box):", "",
              "| k | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for r in rows:
        cells = (f"{lo:+.3f} / {hi:+.3f}" for lo, hi in r["sensitivity_at_1.25_mm_s"].values())
        lines.append(f"| {r['k']:g} | " + " | ".join(cells) + " |")
    print(write_report(a.out, "cycle_limit", lines, rows, t0))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
