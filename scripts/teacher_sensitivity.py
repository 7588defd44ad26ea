#!/usr/bin/env python
"""How sensitive the teacher's drives are to small action errors, on blind-domain points.

    python scripts/teacher_sensitivity.py --n 384 --seed 99001 --sigma 0.02 0.05

At N points drawn as the blind benchmark draws them, the teacher's drive (``DriveField.best`` with
the recipe's ``teacher_radius``) is played as it is and with ``--draws`` Gaussian perturbations of every action
entry (standard deviation SIGMA, action units, clipped to [-1, 1]). Printed per SIGMA, over the points
where the teacher moves >= 2 mm/s: how many lose more than half their velocity in the worst draw,
how many go backwards, and the median of worst over nominal. A student fitted to these drives makes
errors of this size; where the drive is this sensitive, it fails.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("--n", type=int_range(1), default=384, help="blind-domain points (-)")
    p.add_argument("--seed", type=int, required=True, help="seed of the points and the perturbations (-)")
    p.add_argument("--sigma", type=float, nargs="+", default=[0.02, 0.05],
                   help="standard deviations of the action perturbation (action units, (0, 1])")
    p.add_argument("--draws", type=int_range(1), default=4, help="perturbed plays per point (-)")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    args = p.parse_args(argv)
    for sigma in args.sigma:
        if not 0.0 < sigma <= 1.0:
            p.error(f"--sigma {sigma!r} is outside the allowed range (0, 1]")

    from mdr_drive_agents.blind import MOVING_THRESHOLD, draw_points
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    points, _ = draw_points(args.n, args.seed)
    drives, v = teacher_drives(DriveField.load(args.field), points, load_recipe(DEFAULT_CONFIG)["distill"])
    moving = v >= MOVING_THRESHOLD
    rng = np.random.default_rng(args.seed)
    print(f"{args.n} points of seed {args.seed}; {int(moving.sum())} where the teacher moves >= 2 mm/s; "
          f"{args.draws} perturbed plays each")
    print("| sigma | worst play < 0.5 of nominal | worst play backwards | median worst / nominal |")
    print("|---|---|---|---|")
    for sigma in args.sigma:
        noisy = np.clip(np.repeat(drives, args.draws, axis=0) + rng.normal(0.0, sigma, (len(drives) * args.draws, 2, 5)),
                        -1.0, 1.0)
        vp = open_loop_velocity([pt for pt in points for _ in range(args.draws)], noisy).reshape(len(drives), args.draws)
        worst = vp.min(axis=1)[moving]
        print(f"| {sigma:g} | {int((worst < 0.5 * v[moving]).sum())} | {int((worst < 0.0).sum())} | "
              f"{float(np.median(worst / v[moving])):.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
