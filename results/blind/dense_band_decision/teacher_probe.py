"""The teacher alone, on decision data: the band-polished teacher (``../band_phase_decision``) against
the same teacher with ``refine_band`` (load lines between its load lines in a band, searched there),
each played as a codebook student's teacher (its grid drives around the point, radius 2) at every
scored point of the stored blind searches of decision seeds (``../seed*_drawn_scan``: 20261139-20261224
and 20261249-54; ``../codebook_band_decision/seed3232``, ``seed9292``), as a fraction of the search's best.

    python results/blind/dense_band_decision/teacher_probe.py BUDGET K_LOW K_HIGH LOW HIGH [--save FILE]
"""
import argparse
import glob
import json
import time

import numpy as np

from mdr_drive_agents.blind import MOVING_THRESHOLD
from mdr_drive_agents.drive_field import DriveField

BAND_TEACHER = "results/blind/band_phase_decision/band_phase_teacher_field.npz"


def decision_points():
    files = sorted(glob.glob("results/blind/seed*_drawn_scan/blind.json")) + [
        f"results/blind/codebook_band_decision/seed{s}/blind.json" for s in (3232, 9292)]
    points, best = [], []
    for f in files:
        record = json.load(open(f))
        for p, b in zip(record["points"], record["best"]):
            if b["velocity"] >= MOVING_THRESHOLD:
                points.append(tuple(p[:2]))
                best.append(b["velocity"])
    return files, points, np.array(best)


def summary(name, fraction, points):
    k = np.array([p[0] for p in points])
    band = (k >= 0.1) & (k <= 0.3)
    print(f"| {name} | {fraction.min():.3f} | {(fraction < 0.85).sum()} | {(fraction < 0.9).sum()} | "
          f"{fraction.mean():.4f} | {fraction[band].mean():.4f} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("budget", type=int)
    ap.add_argument("k_low", type=float)
    ap.add_argument("k_high", type=float)
    ap.add_argument("low", type=float)
    ap.add_argument("high", type=float)
    ap.add_argument("--save")
    a = ap.parse_args()
    files, points, best = decision_points()
    print(f"{len(files)} stored searches, {len(points)} scored points")
    print("| teacher | minimum fraction of the best | points under 0.85 | under 0.9 | mean | mean at k 0.1-0.3 |")
    print("|---|---|---|---|---|---|")
    field = DriveField.load(BAND_TEACHER)
    summary("band-polished (CBB's)", field.best(points, radius=2, interpolation=False)[1] / best, points)
    t0 = time.perf_counter()
    field.refine_band(a.budget, 0.3, (a.k_low, a.k_high), (a.low, a.high), seed=990_000)
    field.settle(keep_phases_of=field.drives.copy())
    wall = time.perf_counter() - t0
    summary(f"+ refine_band {a.budget}, k {a.k_low}-{a.k_high}, {a.low}-{a.high} ({wall:.0f} s)",
            field.best(points, radius=2, interpolation=False)[1] / best, points)
    print(f"grid {field.velocities.shape}, {field.meta['refined_band']}")
    if a.save:
        field.save(a.save)


if __name__ == "__main__":
    main()
