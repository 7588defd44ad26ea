#!/usr/bin/env python
"""The friction-aware teacher's drive fields against an adaptation report's per-point best drives.

    python scripts/friction_teacher_check.py results/adaptation/seed1777_validation/adaptation.json \
        results/recipe/teacher_field.npz runs/friction_teacher/fields/rho*.npz

At the blind draws of an adaptation report (``python -m mdr_drive_agents.adaptation``: k, load, mu
and mu1 hidden and drawn), the teacher ``FrictionField.best`` (the fields given, ``--radius``)
plays its drive, open loop, at the draw's own friction; printed: its steady velocity as a fraction
of the report's best drive where that moves >= 2 mm/s (mean, minimum, draws under 0.75), beside the
report's full-observation and sensor policies (a runaway counts as no motion), overall and by the draw's ratio mu1 / mu. Only the
fields given are used, so ``results/recipe/teacher_field.npz`` alone is the paper-friction teacher
read at each draw's load over mu F_ref. A decision tool: use a decision seed's report.

``--scaling N`` first replays the report's best drive at each of its first N draws, open loop: at
the draw's friction; at mu = 0.3 with mu1 and the load scaled by 0.3 / mu (the same ratio mu1 / mu
and load over mu F_ref); and with mu1 1.3 times larger and smaller. Why the teacher is searched
along mu1 / mu only.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    import json

    from mdr_drive_env.cli_args import Parser, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("adaptation", type=input_file, help="an adaptation.json (written by mdr_drive_agents.adaptation)")
    p.add_argument("fields", nargs="+", type=input_file, help="drive fields (.npz) of the teacher")
    p.add_argument("--radius", type=int_range(1), default=2, help="the teacher's grid neighbourhood (-)")
    p.add_argument("--scaling", type=int_range(0), default=0, metavar="N",
                   help="first replay the best drives of the first N draws at scaled friction (-)")
    args = p.parse_args(argv)

    from mdr_drive_agents.adaptation import FRACTION_FLOOR, hidden_point
    from mdr_drive_agents.blind import MOVING_THRESHOLD
    from mdr_drive_agents.friction_teacher import FrictionField

    res = json.loads(Path(args.adaptation).read_text())
    points = [hidden_point(d) for d in res["points"]]
    if args.scaling:
        print_scaling(res["points"][:args.scaling], res["best_search"][:args.scaling])
    best = np.asarray(res["best_velocity_m_s"], dtype=np.float64)
    _, teacher = FrictionField.load(args.fields).best(points, radius=args.radius)
    scored = best >= MOVING_THRESHOLD
    best = np.where(scored, np.fmax(best, teacher), best)  # the teacher may beat the report's best
    rho = np.array([p[3] / p[2] for p in points])
    rows = {"friction-aware teacher (fields)": teacher,
            # a runaway (NaN) counts as no motion, as in the blind statistics (agents.blind.velocity_statistics)
            **{name: np.nan_to_num(np.asarray(res["steady_velocity_m_s"][name], dtype=np.float64), nan=0.0)
               for name in ("full-observation policy", "sensor policy")}}
    bands = [("all", np.ones_like(rho, dtype=bool)), ("mu1/mu < 0.28", rho < 0.28),
             ("0.28 ... 0.40", (rho >= 0.28) & (rho < 0.40)), (">= 0.40", rho >= 0.40)]
    print(f"{len(points)} draws of seed {res['seed']}, {int(scored.sum())} where the best drive moves >= 2 mm/s; "
          f"fields: {', '.join(map(str, args.fields))}")
    print("| drive | " + " | ".join(f"{name}: mean / min / under {FRACTION_FLOOR:g} (n)" for name, _ in bands) + " |")
    print("|---|" + "---|" * len(bands))
    for name, v in rows.items():
        cells = []
        for _, band in bands:
            keep = scored & band
            frac = v[keep] / best[keep]
            cells.append(f"{frac.mean():.3f} / {frac.min():.3f} / {int((frac < FRACTION_FLOOR).sum())} ({int(keep.sum())})"
                         if keep.any() else "-")
        print(f"| {name} | " + " | ".join(cells) + " |")
    return 0


def print_scaling(draws: list[dict], searched: list[dict]) -> None:
    """Each searched best drive (the report's ``best_search`` entries) replayed at its draw (the
    report's ``points`` entries) and at scaled friction (``--scaling``), in mm/s."""
    from mdr_drive_agents.adaptation import hidden_point
    from mdr_drive_agents.evaluate import open_loop_velocity

    print("| k | load / (mu F_ref) | mu | mu1 / mu | at the draw | mu = 0.3, same ratio and load / (mu F_ref) | "
          "mu1 x 1.3 | mu1 / 1.3 |")
    print("|---|---|---|---|---|---|---|---|")
    for d, found in zip(draws, searched):
        k, m, mu, mu1 = hidden_point(d)
        drive = np.asarray(found["action"], dtype=np.float64).reshape(-1, 5)
        s = 0.3 / mu
        trials = [(k, m, mu, mu1), (k, m * s, 0.3, mu1 * s), (k, m, mu, mu1 * 1.3), (k, m, mu, mu1 / 1.3)]
        v = open_loop_velocity(trials, np.repeat(drive[None], len(trials), axis=0)) * 1e3
        print(f"| {k:.3f} | {d['load_ratio']:.3f} | {mu:.3f} | {mu1 / mu:.2f} | " + " | ".join(f"{x:.2f}" for x in v) + " |")
    print()


if __name__ == "__main__":
    raise SystemExit(main())
