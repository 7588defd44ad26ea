"""The students against the teacher in a band of (k, load): exploration before the rule, decides by itself nothing.

    python results/blind/f1_seed_decision/explore_band.py --seed 8282 --n 300 --k 0.08 0.2 --load 0 0.15

Points: k uniform in --k, the load uniform in --load times the trapezoid's critical load (interpolated
from the teacher's grid). Per policy: the fraction of the teacher's velocity (the recipe's teacher,
``teacher_drives``) where the teacher moves >= 2 mm/s: mean, min, points under 0.85 and under 0.9.
Policies: Q1 (runs/q1/policy), F1 (agents/pretrained/ppo_generalist), S3 (runs/s3_policy) and any
folders given with --extra."""
import argparse

import numpy as np

from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import load_policy, policy_velocity
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.teacher_data import teacher_drives

parser = argparse.ArgumentParser()
parser.add_argument("--seed", type=int, required=True)
parser.add_argument("--n", type=int, default=300)
parser.add_argument("--k", type=float, nargs=2, default=(0.08, 0.2))
parser.add_argument("--load", type=float, nargs=2, default=(0.0, 0.15))
parser.add_argument("--extra", nargs="*", default=[])
args = parser.parse_args()
field = DriveField.load("results/recipe/teacher_field.npz")
rng = np.random.default_rng(args.seed)
ks = rng.uniform(*args.k, args.n)
loads = rng.uniform(*args.load, args.n) * np.interp(ks, field.ks, field.trapezoid_critical)
pts = [(float(k), float(m)) for k, m in zip(ks, loads)]
tv = teacher_drives(field, pts, load_recipe(DEFAULT_CONFIG)["distill"])[1]
pols = {"Q1": "runs/q1/policy", "F1": "agents/pretrained/ppo_generalist", "S3": "runs/s3_policy",
        **{p: p for p in args.extra}}
moves = tv >= 2e-3
print(f"seed {args.seed}, {args.n} points, k in {list(args.k)}, load in {list(args.load)} x the trapezoid's "
      f"critical load; {moves.sum()} where the teacher moves >= 2 mm/s\n")
print("| policy | fraction mean | min | under 0.85 | under 0.9 |")
print("|---|---|---|---|---|")
worst = {}
for name, path in pols.items():
    frac = policy_velocity(load_policy(path), pts)[moves] / tv[moves]
    worst[name] = np.argsort(frac)[:5]
    print(f"| {name} | {frac.mean():.3f} | {frac.min():.3f} | {(frac < 0.85).sum()} | {(frac < 0.9).sum()} |")
