#!/usr/bin/env python
"""Pick the training seed to ship by its critical loads at grading exponents off the benchmark grid.

For each policy (one training seed each), the critical load (largest cargo mass below which the
steady velocity stays positive, the benchmark's 64-point load grid refined once) at validation
k values between the benchmark's (default 0.05, 0.15, ..., 0.55), divided by the trapezoid's at
the same k. The selected seed has the largest smallest ratio: the target (critical load >= 1.3x the
trapezoid's at every k) fails on a policy's worst k, and a policy's worst k is where it switches
badly between a fixed waveform and a two-waveform cycle. No benchmark point is used. Also listed:
the mean return on the held-out points of training at its end (``evaluations.npz``), the earlier
rule, and the validation points (``--ks`` x ``VALIDATION_MASSES``) where the policy is slower than
the trapezoid while either moves (not used by the rule). A path ending in ``.npz`` is a CMA-ES
teacher, played as its lookup. Writes ``--out`` (markdown) and prints it.

    python scripts/select_seed.py runs/ppo_bc_s0 runs/ppo_bc_s1 runs/ppo_bc_s2 --out results/benchmark/selection.md
"""

import argparse
import time
from pathlib import Path

import numpy as np

from agents.benchmark import critical_loads_grid
from agents.evaluate import load_policy, open_loop_velocity, policy_velocity, trapezoid_action

VALIDATION_KS = (0.05, 0.15, 0.25, 0.35, 0.45, 0.55)
#: Cargo masses (kg) between the benchmark's, for the below-trapezoid count.
VALIDATION_MASSES = (0.025, 0.075, 0.15, 0.25, 0.35, 0.45)


def critical_load_ratios(policy, ks, trapezoid: dict[float, float]) -> list[float]:
    crit = critical_loads_grid(ks, lambda pts: policy_velocity(policy, pts))
    return [crit[k] / trapezoid[k] for k in ks]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("policies", nargs="+", help="trained policy folders (one per seed), or teacher .npz files")
    ap.add_argument("--ks", type=float, nargs="+", default=list(VALIDATION_KS), help="validation k values (-)")
    ap.add_argument("--out", default=None, help="markdown file to write (default: print only)")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    trap = critical_loads_grid(a.ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    points = [(k, m) for k in a.ks for m in VALIDATION_MASSES]
    v_trap = open_loop_velocity(points, trapezoid_action())
    rows = []
    for path in a.policies:
        policy = load_policy(path)
        ratios = critical_load_ratios(policy, a.ks, trap)
        evals = Path(path) / "evaluations.npz"
        held_out = float(np.load(evals)["results"][-1].mean()) if evals.exists() else float("nan")
        v = policy_velocity(policy, points)
        moving = (v_trap > 0.0) | (v > 0.0)
        below = moving & (v < v_trap)
        worst = float(np.min((v - v_trap)[moving])) * 1e3 if moving.any() else 0.0
        rows.append((path, ratios, held_out, int(below.sum()), worst))
    best = max(rows, key=lambda r: min(r[1]))[0]
    lines = ["Critical load / the trapezoid's at validation k (off the benchmark grid), and the validation "
             f"points (k x m = {', '.join(f'{m:g}' for m in VALIDATION_MASSES)} kg) slower than the trapezoid:", "",
             "| policy | " + " | ".join(f"k = {k:g}" for k in a.ks)
             + " | smallest | held-out return | points below trapezoid (worst, mm/s) |",
             "|---|" + "---|" * (len(a.ks) + 3)]
    for path, ratios, held_out, n_below, worst in rows:
        mark = " (selected)" if path == best else ""
        lines.append(f"| {path}{mark} | " + " | ".join(f"{r:.2f}" for r in ratios)
                     + f" | {min(ratios):.2f} | {held_out:.2f} | {n_below} ({worst:+.2f}) |")
    text = "\n".join(lines) + f"\n\nselected: {best}; wall time {time.perf_counter() - t0:.0f} s\n"
    if a.out:
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
