"""Ship a trained policy: copy model, VecNormalize statistics and run record, and write its model card.

    python -m agents.model_card runs/ppo_s0 agents/pretrained/ppo_generalist

The card's evaluation table is computed here, from the shipped files, with the benchmark protocol.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np

from .evaluate import AVERAGE_PERIODS, EVAL_PERIODS, Policy, open_loop_velocity, policy_velocity, trapezoid_action

CARD_KS = (0.0, 0.2, 0.4, 0.6)
CARD_MASSES = (0.0, 0.05, 0.1, 0.2, 0.4)
FILES = ("model.zip", "vecnormalize.pkl", "run.json")


def evaluation_table(policy_dir: str | Path) -> str:
    points = [(k, m) for k in CARD_KS for m in CARD_MASSES]
    learned = policy_velocity(Policy(policy_dir), points)
    trap = open_loop_velocity(points, trapezoid_action())
    lines = ["| k | " + " | ".join(f"m = {m:g} kg" for m in CARD_MASSES) + " |", "|---|" + "---|" * len(CARD_MASSES)]
    for i, k in enumerate(CARD_KS):
        cells = [f"{learned[i * len(CARD_MASSES) + j] * 1e3:.2f} ({trap[i * len(CARD_MASSES) + j] * 1e3:.2f})"
                 for j in range(len(CARD_MASSES))]
        lines.append(f"| {k:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


#: The teacher command of teachers built before they recorded their own.
OLD_TEACHER_COMMAND = "python -m agents.teacher --points 160 --stall-points 192 --cycle-budget 2500"


def teacher_note(run: dict) -> str:
    hyper = run["hyperparameters"]
    warm = hyper.get("warm_start", "none")
    if not warm.startswith("cma:"):
        return f"`{warm}`"
    mse = hyper.get("warm_start_mse", float("nan"))
    about, command = "", OLD_TEACHER_COMMAND
    if Path(warm[4:]).exists():  # describe the teacher from its own file
        data = np.load(warm[4:])
        acts = data["actions"]
        cycles = int(np.sum(np.abs(acts[:, 0] - acts[:, 1]).max(axis=1) > 0)) if acts.ndim == 3 else 0
        command = str(data["command"]) if "command" in data else command
        about = (f": {len(data['points'])} (k, load) points, {cycles} of them best driven by a two-action cycle, "
                 f"built in {float(data['wall_time_s']):.0f} s on 2 cores")
    steps = hyper.get("teacher_steps_per_rollout")
    regulariser = f", with {steps} supervised steps towards the teacher after every rollout" if steps else ""
    return (f"behaviour cloning of the CMA-ES teacher `{warm[4:]}` (`{command}`{about}), fit MSE {mse:.4f}, "
            f"exploration noise log std {hyper.get('cloned_log_std', 'unchanged')} after cloning, then PPO"
            f"{regulariser}")


def ship(src: str | Path, dst: str | Path) -> Path:
    src, dst = Path(src), Path(dst)
    dst.mkdir(parents=True, exist_ok=True)
    files = FILES + (("teacher_lookup.npz",) if (src / "teacher_lookup.npz").exists() else ())
    for name in files:
        shutil.copy2(src / name, dst / name)
    run = json.loads((dst / "run.json").read_text())
    size_kb = sum((dst / n).stat().st_size for n in files) / 1024
    lookup_note = (", `teacher_lookup.npz` (the teacher's drives: the policy plays a residual on them, "
                   "`agents/residual.py`)" if len(files) > len(FILES) else "")
    card = f"""# {dst.name}: a generalist PPO waveform policy for MDRDrive-v0

One policy for every grading exponent and load in its training range: it observes k and the load
(observation entries 10-12) and sets each period's waveform within the paper's actuator limits.

* Produced by: `{run['command']}`
* Algorithm: {run['algo'].upper()}, seed {run['seed']}, {run['total_timesteps']:,} environment steps (drive
  periods), {run['wall_time_s']:.0f} s wall time on this 2-core machine ({run['steps_per_s_this_run']:,.0f} steps/s,
  torch threads {run['torch_threads']}), warm start: {run['hyperparameters'].get('warm_start', 'none')}
* Warm start: {teacher_note(run)}
* Training distribution (env kwargs): `{json.dumps(run['env_kwargs'])}`
* Hyperparameters: `{json.dumps({k: v for k, v in run['hyperparameters'].items() if k != 'policy_kwargs'})}`,
  policy `{json.dumps(run['hyperparameters'].get('policy_kwargs', {}))}`
* Versions: `{json.dumps(run['versions'])}`
* Files: `model.zip` (SB3), `vecnormalize.pkl` (observation normalisation, needed to run it),
  `run.json`{lookup_note}; {size_kb:.0f} KiB in all.

Use: `mdr-drive evaluate --policy {dst.as_posix()} --k 0.2 --cargo-mass 0.1 --json`, or in Python
`agents.evaluate.Policy("{dst.as_posix()}")(obs)`.

## Evaluation

Steady slider velocity in mm/s, learned (trapezoid), mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS} of a
fresh drive, computed by `python -m agents.model_card {src.as_posix()} {dst.as_posix()}` from the shipped files:

{evaluation_table(dst)}

The full comparison with CMA-ES and other training seeds is in docs/results.md
(`mdr-drive benchmark`).
"""
    (dst / "MODEL_CARD.md").write_text(card)
    return dst / "MODEL_CARD.md"


if __name__ == "__main__":
    print(ship(sys.argv[1], sys.argv[2]).read_text())
