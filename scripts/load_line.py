#!/usr/bin/env python
"""Policies and the teacher along a line of load at one k: where a policy stalls and the teacher moves.

    python scripts/load_line.py --k 0.5 --from 0.9 --to 1.0 --loads 21 agents/pretrained/ppo_generalist

Loads evenly spaced from FROM to TO times the trapezoid's critical load at K (as the teacher's grid
is spaced; interpolated from ``--field``). Per load: the teacher's steady velocity (the best of its
drives around the point, ``teacher_drives`` with the recipe's settings) and each policy's
(closed loop, the evaluation protocol's 30 periods, mean of 21-30), in mm/s, a row marked ``<<``
where a policy stalls (<= 0) and the teacher moves. ``--labels`` adds the teacher's drive there
(its two actions' ten entries, action units): where it jumps between loads a student fitted to it
must change its action quickly, and stalls while it does. A critical-load scan stops at the first
such stall, so these narrow pockets are what the blind benchmark's critical-load target measures.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policies", nargs="*", type=folder_with("model.zip"), help="policy folders (with model.zip)")
    p.add_argument("--k", type=float, required=True, help="grading exponent k (-), in the field's range")
    p.add_argument("--from", dest="low", type=float, default=0.8,
                   help="lightest load, times the trapezoid's critical load at k (-)")
    p.add_argument("--to", dest="high", type=float, default=1.4,
                   help="heaviest load, times the trapezoid's critical load at k (-)")
    p.add_argument("--loads", type=int_range(2), default=61, help="loads on the line (-)")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--labels", action="store_true", help="also print the teacher's drive at each load")
    args = p.parse_args(argv)
    if not 0.0 <= args.low < args.high <= 5.0:
        p.error(f"--from {args.low!r} --to {args.high!r}: need 0 <= FROM < TO <= 5")

    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import load_policy, policy_velocity
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    field = DriveField.load(args.field)
    if not field.ks[0] <= args.k <= field.ks[-1]:
        p.error(f"--k {args.k!r} is outside the field's range [{field.ks[0]:g}, {field.ks[-1]:g}]")
    teacher_config = load_recipe(DEFAULT_CONFIG)["distill"]
    crit = float(np.interp(args.k, field.ks, field.trapezoid_critical))
    fractions = np.linspace(args.low, args.high, args.loads)
    points = [(args.k, float(f * crit)) for f in fractions]
    drives, v_teacher = teacher_drives(field, points, teacher_config)
    v_policies = [policy_velocity(load_policy(path), points) for path in args.policies]
    print(f"k = {args.k:g}; the trapezoid's critical load {crit:.5g} kg; velocities in mm/s")
    head = ["load / trapezoid's critical", "load (kg)", "teacher", *(str(path) for path in args.policies)]
    print("| " + " | ".join(head + (["teacher's drive"] if args.labels else [])) + " |")
    print("|" + "---|" * (len(head) + args.labels))
    for i, (f, (_, m)) in enumerate(zip(fractions, points)):
        row = [f"{f:.4f}", f"{m:.5g}", f"{v_teacher[i] * 1e3:.3f}", *(f"{v[i] * 1e3:.3f}" for v in v_policies)]
        if args.labels:
            row.append(" ".join(f"{x:+.2f}" for x in drives[i].ravel()))
        stall = v_teacher[i] > 0.0 and any(v[i] <= 0.0 for v in v_policies)
        print("| " + " | ".join(row) + " |" + (" <<" if stall else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
