"""Labels of the recipe's round-0 draw (seed 0) that a load margin changes, and the teacher's velocity it costs.

    python results/blind/margin_decision/measurements/labels_changed.py
"""
import sys

import numpy as np

sys.path.insert(0, '.')
from mdr_drive_agents.drive_field import DriveField, pick_best
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.teacher_data import draw_points, drive_difference

cfg = load_recipe(DEFAULT_CONFIG)["distill"]
field = DriveField.load('results/recipe/teacher_field.npz')
pts = field.with_friction(draw_points(field, 4096, np.random.default_rng(0), cfg))
cands = [field.candidates(p[0], field.field_load(p), 2) for p in pts]
d0, v0 = pick_best(pts, cands, 0.02)
moving = v0 > 2e-3
for margin in (0.06, 0.08, 0.1):
    d, v = pick_best(pts, cands, 0.02, margin)
    changed = drive_difference(d0, d) > 0.05
    print(f"margin {margin}: {changed.sum()} labels changed; where the teacher moves >= 2 mm/s the velocity falls by "
          f"at most {np.max(1 - v[moving] / v0[moving]):.3f}, by > 5 % at {(v[moving] < 0.95 * v0[moving]).sum()}")
