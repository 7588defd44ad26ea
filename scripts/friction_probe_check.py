#!/usr/bin/env python
"""Can a drive that knows k and the load but not friction do without it? Robust drives and probing.

    python scripts/friction_probe_check.py results/adaptation/seed8888_decision/adaptation.json \
        results/recipe/teacher_field.npz results/adaptation/friction_fields/rho*.npz --probe-periods 2 4 6

The sensor policy reads k and the load off the slider's motion to a few per cent, friction hardly at
all (docs/adaptation.md), and the best drive depends much on the ratio ``rho = mu1 / mu``. This
script asks, at the draws of an adaptation report (``python -m mdr_drive_agents.adaptation``),
what a drive told the true k and load over mu F_ref, but not friction, could reach, open loop:

* **one drive per rho**: at each field's ratio (the drive fields given, each searched at one
  friction, ``agents.friction_teacher``), that field's best drive for the draw's k and load over mu
  F_ref (``DriveField.best`` at the field's friction, ``--radius``); the *told-rho* row plays the
  best of them at the draw's own friction (an upper bound: it knows the velocity each gives);
* **robust drives, no probing**: the one of those drives whose worst (``max-min``) or mean
  (``max-mean``) shortfall against the best of them, over the fields' ratios (each played at its
  field's friction at the same load over mu F_ref), is smallest; the choice a teacher made robust
  over friction would make;
* **probe, then pick**: each of those drives played from rest at the draw for P periods, the one
  whose last two periods move the slider furthest kept (P = ``--probe-periods``; the probes of all
  drives take their number times P periods, within the 20 before the protocol measures);
  ``--sequential`` plays them one after another in one run instead, as a policy would.

Each row: the steady velocity at the draw's friction (the protocol's 30 periods, mean of 21-30)
with the blind statistics: points below the trapezoid (more than 0.05 mm/s, where either moves),
the fraction of the best drive (the report's, or any drive here that beats it) where that moves at
least 2 mm/s. The report's sensor and full-observation policies are printed for scale. A decision
tool: use a decision seed's report; it assumes k and the load known exactly.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def per_rho_drives(fields, points, radius: int) -> np.ndarray:
    """(n, f, 2, 5): at each (k, load kg, mu, mu1) point, each field's best drive at its own friction
    for the point's k and load over mu F_ref."""
    drives = []
    for f in fields:
        at_field = [(p[0], f.field_load(p), *f.friction) for p in points]
        drives.append(f.best(at_field, radius=radius)[0])
    return np.stack(drives, axis=1)


def robust_choice(fields, points, drives: np.ndarray) -> dict[str, np.ndarray]:
    """Per point, the index of the drive whose shortfall against the best of them over the fields'
    frictions (at the point's load over mu F_ref) is smallest at worst (``max-min``) and on average
    (``max-mean``); the shortfall is relative to that best, or to 2 mm/s where it moves less."""
    from mdr_drive_agents.blind import MOVING_THRESHOLD
    from mdr_drive_agents.evaluate import open_loop_velocity

    n, nf = drives.shape[:2]
    trials = [(p[0], f.field_load(p), *f.friction) for p in points for f in fields for _ in range(nf)]
    acts = np.concatenate([np.tile(d, (len(fields), 1, 1)) for d in drives])
    v = open_loop_velocity(trials, acts).reshape(n, len(fields), nf)  # point, friction, drive
    best = v.max(axis=2, keepdims=True)
    shortfall = (best - v) / np.maximum(best, MOVING_THRESHOLD)
    return {"max-min": shortfall.max(axis=1).argmin(axis=1), "max-mean": shortfall.mean(axis=1).argmin(axis=1)}


def probe_choice(points, drives: np.ndarray, periods: int, sequential: bool = False) -> np.ndarray:
    """Per point, the index of the drive that moves the slider furthest in the last two of ``periods``
    periods played at the point: each from rest, or (``sequential``) one after another in one run, each
    starting where the one before left the slider."""
    from mdr_drive_agents.evaluate import open_loop_displacements

    n, nf = drives.shape[:2]
    if sequential:
        schedule = np.stack([drives[:, j, t % 2] for j in range(nf) for t in range(periods)], axis=1)
        disp, _ = open_loop_displacements(points, schedule, nf * periods)
        ends = [j * periods + periods for j in range(nf)]
        return np.stack([disp[e - 2:e].sum(axis=0) for e in ends], axis=1).argmax(axis=1)
    disp, _ = open_loop_displacements([p for p in points for _ in range(nf)], drives.reshape(n * nf, 2, 5), periods)
    return disp[-2:].sum(axis=0).reshape(n, nf).argmax(axis=1)


def main(argv=None) -> int:
    import json

    from mdr_drive_env.cli_args import Parser, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("adaptation", type=input_file, help="an adaptation.json (written by mdr_drive_agents.adaptation)")
    p.add_argument("fields", nargs="+", type=input_file, help="drive fields (.npz), each searched at one friction")
    p.add_argument("--radius", type=int_range(1), default=2, help="each field's grid neighbourhood (-)")
    p.add_argument("--probe-periods", type=int_range(2), nargs="+", default=[2, 4, 6], metavar="P",
                   help="periods each drive is probed for (-)")
    p.add_argument("--sequential", action="store_true",
                   help="probe the drives one after another in one run (each from the state the one before "
                        "left), not each from rest")
    p.add_argument("--limit", type=int_range(1), default=None, help="only the report's first N draws (-)")
    args = p.parse_args(argv)

    from mdr_drive_agents.adaptation import FRACTION_FLOOR, hidden_point
    from mdr_drive_agents.blind import MOVING_THRESHOLD, velocity_statistics
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import open_loop_velocity

    res = json.loads(Path(args.adaptation).read_text())
    draws = res["points"][:args.limit]
    points = [hidden_point(d) for d in draws]
    n = len(points)
    fields = sorted((DriveField.load(f) for f in args.fields), key=lambda f: f.friction[1] / f.friction[0])
    drives = per_rho_drives(fields, points, args.radius)
    nf = drives.shape[1]
    v = open_loop_velocity([q for q in points for _ in range(nf)], drives.reshape(n * nf, 2, 5)).reshape(n, nf)
    rows = {"told rho: the best of the drives": v.max(axis=1)}
    rows.update({f"robust, {name}": v[np.arange(n), pick]
                 for name, pick in robust_choice(fields, points, drives).items()})
    rows.update({f"probe {P} periods each{', in turn' if args.sequential else ''}, then pick":
                 v[np.arange(n), probe_choice(points, drives, P, args.sequential)] for P in args.probe_periods})
    rows.update({name: np.asarray(res["steady_velocity_m_s"][name][:n], dtype=np.float64)
                 for name in ("sensor policy", "full-observation policy")})
    best = np.asarray(res["best_velocity_m_s"][:n], dtype=np.float64)
    best = np.fmax(best, rows["told rho: the best of the drives"])
    trap = np.asarray(res["steady_velocity_m_s"]["trapezoid"][:n], dtype=np.float64)
    rhos = ", ".join(f"{f.friction[1] / f.friction[0]:.3f}" for f in fields)
    print(f"{n} draws of seed {res['seed']}; drives of the fields at mu1 / mu = {rhos}; k and the load told exactly")
    print(f"| drive (open loop) | below the trapezoid (worst mm/s) | fraction of best: mean / min | "
          f"under {FRACTION_FLOOR:g} (of scored) |")
    print("|---|---|---|---|")
    scored = best >= MOVING_THRESHOLD
    for name, vel in rows.items():
        s = velocity_statistics(trap, best, vel)
        under = int((np.nan_to_num(vel)[scored] / best[scored] < FRACTION_FLOOR).sum())
        print(f"| {name} | {s['points_below_trapezoid']} ({s['worst_difference_to_trapezoid_mm_s']:.3f}) | "
              f"{s['fraction_of_best_mean']:.3f} / {s['fraction_of_best_min']:.3f} | {under} ({s['points_scored']}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
