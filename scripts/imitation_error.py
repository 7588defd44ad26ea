#!/usr/bin/env python
"""How far a distilled policy's drive is from its teacher's, and how often that costs the drive.

    python scripts/imitation_error.py --n 1024 --seed 8080 --field results/recipe/teacher_field.npz \
        agents/pretrained/ppo_generalist

N points drawn as the blind benchmark draws them (k uniform in [0, 0.6], load up to 1.25 times the
trapezoid's critical load). At each, the policy drives closed loop for 30 periods; its last two
actions (its steady cycle) are compared with the teacher's drive there (``teacher_data.teacher_drives``
with the recipe's settings, in whichever phase is closer): the root mean square of the difference
over the 10 entries, in action units. Printed: the error's quantiles, and per band of error the
points where the teacher moves >= 2 mm/s and the share of them where the policy reaches less than
0.85 of the teacher's velocity; then the same share per band of k. With ``--label-spread``, also per
band of how much the teacher's own drive jumps near the point: the largest difference (the largest
entry, in the closer phase) between its drive at the point and at four points beside it (k +- 0.01,
the load times 0.95 and 1.05), where a network fitted to the teacher must blend or switch. A
decision tool for the recipe, like ``scripts/teacher_check.py``: use a decision seed.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ERROR_BANDS = (0.0, 0.01, 0.03, 0.06, 0.1, 0.2, np.inf)
SPREAD_BANDS = (0.0, 0.1, 0.3, 1.0, np.inf)


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policy", type=folder_with("model.zip"), help="policy folder (with model.zip)")
    p.add_argument("--n", type=int_range(1), default=1024, help="blind-domain points (-)")
    p.add_argument("--seed", type=int, required=True, help="seed of the points (-): a decision seed, not a report seed")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--label-spread", action="store_true",
                   help="also the share under 0.85 per band of the teacher's jump near the point (4 x the teacher's time)")
    args = p.parse_args(argv)

    from mdr_drive_agents.blind import MOVING_THRESHOLD, draw_points
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import load_policy, policy_rollout, steady_velocity_of
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    teacher_config = load_recipe(DEFAULT_CONFIG)["distill"]
    points, _ = draw_points(args.n, args.seed)
    field = DriveField.load(args.field)
    teacher, v_teacher = teacher_drives(field, points, teacher_config)
    disp, actions, _ = policy_rollout(load_policy(args.policy), points)
    v = steady_velocity_of(disp)
    cycle = actions[-2:].transpose(1, 0, 2).astype(np.float64)
    rms = np.minimum(np.sqrt(((cycle - teacher) ** 2).mean(axis=(1, 2))),
                     np.sqrt(((cycle - teacher[:, ::-1]) ** 2).mean(axis=(1, 2))))
    moving = v_teacher >= MOVING_THRESHOLD
    short = v[moving] / v_teacher[moving] < 0.85
    rms, ks = rms[moving], np.array([k for k, _ in points])[moving]
    print(f"{args.policy}: {args.n} points of seed {args.seed}, {int(moving.sum())} where the teacher moves >= 2 mm/s; "
          f"{int(short.sum())} of them under 0.85 of the teacher")
    print("rms error of the steady cycle, quantiles 10 / 50 / 90 / 99 %:",
          " / ".join(f"{q:.3f}" for q in np.percentile(rms, [10, 50, 90, 99])))
    print("| rms error | points | under 0.85 of the teacher |\n|---|---|---|")
    for lo, hi in zip(ERROR_BANDS[:-1], ERROR_BANDS[1:]):
        sel = (rms >= lo) & (rms < hi)
        print(f"| {lo:g} - {hi:g} | {int(sel.sum())} | {short[sel].mean() if sel.any() else float('nan'):.3f} |")
    print("| k | points | under 0.85 of the teacher |\n|---|---|---|")
    for lo in np.arange(0.0, 0.6, 0.1):
        sel = (ks >= lo) & (ks < lo + 0.1 + (1e-9 if lo >= 0.5 else 0.0))
        print(f"| {lo:.1f} - {lo + 0.1:.1f} | {int(sel.sum())} | {short[sel].mean() if sel.any() else float('nan'):.3f} |")
    if args.label_spread:
        spread = label_spread(field, points, teacher, teacher_config)[moving]
        print("| the teacher's jump near the point | points | under 0.85 of the teacher |\n|---|---|---|")
        for lo, hi in zip(SPREAD_BANDS[:-1], SPREAD_BANDS[1:]):
            sel = (spread >= lo) & (spread < hi)
            print(f"| {lo:g} - {hi:g} | {int(sel.sum())} | {short[sel].mean() if sel.any() else float('nan'):.3f} |")
    return 0


def label_spread(field, points, teacher: np.ndarray, teacher_config) -> np.ndarray:
    """Per point, the largest entry of the difference (in the closer phase) between the teacher's
    drive ``teacher`` (n, 2, 5) there and at k +- 0.01 (kept in the field's k range) and the load
    times 0.95 and 1.05 (action units)."""
    from mdr_drive_agents.teacher_data import teacher_drives

    lo, hi = float(field.ks[0]), float(field.ks[-1])
    beside = [(float(np.clip(k + dk, lo, hi)), m * f) for k, m in points
              for dk, f in ((-0.01, 1.0), (0.01, 1.0), (0.0, 0.95), (0.0, 1.05))]
    others = teacher_drives(field, beside, teacher_config)[0].reshape(len(points), 4, 2, 5)
    same = np.abs(others - teacher[:, None]).max(axis=(2, 3))
    swapped = np.abs(others - teacher[:, None, ::-1]).max(axis=(2, 3))
    return np.minimum(same, swapped).max(axis=1)


if __name__ == "__main__":
    sys.exit(main())
