"""The candidate's teacher: the teacher committed before it (git dee11ed) plus its last stage,
polish_stall [1500, 0.3, 0.15] (what the candidate recipe's teacher stage computes after refine_load,
with the recipe's seed 0; `make train` then gave the same teacher, value for value).

git show dee11ed:results/recipe/teacher_field.npz > runs/teacher_dee11ed.npz
python results/blind/stall_low_k_decision/stall_low_k_teacher.py runs/teacher_dee11ed.npz runs/stall_low_k_teacher.npz
"""
import dataclasses
import json
import sys
import time

from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.recipe import load_recipe
from mdr_drive_env.sweep import Executor

config = load_recipe("results/blind/stall_low_k_decision/recipe_stall_low_k.yaml")["teacher"]
field = DriveField.load(sys.argv[1])
t0 = time.perf_counter()
budget, sigma, k_max = config.polish_stall
changed = field.polish_stall(budget, sigma, executor=Executor(progress=False), seed=0 + 970_000, k_max=k_max)
field.exchange()
field.align()
field.meta["config"] = json.loads(json.dumps(dataclasses.asdict(config)))
field.save(sys.argv[2])
print(f"polish_stall: {field.meta['polished_stall']}, {time.perf_counter() - t0:.1f} s")
