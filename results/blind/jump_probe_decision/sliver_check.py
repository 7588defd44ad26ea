#!/usr/bin/env python
"""Slow-start slivers along fine load lines (a decision check, rule in RULE.md).

    python results/blind/jump_probe_decision/sliver_check.py --seed 4343 POLICY...

``--ks`` k values drawn uniformly in [0, 0.6] with ``--seed``; at each, ``--loads`` loads evenly from
``--from`` to ``--to`` times the trapezoid's critical load there (interpolated from the teacher's
field). Per policy: points where its steady velocity (closed loop from the blind start, the
evaluation protocol) is under ``--fraction`` of the teacher's where the teacher moves >= 2 mm/s,
how many separate runs of consecutive loads they make, and each run's k, loads and worst fraction.
"""
from __future__ import annotations

import argparse

import numpy as np

from mdr_drive_agents.blind import FRACTION_TARGET, MOVING_THRESHOLD


def runs_of(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of consecutive True entries."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return list(zip(edges[::2], edges[1::2]))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("policies", nargs="+", help="policy folders (with model.zip)")
    p.add_argument("--seed", type=int, required=True, help="seed of the k values (-): a decision seed")
    p.add_argument("--ks", type=int, default=10, help="k values drawn in [0, 0.6] (-)")
    p.add_argument("--loads", type=int, default=2500, help="loads per k (-)")
    p.add_argument("--from", dest="low", type=float, default=0.3, help="lightest load, times the trapezoid's critical load (-)")
    p.add_argument("--to", dest="high", type=float, default=1.25, help="heaviest load, times the trapezoid's critical load (-)")
    p.add_argument("--fraction", type=float, default=FRACTION_TARGET, help="a point counts under this fraction of the teacher (-)")
    p.add_argument("--field", default="results/recipe/teacher_field.npz", help="the teacher's drive field (.npz)")
    args = p.parse_args()

    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import load_policy, policy_velocity
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    field = DriveField.load(args.field)
    ks = np.sort(np.random.default_rng(args.seed).uniform(0.0, 0.6, args.ks))
    fractions = np.linspace(args.low, args.high, args.loads)
    crit = np.interp(ks, field.ks, field.trapezoid_critical)
    points = [(float(k), float(f * c)) for k, c in zip(ks, crit) for f in fractions]
    _, v_teacher = teacher_drives(field, points, load_recipe(DEFAULT_CONFIG)["distill"])
    v_teacher = v_teacher.reshape(args.ks, args.loads)
    moving = v_teacher >= MOVING_THRESHOLD
    print(f"seed {args.seed}: {args.ks} k values, {args.loads} loads each from {args.low:g} to {args.high:g} of the "
          f"trapezoid's critical load ({moving.sum()} points where the teacher ({args.field}) moves >= {MOVING_THRESHOLD * 1e3:g} mm/s); "
          f"k = {', '.join(f'{k:.4f}' for k in ks)}\n")
    print(f"| policy | points under {args.fraction:g} of the teacher | runs | min fraction | mean fraction |")
    print("|---|---|---|---|---|")
    details = []
    for path in args.policies:
        v = policy_velocity(load_policy(path), points).reshape(args.ks, args.loads)
        frac = np.where(moving, v / np.where(moving, v_teacher, 1.0), np.inf)
        under = frac < args.fraction
        found = [(i, s, e) for i in range(args.ks) for s, e in runs_of(under[i])]
        print(f"| {path} | {int(under.sum())} | {len(found)} | {frac[moving].min():.3f} | {frac[moving].mean():.4f} |",
              flush=True)
        details += [f"{path}: k = {ks[i]:.4f}, loads {fractions[s]:.5f}-{fractions[e - 1]:.5f} ({e - s} points), "
                    f"min {frac[i, s:e].min():.3f} (teacher {v_teacher[i, s:e].max() * 1e3:.2f} mm/s)" for i, s, e in found]
    print("\nRuns of points under the fraction:")
    print("\n".join(f"- {line}" for line in details) or "- none")


if __name__ == "__main__":
    main()
