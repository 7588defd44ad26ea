#!/usr/bin/env python
"""The CMA-ES teacher played as a policy: how much of the critical-load target a lookup table meets.

The lookup (``agents.residual.TeacherLookup``) plays, at every period, the drive of the teacher's
point nearest to the drive's (k, load ratio) (the metric of ``agents.reward_scale``), in the phase
that follows the previous action: after a period close to the drive's first action it plays the
second, else the first. It is what a policy cloned perfectly from the teacher would do, without
any interpolation between points.
Reported: its critical load / the trapezoid's (the benchmark's load grid and refinement) at each
k, and its steady velocity along the load at the k values of ``--profile-ks``. Writes
``teacher_lookup.{md,json}`` into ``--out``.

    python scripts/teacher_lookup.py runs/teacher4.npz runs/teacher6.npz --out results/benchmark
"""

import argparse
import time

import numpy as np

from agents.benchmark import GRID_KS, critical_loads_grid, write_report
from agents.evaluate import open_loop_velocity, policy_velocity, trapezoid_action
from agents.residual import TeacherLookup


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("teachers", nargs="+", help="teacher files (python -m agents.teacher)")
    ap.add_argument("--ks", type=float, nargs="+", default=list(GRID_KS), help="grading exponents (-)")
    ap.add_argument("--profile-ks", type=float, nargs="*", default=[0.0], help="k values of the load profile (-)")
    ap.add_argument("--out", default="results/benchmark", help="output folder")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    ks = sorted(set(a.ks) | set(a.profile_ks))
    trap = critical_loads_grid(ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    fractions = np.round(np.arange(0.0, 1.61, 0.1), 2)
    rows = []
    for path in a.teachers:
        lookup = TeacherLookup.from_teacher(dict(np.load(path)))
        crit = critical_loads_grid(a.ks, lambda pts: policy_velocity(lookup, pts))
        profile = {k: (policy_velocity(lookup, [(k, f * trap[k]) for f in fractions]) * 1e3).tolist()
                   for k in a.profile_ks}
        rows.append({"teacher": path, "ratio": {k: crit[k] / trap[k] for k in a.ks}, "profile_mm_s": profile})
    lines = ["Critical load of the teacher played as a lookup policy / the trapezoid's:", "",
             "| teacher | " + " | ".join(f"k = {k:g}" for k in a.ks) + " |", "|---|" + "---|" * len(a.ks)]
    lines += [f"| {r['teacher']} | " + " | ".join(f"{r['ratio'][k]:.3f}" for k in a.ks) + " |" for r in rows]
    for k in a.profile_ks:
        lines += ["", f"Steady velocity (mm/s) of the lookup at k = {k:g} against the load / the trapezoid's "
                  "critical load:", "", "| teacher | " + " | ".join(f"{f:g}" for f in fractions) + " |",
                  "|---|" + "---|" * len(fractions)]
        lines += [f"| {r['teacher']} | " + " | ".join(f"{v:+.2f}" for v in r["profile_mm_s"][k]) + " |" for r in rows]
    print(write_report(a.out, "teacher_lookup", lines, rows, t0))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
