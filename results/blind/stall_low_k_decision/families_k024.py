"""Why students fall short near k = 0.24: the teacher's drive near the stall switches between two
families there, and each carries the heaviest load on one side only.

python results/blind/stall_low_k_decision/families_k024.py > results/blind/stall_low_k_decision/families_k024.md

Family A: the committed teacher's drive at k = 0.225, 1.32 times the trapezoid's critical load;
family B: its drive at k = 0.25, the same load. Each played open loop (and the teacher, as the
student is taught: the best of the interpolation and the 4 x 4 grid drives around) on 121 loads from
1.0 to 1.6 times the trapezoid's critical load; the critical load is the last load before the first
stall, over the trapezoid's.
"""
import numpy as np

from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import open_loop_velocity

field = DriveField.load("results/recipe/teacher_field.npz")
line = {round(float(k), 4): i for i, k in enumerate(field.ks)}
j = int(np.argmin(np.abs(field.fractions - 1.32)))
families = {"A (k = 0.225 line)": field.drives[line[0.225], j], "B (k = 0.25 line)": field.drives[line[0.25], j]}
ks = np.round(np.concatenate([np.linspace(0.2, 0.275, 16), np.linspace(0.3, 0.6, 13)]), 4)
fractions = np.linspace(1.0, 1.6, 121)
crit = np.interp(ks, field.ks, field.trapezoid_critical)
points = [(k, s * c) for k, c in zip(ks, crit) for s in fractions]


def critical(v: np.ndarray) -> float:
    bad = np.flatnonzero(~(v > 0.0))
    return float(fractions[-1] if bad.size == 0 else fractions[bad[0] - 1] if bad[0] > 0 else 0.0)


columns = {name: open_loop_velocity(points, np.repeat(d[None], len(points), 0)).reshape(len(ks), -1)
           for name, d in families.items()}
columns["teacher"] = field.best(points, radius=2)[1].reshape(len(ks), -1)
print("Critical load over the trapezoid's, per drive (the command in the script's docstring)\n")
print("| k | " + " | ".join(columns) + " |\n|---|" + "---|" * len(columns))
for i, k in enumerate(ks):
    print(f"| {k:g} | " + " | ".join(f"{critical(v[i]):.3f}" for v in columns.values()) + " |")
