"""Ship the best plain-RL run (``mdr-drive rl-baselines --ship DIR``): its policy files and a model
card with its scores from the run's ``results.json``."""

from __future__ import annotations

import json
import math
from pathlib import Path

from mdr_drive_env.files import write_text

from ..benchmarks.model_card import copy_policy, evaluation_table, load_snippet, snippet
from ..benchmarks.record import blind_record
from ..benchmarks.score import aggregate, format_aggregate
from ..protocol import AVERAGE_PERIODS, EVAL_PERIODS
from .config import ALGORITHM_NAMES
from .report import run_scores
from .runner import Plan


def shipped_folder(root: str | Path, algo: str) -> Path:
    """Where ``--ship ROOT`` puts a plain ``algo`` policy: ``ROOT/<algo>_plain``."""
    return Path(root) / f"{algo}_plain"


def ship_plain(best: dict, found: dict, summaries: dict, results_dir: str | Path, root: str | Path,
               records=()) -> Path:
    """Copy the run ``best`` (``pipeline.best_run``) to ``shipped_folder(root, algo)`` and write its card,
    with its blind record if ``records`` (``blind.json`` files of ``mdr-drive benchmark --blind`` that
    judged the shipped folder) are given; returns the card's path."""
    plan: Plan = found["plan"]
    run = next(r for r in found["runs"][best["agent"]] if r["seed"] == best["seed"])
    scores, fractions, parts = run_scores(plan, run)
    stats = [ref.statistics(v) for ref, v in zip(plan.reports, parts)]
    below = sum(st["points_below_trapezoid"] for st in stats)
    worst = min(st["worst_difference_to_trapezoid_mm_s"] for st in stats)
    fraction_min = min(st["fraction_of_best_min"] for st in stats)
    points = sum(len(ref.points) for ref in plan.reports)
    dst = shipped_folder(root, best["algo"])
    for path in records:  # before anything is copied
        if dst.as_posix() not in json.loads(Path(path).read_text()).get("statistics", {}):
            raise ValueError(f"{path} did not judge {dst.as_posix()}: its record is not this policy's")
    dst, record = copy_policy(source_of(best, dst), dst)
    name = ALGORITHM_NAMES[best["algo"]]
    own = format_aggregate(aggregate(scores))
    agent = summaries[best["agent"]]
    hyper = {k: v for k, v in record["hyperparameters"].items() if k != "policy_kwargs"}
    results = Path(results_dir).as_posix()
    warm = record["hyperparameters"].get("warm_start", "none")
    start = "no warm start" if warm == "none" else "its mean action started at the paper's trapezoid"
    card = f"""# {dst.name}: plain {name} on MDRDrive-v0

A Stable-Baselines3 {name} policy trained on `MDRDrive-v0` by reinforcement learning alone: no
teacher, no table of drives, {start}. It observes the env's 14 observations (k and the load among
them) and sets each period's waveform within the paper's actuator limits, its rises and z phase in
{record['env_kwargs'].get('time_quantum', 1e-5) * 1e6:g} us steps. It is the best of the runs of
`mdr-drive rl-baselines` on the points of its validation blind record ({plan.validation.name}): agent
"{best['agent']}", training seed {best['seed']}. It is the reference for what plain RL reaches here
(`{results}/benchmark.md`, docs/rl_baselines.md); the distilled `ppo_generalist` scores higher
on the same points (the table there).

## Load it

{load_snippet(dst, record)}

With Stable-Baselines3 alone:

{snippet(dst, record)}

Or: `mdr-drive evaluate --policy {dst.as_posix()} --k 0.2 --cargo-mass 0.1 --json`.

## How it was made

* Command: `{record['command']}`, as one run of `mdr-drive rl-baselines` (its hyperparameters:
  `{results}/hyperparameters/`)
* Training: {name}, {record['total_timesteps']:,} environment steps (drive periods), {record['wall_time_s']:.0f} s
  on one core
* Training range (env kwargs): `{json.dumps(record['env_kwargs'])}`
* Settings: `{json.dumps(hyper)}`, policy `{json.dumps(record['hyperparameters'].get('policy_kwargs', {}))}`
* Versions: `{json.dumps(record['versions'])}`

## Its scores

Normalised score (0 the trapezoid, 1 the best drive the blind benchmark's search found; IQM and mean
with 95 % bootstrap intervals over the points) on the report records {', '.join(r.name for r in plan.reports)},
from `{results}/results.json`:

* this policy: {own}
* its agent's {len(agent['steps'])} training seeds: {format_aggregate(agent['score'])}
* this policy's fraction of the best drive where that drive moves at least 2 mm/s: mean
  {sum(float(f.sum()) for f in fractions) / max(1, sum(f.size for f in fractions)):.3f}, lowest {fraction_min:.3f}
* points below the trapezoid by more than 0.05 mm/s: {below} of {points} (at worst {worst:.2f} mm/s)

## Limits

{dropped_load_note(list(records), dst.as_posix())}* It is below the trapezoid at some points (above) and well short of the best drive at others: judge a
  working point with `mdr-drive evaluate` first, or a whole record with `mdr-drive benchmark --blind N
  --seed S --policies {dst.as_posix()}`.
* Trained for the ranges above with the paper's friction (mu = 0.3, mu1 = 0.1) and material.

## Evaluation

Steady slider velocity in mm/s, policy (trapezoid), mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}
of a fresh drive, computed from the shipped files. "runaway": the load accelerates the slider backwards
without bound.

{evaluation_table(dst)}

{blind_record(list(records), dst.as_posix()) if records else ""}"""
    write_text(dst / "MODEL_CARD.md", card)
    return dst / "MODEL_CARD.md"


def source_of(best: dict, dst: Path) -> Path:
    """Where the run ``best`` is: its training folder, or ``dst`` when that folder is gone and ``dst``
    already holds the same run (its card is written again in place); ``ValueError`` otherwise."""
    folder = Path(best["folder"])
    if (folder / "run.json").is_file():
        return folder
    shipped = json.loads((dst / "run.json").read_text()) if (dst / "run.json").is_file() else {}
    if shipped.get("algo") == best["algo"] and shipped.get("seed") == best["seed"]:
        return dst
    raise ValueError(f"{folder}: the run to ship is not there (and {dst} holds another): train it again")


def dropped_loads(records: list[dict], key: str) -> list[tuple[float, float, float, float]]:
    """Where the blind benchmarks ``records`` (``blind.json`` loaded) saw the policy ``key`` drop the
    load the trapezoid carries: (k, cargo mass kg, trapezoid m/s, policy m/s, NaN a runaway) at each
    point where the trapezoid holds or moves the load forward (>= 0) and under the policy it runs away
    or drags the slider back."""
    return [(k, m, trap, math.nan if v is None else v)
            for res in records for (k, m), trap, v in zip(res["points"], res["trapezoid"], res["learned"][key])
            if trap is not None and trap >= 0.0 and (v is None or v < 0.0)]


def dropped_load_note(paths, key: str) -> str:
    """The card's warning of :func:`dropped_loads` over the ``blind.json`` files ``paths`` (a bullet, or
    '' where there is no record)."""
    if not paths:
        return ""
    records = [json.loads(Path(p).read_text()) for p in paths]
    dropped = dropped_loads(records, key)
    n = sum(len(res["points"]) for res in records)
    if not dropped:
        return f"* It never drops a load the trapezoid carries on its record's {n:,} points.\n"
    runaways = sum(math.isnan(d[3]) for d in dropped)
    ks = [d[0] for d in dropped]
    worst = max(dropped, key=lambda d: d[2])  # where the trapezoid moves it forward fastest
    where = (f"k = {worst[0]:.3f}, m = {worst[1]:.4f} kg: the trapezoid {worst[2] * 1e3:.2f} mm/s, this policy "
             + ("a runaway" if math.isnan(worst[3]) else f"{worst[3] * 1e3:.2f} mm/s"))
    return (f"* **It drops loads the trapezoid carries.** At {len(dropped)} of its record's {n:,} points (k\n"
            f"  {min(ks):.2f}-{max(ks):.2f}) the trapezoid holds the load or moves it forward and under this policy\n"
            f"  it runs away with the slider ({runaways} points) or drags it back; at worst {where}.\n"
            "  Do not drive a load near the trapezoid's critical load with it.\n")


__all__ = ["dropped_load_note", "dropped_loads", "ship_plain", "shipped_folder", "source_of"]
