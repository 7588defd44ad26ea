"""The shipped teacher with the recipe's last stage, ``polish_band``, run on it as ``DriveField.search``
runs it (seed 0 + 980,000, then ``settle``): the same field a from-scratch recipe with that stage
writes, since every earlier stage is deterministic (``make train`` reproduced the shipped teacher).

    PYTHONPATH=. python results/blind/teacher_band_decision/band_teacher.py 700 0.3 0.15 0.275 0.84 1.38 \
        --recipe results/blind/teacher_band_decision/recipe_band_seed0.yaml --out runs/band_teacher.npz

With ``--recipe``, the field's recorded config is that recipe's teacher (which must be the shipped one
plus this ``polish_band``), so the recipe loads it without a warning; its recorded wall time is the
shipped teacher's plus this stage's. With ``--keep-phases``, the stage settles as ``DriveField.search``
settles it since results/blind/band_phase_decision (every node in its old phase) instead of as it did
here (``settle()``: each k line re-aligned from its lightest node), and the script says how many
nodes changed and how many only in phase.
"""
import argparse, dataclasses, json, time

from agents.drive_field import DriveField  # first: the package pins numpy's BLAS kernels (mdr_drive_env.blas)
from agents.recipe import load_recipe

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("band", type=float, nargs=6, metavar=("BUDGET", "SIGMA", "K_LOW", "K_HIGH", "LOW", "HIGH"))
ap.add_argument("--field", default="results/recipe/teacher_field.npz")
ap.add_argument("--seed", type=int, default=0, help="the recipe's seed")
ap.add_argument("--recipe", default=None, help="a recipe YAML whose teacher is the shipped one plus this polish_band")
ap.add_argument("--out", required=True)
ap.add_argument("--keep-phases", action="store_true", help="settle as DriveField.search now does (band_phase_decision)")
a = ap.parse_args()
field = DriveField.load(a.field)
budget, sigma, k_low, k_high, low, high = a.band
t0 = time.perf_counter()
before = field.drives.copy()
changed = field.polish_band(int(budget), sigma, (k_low, k_high), (low, high), seed=a.seed + 980_000)
field.settle(keep_phases_of=before if a.keep_phases else None)
wall = time.perf_counter() - t0
field.meta["polish_band_wall_time_s"] = round(wall, 1)
if a.recipe:
    teacher = load_recipe(a.recipe)["teacher"]
    shipped = json.loads(json.dumps(field.meta["config"]))
    wanted = json.loads(json.dumps(dataclasses.asdict(teacher)))
    if {**shipped, "polish_band": wanted["polish_band"]} != wanted or list(teacher.polish_band) != list(a.band):
        raise SystemExit(f"{a.recipe}: its teacher is not the shipped one plus polish_band {a.band}")
    field.meta["config"] = dataclasses.asdict(teacher)
    field.meta["wall_time_s"] = round(field.meta["wall_time_s"] + wall, 1)
field.save(a.out)
old, new = before.reshape(-1, 2, 5), field.drives.reshape(-1, 2, 5)
same = np.all(new == old, axis=(1, 2))
swapped_only = np.all(new[:, ::-1] == old, axis=(1, 2)) & ~same
print(f"polish_band {a.band}: {field.meta['polished_band']}, {wall:.1f} s with settle; against the field before: "
      f"{int((~same).sum())} nodes changed, {int(swapped_only.sum())} of them only in phase")
