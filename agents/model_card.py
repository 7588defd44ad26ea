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

from mdr_drive_env.files import write_text

from .evaluate import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    Policy,
    format_velocity,
    open_loop_velocity,
    policy_velocity,
    trapezoid_action,
)

CARD_KS = (0.0, 0.2, 0.4, 0.6)
CARD_MASSES = (0.0, 0.05, 0.1, 0.2, 0.4)
FILES = ("model.zip", "vecnormalize.pkl", "run.json")


def evaluation_table(policy_dir: str | Path) -> str:
    points = [(k, m) for k in CARD_KS for m in CARD_MASSES]
    learned = policy_velocity(Policy(policy_dir), points, mark_runaway=True)
    trap = open_loop_velocity(points, trapezoid_action(), mark_runaway=True)
    lines = ["| k | " + " | ".join(f"m = {m:g} kg" for m in CARD_MASSES) + " |", "|---|" + "---|" * len(CARD_MASSES)]
    for i, k in enumerate(CARD_KS):
        cells = [f"{format_velocity(learned[i * len(CARD_MASSES) + j])} "
                 f"({format_velocity(trap[i * len(CARD_MASSES) + j])})" for j in range(len(CARD_MASSES))]
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


def blind_section(blind_json: str | Path, policy_key: str) -> str:
    """The policy's statistics from a blind benchmark's ``blind.json`` (``mdr-drive benchmark --blind``)."""
    res = json.loads(Path(blind_json).read_text())
    s = res["statistics"][policy_key]
    over_trap = [r for r in s["critical_load_over_trapezoid"] if r is not None]
    return f"""## Blind results (`{Path(blind_json).as_posix()}`)

`mdr-drive benchmark --blind {res['n']} --seed {res['seed']} --policies {policy_key}`: {res['n']} random
(k, load) points of the training domain that no training or selection decision saw.

* points below the trapezoid by more than 0.05 mm/s: {s['points_below_trapezoid']}
* fraction of the best drive a CMA-ES search finds (where it moves >= 2 mm/s, {s['points_scored']} points):
  mean {s['fraction_of_best_mean']:.3f}, minimum {s['fraction_of_best_min']:.3f}
* critical load over the best two-action cycle's, smallest over {len(s['critical_load_over_best_cycle'])} k:
  {s['critical_load_over_best_cycle_min']:.3f}; over the trapezoid's: {min(over_trap):.3f}-{max(over_trap):.3f}
"""


def ship(src: str | Path, dst: str | Path, blind_json: str | Path | None = None) -> Path:
    """Copy the run in ``src`` to ``dst`` (nothing to copy if they are the same folder) and write
    its card; with ``blind_json``, the card quotes the policy's blind results from it."""
    src, dst = Path(src), Path(dst)
    dst.mkdir(parents=True, exist_ok=True)
    files = FILES + (("teacher_lookup.npz",) if (src / "teacher_lookup.npz").exists() else ())
    if src.resolve() != dst.resolve():
        for name in files:
            shutil.copy2(src / name, dst / name)
    run = json.loads((dst / "run.json").read_text())
    size_kb = sum((dst / n).stat().st_size for n in files) / 1024
    lookup_limit = ("\n* It plays a residual on its teacher's lookup, so it runs only through "
                    "`agents.evaluate.Policy`: `PPO.load` reads `model.zip`, but its observation has 19 entries "
                    "(the env's 14 and the lookup's action)." if len(files) > len(FILES) else "")
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

## Limits

* Trained for the ranges above with the paper's friction (mu = 0.3, mu1 = 0.1) and material; `mdr-drive
  evaluate` warns outside the trained k and loads and at other friction coefficients.{lookup_limit}
* It observes k and the load: a drive that knows neither needs a sensor-only policy (`MDRDriveSensor-v0`).

## Evaluation

Steady slider velocity in mm/s, learned (trapezoid), mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS} of a
fresh drive, computed by `python -m agents.model_card {src.as_posix()} {dst.as_posix()}` from the shipped files:

{evaluation_table(dst)}

The full comparison with CMA-ES and other training seeds is in docs/results.md
(`mdr-drive benchmark`). "runaway": the load accelerates the slider backwards without bound.

{blind_section(blind_json, dst.as_posix()) if blind_json else ""}"""
    write_text(dst / "MODEL_CARD.md", card)
    return dst / "MODEL_CARD.md"


if __name__ == "__main__":  # python -m agents.model_card SRC DST [BLIND.json]
    print(ship(*sys.argv[1:4]).read_text())
