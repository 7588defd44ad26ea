"""The shipped teacher against the same teacher with polish_stall's search also at the two nodes
lighter than each k line's stall pair (k <= 0.15), on the pool of stored blind searches.

    python results/blind/stall_side_teacher_decision/teacher_variants.py runs/stall_side_teacher.npz
    python results/blind/stall_side_teacher_decision/teacher_variants.py runs/stall_side_k025_teacher.npz 0.25

With a second argument K2: also, at 0.15 < k <= K2, each k line's stall pair and the two nodes
below it.
"""
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from pooled_blind import pooled_points, stored_searches  # noqa: E402

from mdr_drive_agents.blind import MOVING_THRESHOLD, trapezoid_critical  # noqa: E402
from mdr_drive_agents.drive_field import DriveField  # noqa: E402
from mdr_drive_agents.recipe import load_recipe  # noqa: E402
from mdr_drive_agents.teacher_data import teacher_drives  # noqa: E402
from mdr_drive_env.sweep import Executor  # noqa: E402

K_MAX, BUDGET, SIGMA, SEED = 0.15, 1500, 0.3, 975_000
distill = load_recipe(ROOT / "agents/configs/recipe.yaml")["distill"]
shipped = DriveField.load(ROOT / "results/recipe/teacher_field.npz")

out = Path(sys.argv[1])
if out.exists():
    variant = DriveField.load(out)
    print(f"variant read from {out}")
else:
    variant = DriveField.load(ROOT / "results/recipe/teacher_field.npz")
    groups = [[(i, j - d) for i, j in variant.stall_nodes(K_MAX)[::2] for d in (1, 2) if j - d >= 0]]
    if len(sys.argv) > 2:  # the second variant: the stall pair and the two below it at K_MAX < k <= K2
        k2 = float(sys.argv[2])  # a group of its own: search_new_nodes wants as many nodes on every line
        groups.append([(i, j + d) for i, j in variant.stall_nodes(k2)[::2] if variant.ks[i] > K_MAX
                       for d in (-2, -1, 0, 1) if 0 <= j + d < variant.velocities.shape[1]])
    t0, changed = time.perf_counter(), 0
    for n, nodes in enumerate(groups):
        variant.stall_nodes = lambda k_max=None, nodes=nodes: nodes  # polish_stall's search at these nodes
        changed += variant.polish_stall(BUDGET, SIGMA, executor=Executor(progress=False), seed=SEED + n)
    del variant.stall_nodes
    print(f"extra search at {sum(map(len, groups))} nodes: {changed} changed, {time.perf_counter() - t0:.1f} s")
    variant.settle()
    variant.save(out)

searches = stored_searches(sorted((ROOT / "results/blind").glob("*/blind.json")))
points, _, best, _ = pooled_points(searches)
scored = best >= MOVING_THRESHOLD
print(f"pool: {len(searches)} stored searches, {len(points)} points, {int(scored.sum())} where the search moves >= 2 mm/s")
print("| teacher | under 0.85 | under 0.85 at k <= 0.2 | fraction mean | min |")
print("|---|---|---|---|---|")
rows = {}
for name, field in (("shipped (T1)", shipped), ("+ stall-side search", variant)):
    _, v = teacher_drives(field, points, distill)
    frac = np.where(scored, v / np.where(scored, best, 1.0), np.nan)
    under = np.flatnonzero(frac < 0.85)
    rows[name] = frac
    low = [i for i in under if points[i][0] <= 0.2]
    print(f"| {name} | {len(under)} | {len(low)} | {np.nanmean(frac):.4f} | {np.nanmin(frac):.3f} |")
print("\nthe points under 0.85 for either (k, load / trapezoid's critical, fraction shipped -> variant):")
either = np.flatnonzero((rows["shipped (T1)"] < 0.85) | (rows["+ stall-side search"] < 0.85))
either = either[np.argsort([points[i][0] for i in either])]
crit = trapezoid_critical([points[i][0] for i in either])  # only where printed: a bisection per k
for i, c in zip(either, crit):
    print(f"  k = {points[i][0]:.4f}, {points[i][1] / c:.3f}: {rows['shipped (T1)'][i]:.3f} -> "
          f"{rows['+ stall-side search'][i]:.3f}")
