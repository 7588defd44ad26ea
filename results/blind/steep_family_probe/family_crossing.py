#!/usr/bin/env python
"""Decision tool (not shipped): two teacher drive families played across k where the teacher switches.

    python results/blind/steep_family_probe/family_crossing.py --field runs/s5/teacher_field.npz \
        --ks 0.23875 0.2425 0.24625 0.25 --loads 1.2 1.23 1.26 1.3

Per load (times the trapezoid's critical load at each k): drive A, the teacher's at the first k,
and drive B, the teacher's at the last k, each played open loop at every k, beside the teacher
there (its best drive; the recipe's settings). mm/s.
"""
import argparse

import numpy as np

from mdr_drive_agents.blind import trapezoid_critical
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import open_loop_velocity
from mdr_drive_agents.recipe import load_recipe
from mdr_drive_agents.teacher_data import teacher_drives

p = argparse.ArgumentParser()
p.add_argument("--field", required=True)
p.add_argument("--ks", type=float, nargs="+", required=True)
p.add_argument("--loads", type=float, nargs="+", required=True)
p.add_argument("--recipe", default="results/blind/steep_budget_decision/recipe_steep1500.yaml")
a = p.parse_args()
field = DriveField.load(a.field)
config = load_recipe(a.recipe)["distill"]
crit = trapezoid_critical(a.ks)
print(f"{a.field}: A = the teacher's drive at k = {a.ks[0]}, B = at k = {a.ks[-1]}; mm/s")
print("| load / trapezoid's critical | " + " | ".join(f"k = {k}: A / B / teacher" for k in a.ks) + " |")
print("|---" * (len(a.ks) + 1) + "|")
for s in a.loads:
    points = [(k, s * c) for k, c in zip(a.ks, crit)]
    drive_a, drive_b = teacher_drives(field, [points[0]], config)[0], teacher_drives(field, [points[-1]], config)[0]
    v_a = open_loop_velocity(points, np.repeat(drive_a, len(points), 0))
    v_b = open_loop_velocity(points, np.repeat(drive_b, len(points), 0))
    v_t = teacher_drives(field, points, config)[1]
    print(f"| {s:g} | " + " | ".join(f"{1e3 * x:.2f} / {1e3 * y:.2f} / {1e3 * t:.2f}" for x, y, t in zip(v_a, v_b, v_t)) + " |")
