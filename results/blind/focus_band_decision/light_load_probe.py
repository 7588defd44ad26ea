"""The almost unloaded misses at k = 0.11-0.17 (F1's record, Q1's record, 5353): each student at 10 us and at 5 us (mm/s).

Run after the record; decides nothing. The policies with the other quantum are copies whose run.json
env_kwargs gain or lose `time_quantum` (runs/probe_s16/); runs/s3_policy: `git show ddc6a6b:agents/pretrained/ppo_generalist/FILE`,
runs/q1/policy: Q1, runs/recipe/policy: F1 (make train)."""
import numpy as np
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import load_policy, policy_velocity
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.teacher_data import teacher_drives
pts = [(0.1169, 0.0086), (0.16148, 0.01488), (0.1718, 0.01556), (0.1163, 0.01035), (0.14, 0.0), (0.15, 0.01), (0.13, 0.005)]
field = DriveField.load("results/recipe/teacher_field.npz")
tv = teacher_drives(field, pts, load_recipe(DEFAULT_CONFIG)["distill"])[1]
pols = {"S3 10us": "runs/s3_policy", "S3 5us": "runs/probe_s16/s3_5us", "Q1 5us": "runs/q1/policy",
        "Q1 10us": "runs/probe_s16/q1_10us", "F1 5us": "runs/recipe/policy", "F1 10us": "runs/probe_s16/f1_10us"}
v = {n: policy_velocity(load_policy(p), pts) for n, p in pols.items()}
print("| k | load kg | teacher | " + " | ".join(pols) + " |")
print("|---" * (3 + len(pols)) + "|")
for i, (k, m) in enumerate(pts):
    print(f"| {k} | {m} | {1e3*tv[i]:.2f} | " + " | ".join(f"{1e3*v[n][i]:.2f}" for n in pols) + " |")
