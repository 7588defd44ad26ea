"""The blind record: a policy's results on its report seeds as one table, as its model card prints it.

    from mdr_drive_agents.benchmarks.record import blind_record
    print(blind_record(["results/record/seed20261255/blind.json"], "agents/pretrained/ppo_generalist"))
"""

from __future__ import annotations

import json
from pathlib import Path

from mdr_drive_env.files import nan_array

from .blind import DRAWN_SCAN, scan_of
from .score import SCORE_MIN_GAP, aggregate, format_aggregate, normalized_scores
from .targets import (BELOW_TOLERANCE, CRITICAL_LOAD_TARGET, FRACTION_TARGET, MEAN_FRACTION_TARGET, MOVING_THRESHOLD,
                      missed_targets)


def blind_command(res: dict, policy_key: str) -> str:
    """The command that wrote a blind benchmark's result ``res``, with SEED in place of its seed."""
    draw = " --scan-draw" if scan_of(res) == DRAWN_SCAN else ""
    return f"mdr-drive benchmark --blind {res['n']} --seed SEED{draw} --policies {' '.join(res.get('policies', [policy_key]))}"


def blind_record(blind_jsons, policy_key: str) -> str:
    """The policy's blind record: one table row per blind benchmark's ``blind.json`` (one per report
    seed, ``mdr-drive benchmark --blind``), the commands that wrote them and on how many seeds the
    policy met every target (``targets.missed_targets``)."""
    rows, commands, clean, scores = [], {}, 0, []
    for path in blind_jsons:
        res = json.loads(Path(path).read_text())
        s = res["statistics"][policy_key]
        if "trapezoid" in res:  # the per-point velocities (a blind.json holds them)
            scores.append(normalized_scores(nan_array(res["trapezoid"]), nan_array([b["velocity"] for b in res["best"]]),
                                            nan_array(res["learned"][policy_key])))
        over_trap = [r for r in s["critical_load_over_trapezoid"] if r is not None]
        scanned = sum(r is not None for r in s["critical_load_over_best_cycle"])
        missed = missed_targets(s)
        clean += not missed
        commands.setdefault(blind_command(res, policy_key), []).append(str(res["seed"]))
        at_target = sum(r is not None and r >= CRITICAL_LOAD_TARGET for r in s["critical_load_over_best_cycle"])
        crit = "-" if s["critical_load_over_best_cycle_min"] is None else (
            f"{_ratio(s['critical_load_over_best_cycle_min'], CRITICAL_LOAD_TARGET)} ({at_target} of {scanned})")
        under = s.get("points_under_fraction_target", "?")  # not in files written before the key was added
        rows.append(f"| {res['seed']} | {s['points_below_trapezoid']} | {_ratio(s['fraction_of_best_mean'])} | "
                    f"{_ratio(s['fraction_of_best_min'], FRACTION_TARGET)} ({under} of {s['points_scored']}) | "
                    f"{crit} | {_range(over_trap)} | {', '.join(missed) or 'none'} |")
    runs = "\n".join(f"* `{cmd}` with SEED = {', '.join(seeds)}" for cmd, seeds in commands.items())
    low, high = wilson_interval(clean, len(rows))
    return f"""## Blind results

Random (k, load) points of the training domain, drawn with seeds that were not used to build or
select the policy; the best drive at a point is the best a stated CMA-ES search finds (a closed-loop
policy can beat it: fractions above 1). The targets: no point below the trapezoid by more than {BELOW_TOLERANCE * 1e3:g} mm/s; the fraction
of the best drive (where it moves >= {MOVING_THRESHOLD * 1e3:g} mm/s) at least {MEAN_FRACTION_TARGET:g} on average and
{FRACTION_TARGET:g} at every point; the critical load at least {CRITICAL_LOAD_TARGET:g} of the best two-action
cycle's at every scanned k.

{runs}

| report seed | points below the trapezoid | fraction of the best: mean | minimum (points under {FRACTION_TARGET:g}) | critical load / best cycle's: minimum (k at >= {CRITICAL_LOAD_TARGET:g}) | / trapezoid's | targets missed |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}

All four targets met on {clean} of {len(rows)} report seeds: a fresh seed passes with probability about
{clean / len(rows):.2f} (95 % Wilson interval {low:.2f}-{high:.2f}).
{score_note(scores) if len(scores) == len(rows) else ""}"""


def score_note(scores) -> str:
    """The record's normalised score (``score``), each report seed's points a stratum."""
    return f"""
Normalised score over the report seeds' points, `(V - V_trapezoid) / (V_best - V_trapezoid)` where
the best drive beats the trapezoid by at least {SCORE_MIN_GAP * 1e3:g} mm/s (0 the trapezoid, 1 the best
drive found), with 95 % stratified-bootstrap intervals (each seed's points a stratum; rliable's
IQM): {format_aggregate(aggregate(scores))}.
"""


def wilson_interval(passed: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a pass probability from ``passed`` of ``n`` trials (``z`` = 1.96: 95 %)."""
    if n < 1 or not 0 <= passed <= n:
        raise ValueError(f"passed={passed} of n={n}: need 0 <= passed <= n and n >= 1")
    p, z2 = passed / n, z * z
    centre, half = (p + z2 / (2 * n)) / (1 + z2 / n), z / (1 + z2 / n) * (p * (1 - p) / n + z2 / (4 * n * n)) ** 0.5
    return max(centre - half, 0.0), min(centre + half, 1.0)


def _ratio(x, target: float | None = None) -> str:
    """``x`` to three decimals, or as many more as it takes not to print a miss as ``target`` itself
    (0.9696 against 0.97, not 0.970)."""
    if x is None:
        return "-"
    digits = 3
    while target is not None and x < target and float(f"{x:.{digits}f}") >= target and digits < 8:
        digits += 1
    return f"{x:.{digits}f}"


def _range(values) -> str:
    return "-" if not values else f"{min(values):.3f}-{max(values):.3f}"
