"""At every scored point where a candidate or F1s1 is under 0.87 of the search's best drive (F1s1's six
spent record seeds), the teacher's fraction too: the recipe's teacher (interpolation and grid drives)
and the codebook's (grid drives only), each played open loop at the point. A student can reach at most
about its teacher, so where the teacher is under 0.85 no student of it meets the target.

    python results/blind/codebook_decision/teacher_at_misses.py cb60 [cbs cb30]
"""
import json
import sys

import numpy as np

from mdr_drive_agents.blind import MOVING_THRESHOLD
from mdr_drive_agents.drive_field import DriveField

SEEDS = range(20261219, 20261225)
SHIPPED = "agents/pretrained/ppo_generalist"
def teacher_at_low_points(field, record: dict, learned, below: float = 0.87):
    """The scored points of a blind result ``record`` where any velocity array of ``learned`` is under
    ``below`` of the search's best drive: their indices, (k, load) points, and the velocities (m/s) of
    ``field``'s teacher there, with and without its interpolation (radius 2, the recipe's)."""
    best = np.array([b["velocity"] for b in record["best"]], dtype=float)
    scored = best >= MOVING_THRESHOLD
    low = np.zeros(len(best), dtype=bool)
    for v in learned:
        low |= scored & (v / np.where(scored, best, 1.0) < below)
    idx = np.flatnonzero(low)
    points = [tuple(record["points"][i]) for i in idx]
    if not len(idx):
        return idx, points, np.zeros(0), np.zeros(0)
    _, v_teacher = field.best(points, radius=2)
    _, v_grid = field.best(points, radius=2, interpolation=False)
    return idx, points, v_teacher, v_grid


def main() -> None:
    names = sys.argv[1:] or ["cb60"]
    field = DriveField.load("results/recipe/teacher_field.npz")
    print("| seed | k | m (kg) | best (mm/s) | trapezoid (mm/s) | F1s1 | "
          + " | ".join(names) + " | teacher | grid-drive teacher |")
    print("|---|---|---|---|---|---|" + "---|" * len(names) + "---|---|")
    for seed in SEEDS:
        record = json.load(open(f"results/blind/seed{seed}_drawn_scan/blind.json"))
        best = np.array([b["velocity"] for b in record["best"]], dtype=float)
        learned = {SHIPPED: np.array(record["learned"][SHIPPED], dtype=float)}
        for name in names:
            d = json.load(open(f"results/blind/codebook_decision/{name}_seed{seed}/blind.json"))
            learned[name] = np.array(d["learned"][f"runs/{name}/policy"], dtype=float)
        idx, points, v_teacher, v_grid = teacher_at_low_points(field, record, learned.values())
        for j, i in enumerate(idx):
            cells = [f"{learned[SHIPPED][i] / best[i]:.3f}"] + [f"{learned[n][i] / best[i]:.3f}" for n in names]
            print(f"| {seed} | {points[j][0]:.4f} | {points[j][1]:.4f} | {best[i] * 1e3:.2f} | "
                  f"{record['trapezoid'][i] * 1e3:.2f} | " + " | ".join(cells)
                  + f" | {v_teacher[j] / best[i]:.3f} | {v_grid[j] / best[i]:.3f} |")


if __name__ == "__main__":
    main()
