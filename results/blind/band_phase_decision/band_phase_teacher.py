"""The shipped teacher with the recipe's last stage, ``polish_band``, as ``DriveField.search`` now runs
it (seed 0 + 980,000, then ``settle(keep_phases_of=...)``: every node in its old phase): the same field a
from-scratch recipe with that stage writes, since every earlier stage is deterministic.

    PYTHONPATH=. python results/blind/band_phase_decision/band_phase_teacher.py 700 0.3 0.15 0.275 0.84 1.38 \
        --recipe results/blind/band_phase_decision/recipe_band_phase.yaml --out runs/band_phase/teacher_field.npz

It also prints, against the shipped teacher, how many nodes changed drive and how many changed only
their phase (a cycle written swapped): the second is what ``keep_phases`` keeps at zero.
"""
import argparse, dataclasses, json, time

import numpy as np

from agents.cycles import swap_is_closer
from agents.drive_field import DriveField
from agents.recipe import load_recipe

ap = argparse.ArgumentParser()
ap.add_argument("band", type=float, nargs=6, metavar=("BUDGET", "SIGMA", "K_LOW", "K_HIGH", "LOW", "HIGH"))
ap.add_argument("--field", default="results/recipe/teacher_field.npz")
ap.add_argument("--seed", type=int, default=0, help="the recipe's seed")
ap.add_argument("--recipe", default=None, help="a recipe YAML whose teacher is the shipped one plus this polish_band")
ap.add_argument("--out", required=True)
a = ap.parse_args()
field = DriveField.load(a.field)
budget, sigma, k_low, k_high, low, high = a.band
t0 = time.perf_counter()
before = field.drives.copy()
changed = field.polish_band(int(budget), sigma, (k_low, k_high), (low, high), seed=a.seed + 980_000)
field.settle(keep_phases_of=before)
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
      f"{int((~same).sum())} nodes changed, {int(swapped_only.sum())} of them only their phase; "
      f"changed nodes whose new drive is closer swapped to the old: {int(swap_is_closer(new[~same], old[~same]).sum())}")
