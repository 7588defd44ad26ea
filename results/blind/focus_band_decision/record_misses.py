"""F1's record misses against its teacher and Q1 (the build before it): the critical load at the k
where F1 fell under 0.97 of the best cycle's, and the velocity at the point under 0.85 of the best
drive. python results/blind/focus_band_decision/record_misses.py runs/q1/policy
(runs/q1/policy: Q1, the same weights as `git show 263ed8d:agents/pretrained/ppo_generalist/FILE`)."""
import csv
import sys

import numpy as np

from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import critical_loads_grid, load_policy, policy_velocity
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.teacher_data import teacher_drives

field = DriveField.load("results/recipe/teacher_field.npz")
config = load_recipe(DEFAULT_CONFIG)["distill"]
policies = {"F1": load_policy("agents/pretrained/ppo_generalist"), "Q1": load_policy(sys.argv[1])}
rows, points = [], []
for seed in range(20261213, 20261219):
    folder = f"results/blind/seed{seed}_drawn_scan"
    for r in csv.DictReader(open(f"{folder}/critical_loads.csv")):
        if float(r["policy 1_kg"]) < 0.97 * float(r["best_cycle_kg"]):
            rows.append((seed, float(r["k"]), float(r["best_cycle_kg"])))
    for r in csv.DictReader(open(f"{folder}/points.csv")):
        best = float(r["best_m_s"])
        if best >= 2e-3 and float(r["policy 1_m_s"]) < 0.85 * best:
            points.append((seed, float(r["k"]), float(r["cargo_mass_kg"]), best))
ks = [k for _, k, _ in rows]
teacher = critical_loads_grid(ks, lambda pts: teacher_drives(field, pts, config)[1])
played = {name: critical_loads_grid(ks, lambda pts, p=p: policy_velocity(p, pts)) for name, p in policies.items()}
print("Critical load under 0.97 of the best two-action cycle's (kg; ratios to it)\n")
print("| seed | k | best cycle | teacher (10 us, as searched) | F1 | Q1 |")
print("|---|---|---|---|---|---|")
for seed, k, best in rows:
    print(f"| {seed} | {k:.5f} | {best:.5f} | {teacher[k]:.5f} ({teacher[k] / best:.3f}) | "
          + " | ".join(f"{played[n][k]:.5f} ({played[n][k] / best:.3f})" for n in ("F1", "Q1")) + " |")
pts = [(k, m) for _, k, m, _ in points]
tv = teacher_drives(field, pts, config)[1]
pv = {name: policy_velocity(p, pts) for name, p in policies.items()}
print("\nPoints under 0.85 of the search's best drive (mm/s; fractions of it)\n")
print("| seed | k | load kg | best | teacher | F1 | Q1 |")
print("|---|---|---|---|---|---|---|")
for i, (seed, k, m, best) in enumerate(points):
    print(f"| {seed} | {k:.5f} | {m:.5f} | {1e3 * best:.2f} | {1e3 * tv[i]:.2f} ({tv[i] / best:.3f}) | "
          + " | ".join(f"{1e3 * pv[n][i]:.2f} ({pv[n][i] / best:.3f})" for n in ("F1", "Q1")) + " |")
