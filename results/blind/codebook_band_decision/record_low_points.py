"""CBB's record (seeds 20261249-54): every scored point where CBB is under 0.87 of the search's best drive,
with its teacher's drives played there (the band teacher, with and without the interpolation): where
they are equal the miss is the teacher's.

    python results/blind/codebook_band_decision/record_low_points.py
"""
import json
import sys
from pathlib import Path

import numpy as np

from mdr_drive_agents.drive_field import DriveField

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "codebook_decision"))
from teacher_at_misses import teacher_at_low_points  # noqa: E402

KEY = "runs/cbb/policy"
field = DriveField.load("results/blind/band_phase_decision/band_phase_teacher_field.npz")
print("| seed | k | m (kg) | best (mm/s, kind) | trapezoid (mm/s) | CBB | teacher | grid-drive teacher (CBB's) |")
print("|---|---|---|---|---|---|---|---|")
for seed in range(20261249, 20261255):
    d = json.load(open(f"results/blind/seed{seed}_drawn_scan/blind.json"))
    best = np.array([b["velocity"] for b in d["best"]], dtype=float)
    v = np.array(d["learned"][KEY], dtype=float)
    idx, points, v_teacher, v_grid = teacher_at_low_points(field, d, [v])
    for j, i in enumerate(idx):
        print(f"| {seed} | {points[j][0]:.4f} | {points[j][1]:.4f} | {best[i] * 1e3:.2f} ({d['best'][i].get('kind')}) | "
              f"{d['trapezoid'][i] * 1e3:.2f} | {v[i] / best[i]:.3f} | {v_teacher[j] / best[i]:.3f} | {v_grid[j] / best[i]:.3f} |")
