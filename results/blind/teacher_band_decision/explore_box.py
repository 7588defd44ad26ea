"""Exploration: polish the shipped teacher's nodes in a box of k and load with the stall polish's search,
and measure the teacher against the per-point searches of stored blind points (decision data).

    PYTHONPATH=. python results/blind/teacher_band_decision/explore_box.py --k 0.15 0.275 --fractions 0.84 1.38 \
        --budget 1500 --sigma 0.3 --out runs/teacher_box.npz

The stored points: the searched blind points of report seeds 20261207-24 (all used for decisions
since), where the best drive moves >= 2 mm/s. The teacher at a point: ``DriveField.best`` with radius
2 (the student's labels).
"""
import argparse, csv, time
import numpy as np
from agents.drive_field import DriveField
from agents.field_search import search_new_nodes
from agents.baselines import PUSH_CLAMP
from agents.cycles import align_phase

ap = argparse.ArgumentParser()
ap.add_argument("--field", default="results/recipe/teacher_field.npz")
ap.add_argument("--k", type=float, nargs=2, required=True)
ap.add_argument("--fractions", type=float, nargs=2, required=True)
ap.add_argument("--budget", type=int, default=1500)
ap.add_argument("--sigma", type=float, default=0.3)
ap.add_argument("--starts", type=int, default=3)
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--out", required=True)
a = ap.parse_args()

f = DriveField.load(a.field)
old = DriveField.load(a.field)
nk = len(f.ks)
lines = {}
for i, k in enumerate(f.ks):
    if not a.k[0] - 1e-9 <= k <= a.k[1] + 1e-9:
        continue
    for j, fr in enumerate(f.fractions):
        if not a.fractions[0] - 1e-9 <= fr <= a.fractions[1] + 1e-9:
            continue
        own = f.drives[i, j]
        trials = [own, align_phase(PUSH_CLAMP, own)] + [align_phase(f.drives[x, y], own) for x, y in
                                                        ((i, j - 1), (i, j + 1), (i - 1, j), (i + 1, j)) if 0 <= x < nk and 0 <= y < len(f.fractions)]
        lines.setdefault(i, []).append(((j, f.point(i, j)[:2]), np.array(trials)))
n_nodes = sum(map(len, lines.values()))
t0 = time.perf_counter()
found_d, found_v = search_new_nodes([[(p, t) for (_, p), t in line] for line in lines.values()], a.budget, a.sigma,
                                    a.starts, a.seed, f.friction, "teacher: polish box")
wall = time.perf_counter() - t0
changed = 0
for (i, line), drives, vel in zip(lines.items(), found_d, found_v):
    for ((j, _), _), d, v in zip(line, drives, vel):
        if v > f.velocities[i, j] * (1 + 1e-3) + 1e-6:
            f.drives[i, j], f.velocities[i, j] = d, v
            changed += 1
print(f"nodes {n_nodes}, changed {changed}, search wall time {wall:.1f} s")
f.save(a.out)

pts, best = [], []
for s in range(20261207, 20261225):
    for r in csv.DictReader(open(f"results/blind/seed{s}_drawn_scan/points.csv")):
        if float(r["best_m_s"]) >= 2e-3:
            pts.append((float(r["k"]), float(r["cargo_mass_kg"])))
            best.append(float(r["best_m_s"]))
best = np.array(best)
for name, field in (("shipped teacher", old), ("box-polished", f)):
    _, v = field.best(pts, radius=2)
    r = np.asarray(v) / best
    print(f"{name}: {len(pts)} points, teacher/best mean {r.mean():.4f}, min {r.min():.3f}, "
          f"<0.85 {(r < 0.85).sum()}, <0.90 {(r < 0.9).sum()}, <0.95 {(r < 0.95).sum()}")
_, v = f.best(pts, radius=2)
r = np.asarray(v) / best
for n in np.argsort(r)[:8]:
    print(f"  k {pts[n][0]:.4f} load {pts[n][1]:.4f} kg: best {best[n] * 1e3:.2f} mm/s, box-polished teacher {r[n]:.3f}")
