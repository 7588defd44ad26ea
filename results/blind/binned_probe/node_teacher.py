"""The teacher restricted to its grid's own drives (no interpolation) against the recipe's teacher
(radius 2): velocities at blind-domain points and critical loads at drawn k. A probe of what a
student that picks whole drives from the grid's (a codebook) could reach; decides nothing.

    python results/blind/binned_probe/node_teacher.py --n 2000 --seed S --scan-ks 120 --scan-seed S2
    python results/blind/binned_probe/node_teacher.py --cycle-scans FILE.json ...   # against stored best-cycle scans
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))


def node_best(field, points, radius: int):
    """Per point the best of the grid drives around it (``candidates`` without the interpolation):
    ``DriveField.best`` with ``interpolation=False``, the codebook student's teacher."""
    return field.best(points, radius=radius, interpolation=False)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", type=int, default=2000)
    p.add_argument("--seed", type=int)
    p.add_argument("--scan-ks", type=int, default=120)
    p.add_argument("--scan-seed", type=int)
    p.add_argument("--cycle-scans", nargs="+", default=None,
                   help="instead: both teachers' critical loads over the best cycle's of these stored scans "
                        "(teacher_check.py --cycle-scan-file JSON: k, best_cycle_kg)")
    p.add_argument("--radius", type=int, default=2, help="the recipe's teacher_radius")
    a = p.parse_args()
    if not a.cycle_scans and (a.seed is None or a.scan_seed is None):
        p.error("--seed and --scan-seed are required (or --cycle-scans)")
    from mdr_drive_agents.blind import MOVING_THRESHOLD, draw_points, in_k_cells
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import critical_loads_grid

    field = DriveField.load("results/recipe/teacher_field.npz")
    if a.cycle_scans:
        return against_cycle_scans(field, a.cycle_scans, a.radius)
    drives = field.drives.reshape(-1, 5)
    print(f"grid actions: {len(drives)}, distinct: {len(np.unique(np.round(drives, 9), axis=0))}")
    t0 = time.perf_counter()
    points, _ = draw_points(a.n, a.seed)
    _, v_teacher = field.best(points, radius=a.radius)
    _, v_node = node_best(field, points, a.radius)
    scored = v_teacher >= MOVING_THRESHOLD
    frac = v_node[scored] / v_teacher[scored]
    print(f"{a.n} points of seed {a.seed}: node-only over the teacher where it moves >= 2 mm/s ({int(scored.sum())}): "
          f"mean {frac.mean():.4f}, median {np.median(frac):.4f}, min {frac.min():.3f}, under 0.95 "
          f"{int((frac < 0.95).sum())}, under 0.85 {int((frac < 0.85).sum())}  [{time.perf_counter() - t0:.0f} s]")
    ks = [float(round(k, 6)) for k in in_k_cells(np.random.default_rng(a.scan_seed).uniform(size=a.scan_ks), (0.0, 0.6))]
    crit_t = critical_loads_grid(ks, lambda pts: field.best(pts, radius=a.radius)[1])
    crit_n = critical_loads_grid(ks, lambda pts: node_best(field, pts, a.radius)[1])
    r = np.array([crit_n[k] / crit_t[k] for k in ks if crit_t[k] > 0])
    print(f"critical load, node-only over the teacher's at {len(ks)} k of scan seed {a.scan_seed}: min {r.min():.3f}, "
          f"median {np.median(r):.4f}, under 0.97 {int((r < 0.97).sum())}, under 0.99 {int((r < 0.99).sum())}  "
          f"[{time.perf_counter() - t0:.0f} s]")


def against_cycle_scans(field, files, radius: int) -> None:
    import json

    from mdr_drive_agents.evaluate import critical_loads_grid

    for name in files:
        d = json.loads(Path(name).read_text())
        ks, best = [float(k) for k in d["k"]], np.array(d["best_cycle_kg"])
        crit_t = critical_loads_grid(ks, lambda pts: field.best(pts, radius=radius)[1])
        crit_n = critical_loads_grid(ks, lambda pts: node_best(field, pts, radius)[1])
        rt = np.array([crit_t[k] for k in ks]) / best
        rn = np.array([crit_n[k] for k in ks]) / best
        print(f"{name} ({len(ks)} k): over the best cycle's critical load: teacher min {rt.min():.3f} "
              f"(under 0.97 {int((rt < 0.97).sum())}), node-only min {rn.min():.3f} (under 0.97 {int((rn < 0.97).sum())})")
        for k, x, y in zip(ks, rt, rn):
            if min(x, y) < 0.98:
                print(f"  k {k:.4f}: teacher {x:.3f}, node-only {y:.3f}")


if __name__ == "__main__":
    main()
