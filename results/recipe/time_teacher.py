"""Per stage of the teacher's search: wall time, summed task time, and the workers' busy share; the field it writes is
compared with the shipped teacher. `PYTHONPATH=. python results/recipe/time_teacher.py agents/configs/recipe.yaml OUT.npz`
(writes OUT.npz and OUT.npz.timing.json)."""
import json, sys, time
sys.path.insert(0, ".")
from mdr_drive_env import sweep  # first: it pins numpy's BLAS kernels (mdr_drive_env.blas)
import numpy as np
from mdr_drive_env.blas import blas_core
from agents.drive_field import DriveField
from agents.recipe import load_recipe


class Timed:
    def __init__(self, fn):
        self.fn = fn

    def __call__(self, task):
        t = time.perf_counter()
        out = self.fn(task)
        return out, time.perf_counter() - t


log = []
orig = sweep.Executor.map


def timed_map(self, fn, tasks, desc, store=None, on_result=None):
    t0 = time.perf_counter()
    res = orig(self, Timed(fn), tasks, desc, store=None)
    wall = time.perf_counter() - t0
    dts = [r[1] for r in res]
    log.append({"stage": desc, "tasks": len(dts), "wall_s": round(wall, 1), "task_sum_s": round(sum(dts), 1),
                "task_max_s": round(max(dts), 1), "task_dts": [round(d, 1) for d in dts]})
    print(json.dumps({k: v for k, v in log[-1].items() if k != "task_dts"}), flush=True)
    return [r[0] for r in res]


sweep.Executor.map = timed_map
recipe = load_recipe(sys.argv[1])
t0 = time.perf_counter()
field = DriveField.search(recipe["teacher"], seed=recipe["seed"], executor=sweep.Executor(progress=False))
total = time.perf_counter() - t0
field.save(sys.argv[2])
ref = DriveField.load("results/recipe/teacher_field.npz")
print("BLAS kernels", blas_core(), "total", round(total, 1), "identical to shipped:", np.array_equal(field.drives, ref.drives) and np.array_equal(field.velocities, ref.velocities))
json.dump({"total_s": total, "stages": log}, open(sys.argv[2] + ".timing.json", "w"), indent=1)
