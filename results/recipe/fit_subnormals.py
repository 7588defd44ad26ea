"""Run the recipe (``python -m mdr_drive_agents.recipe ...``) and count, every 1,000 Adam steps of
each fit, the subnormal entries of Adam's moments, the weights and the gradients, with the
seconds those 1,000 steps took (docs/performance.md). ``--keep-subnormals`` turns off
``adam_fit``'s sweep (``agents/student.py``, ``zero_subnormal_moments``), as before it existed.

    PYTHONPATH=. python results/recipe/fit_subnormals.py OUT.jsonl [--keep-subnormals] -- \\
        agents/configs/recipe.yaml --teacher results/recipe/teacher_field.npz --out runs/X --force

The counts are taken after an Adam step and before the sweep that may follow it, so with the sweep
they show what at most 16 steps leave.
"""

from __future__ import annotations

import argparse
import json
import runpy
import sys
import time

import torch

from mdr_drive_agents import student


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="JSON-lines file of the counts (overwritten)")
    ap.add_argument("--keep-subnormals", action="store_true", help="do not zero Adam's subnormal moments")
    ap.add_argument("recipe_args", nargs=argparse.REMAINDER, help="-- then the recipe's arguments")
    a = ap.parse_args()
    if a.keep_subnormals:
        student.SUBNORMAL_SWEEP_STEPS = 10**18
    tiny = torch.finfo(torch.float32).tiny
    original_step = torch.optim.Adam.step
    clock = {"steps": 0, "t": time.perf_counter()}
    log = open(a.out, "w")

    def subnormal(x) -> int:
        x = x.detach().abs()
        return int(((x > 0) & (x < tiny)).sum())

    def step(self, *args, **kwargs):
        out = original_step(self, *args, **kwargs)
        clock["steps"] += 1
        if clock["steps"] % 1000 == 0:
            counts = {"exp_avg": 0, "exp_avg_sq": 0, "param": 0, "grad": 0, "total": 0}
            with torch.no_grad():
                for group in self.param_groups:
                    for p in group["params"]:
                        state = self.state.get(p, {})
                        counts["total"] += p.numel()
                        counts["param"] += subnormal(p)
                        counts["grad"] += subnormal(p.grad) if p.grad is not None else 0
                        for key in ("exp_avg", "exp_avg_sq"):
                            counts[key] += subnormal(state[key]) if key in state else 0
            now = time.perf_counter()
            counts.update(step=clock["steps"], s_per_1000=round(now - clock["t"], 2))
            clock["t"] = now
            log.write(json.dumps(counts) + "\n")
            log.flush()
        return out

    torch.optim.Adam.step = step
    sys.argv = ["mdr_drive_agents.recipe"] + [x for x in a.recipe_args if x != "--"]
    runpy.run_module("mdr_drive_agents.recipe", run_name="__main__")


if __name__ == "__main__":
    main()
