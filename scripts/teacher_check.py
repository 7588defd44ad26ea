#!/usr/bin/env python
"""Policies against the recipe's teacher on many blind-domain points, without per-point searches.

    python scripts/teacher_check.py --n 192 --seed 7717 --field results/recipe/teacher_field.npz \
        agents/pretrained/ppo_generalist runs/recipe/policy

A cheaper check than ``mdr-drive benchmark --blind`` for deciding between recipe variants: N points
drawn as the blind benchmark draws them (k uniform in [0, 0.6], load up to 1.25 times the
trapezoid's critical load), and as the reference at each point, instead of a CMA-ES search, the
best of the teacher's grid drives around it (``DriveField.best`` with a radius of 3: the
interpolation and the 6 x 6 nearest grid drives, played at the point) or any drive here that beats
it. Per policy, with the blind benchmark's statistics: points below the trapezoid by more than
0.05 mm/s (where either moves), the fraction of that reference where it moves >= 2 mm/s (mean,
minimum, points under 0.85), and the critical load over the trapezoid's at six k values. The reference is weaker than the benchmark's search, so fractions
read higher here; use it to compare policies, and report on ``mdr-drive benchmark --blind``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SCAN_KS = (0.05, 0.15, 0.25, 0.35, 0.45, 0.55)


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policies", nargs="+", type=folder_with("model.zip"), help="policy folders (with model.zip)")
    p.add_argument("--n", type=int_range(1), default=192, help="blind-domain points (-)")
    p.add_argument("--seed", type=int, required=True, help="seed of the points (-): a decision seed, not a report seed")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    args = p.parse_args(argv)

    from mdr_drive_agents.blind import MOVING_THRESHOLD, draw_points, trapezoid_critical, velocity_statistics
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import (
        critical_loads_grid,
        load_policy,
        open_loop_velocity,
        policy_velocity,
        trapezoid_action,
    )

    points, _ = draw_points(args.n, args.seed)
    trap = open_loop_velocity(points, trapezoid_action())
    _, teacher = DriveField.load(args.field).best(points, radius=3)
    learned = {path: policy_velocity(load_policy(path), points) for path in args.policies}
    reference = np.fmax(np.fmax(trap, teacher), np.max(list(learned.values()), axis=0))
    scored = reference >= MOVING_THRESHOLD
    crit_trap = trapezoid_critical(list(SCAN_KS))
    print(f"{args.n} points of seed {args.seed}; reference: the teacher's 6 x 6 neighbourhood ({args.field}) "
          f"or any better drive; {int(scored.sum())} points where it moves >= 2 mm/s")
    print("| policy | below the trapezoid (worst, mm/s) | fraction of the reference: mean / min | under 0.85 | "
          "critical load / trapezoid's at k = " + ", ".join(f"{k:g}" for k in SCAN_KS) + " |")
    print("|---|---|---|---|---|")
    for path, v in learned.items():
        stats = velocity_statistics(trap, reference, v)  # the blind benchmark's statistics, against this reference
        fraction = v[scored] / reference[scored]
        policy = load_policy(path)
        crit = critical_loads_grid(list(SCAN_KS), lambda pts, pol=policy: policy_velocity(pol, pts))
        ratios = ", ".join(f"{crit[k] / c:.2f}" for k, c in zip(SCAN_KS, crit_trap))
        print(f"| {path} | {stats['points_below_trapezoid']} ({stats['worst_difference_to_trapezoid_mm_s']:.2f}) | "
              f"{stats['fraction_of_best_mean']:.3f} / {stats['fraction_of_best_min']:.3f} | "
              f"{int((fraction < 0.85).sum())} | {ratios} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
