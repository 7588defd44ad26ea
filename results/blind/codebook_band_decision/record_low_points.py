"""CBB's record (seeds 20261249-54): every scored point where CBB is under 0.87 of the search's best drive,
with its teacher's drives played there (the band teacher, with and without the interpolation): where
they are equal the miss is the teacher's.

    python results/blind/codebook_band_decision/record_low_points.py
"""
import json

import numpy as np

from mdr_drive_agents.blind import MOVING_THRESHOLD
from mdr_drive_agents.drive_field import DriveField

KEY = "runs/cbb/policy"
field = DriveField.load("results/blind/band_phase_decision/band_phase_teacher_field.npz")
print("| seed | k | m (kg) | best (mm/s, kind) | trapezoid (mm/s) | CBB | teacher | grid-drive teacher (CBB's) |")
print("|---|---|---|---|---|---|---|---|")
for seed in range(20261249, 20261255):
    d = json.load(open(f"results/blind/seed{seed}_drawn_scan/blind.json"))
    best = np.array([b["velocity"] for b in d["best"]], dtype=float)
    v = np.array(d["learned"][KEY], dtype=float)
    scored = best >= MOVING_THRESHOLD
    idx = np.flatnonzero(scored & (v / np.where(scored, best, 1.0) < 0.87))
    if not len(idx):
        continue
    points = [tuple(d["points"][i]) for i in idx]
    _, v_teacher = field.best(points, radius=2)
    _, v_grid = field.best(points, radius=2, interpolation=False)
    for j, i in enumerate(idx):
        print(f"| {seed} | {points[j][0]:.4f} | {points[j][1]:.4f} | {best[i] * 1e3:.2f} ({d['best'][i].get('kind')}) | "
              f"{d['trapezoid'][i] * 1e3:.2f} | {v[i] / best[i]:.3f} | {v_teacher[j] / best[i]:.3f} | {v_grid[j] / best[i]:.3f} |")
