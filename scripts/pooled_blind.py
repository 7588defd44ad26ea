#!/usr/bin/env python
"""Policies on every stored blind search at once: the blind velocity statistics over hundreds of points.

    python scripts/pooled_blind.py agents/pretrained/ppo_generalist runs/NAME/policy     # about 20 s per policy

A 120-point blind draw holds a handful of the points where a build falls under 0.85 of the best
drive (a few per cent of the domain), so one draw cannot tell two builds apart. The per-point
searches are the blind benchmark's cost (about 4 s a point), and every ``blind.json`` keeps its
points, the trapezoid's velocity and the search's best drive there. This plays each policy at the
points of all of them (``--searches``, default every ``results/blind/*/blind.json`` searched with the
benchmark's budgets, one file per seed and size) and counts the blind benchmark's velocity
statistics (``agents.blind.velocity_statistics``: below the trapezoid, the fraction of the search's
best drive where it moves >= 2 mm/s, points under 0.85) over the pool. ``--critical-load`` adds the
critical-load target on each distinct scan the files hold (the 25-k scan is the same for every seed;
one seed has 31 k): the policy's critical load (``agents.evaluate.critical_loads_grid``, as the
benchmark scans it) over the stored best two-action cycle's, the k values at >= 0.97 and those
under it (about 10 s a scan and policy).

The stored seeds were report seeds of earlier builds or decision seeds: pooled, they are decision
data, never a report. Report on a fresh seed with ``mdr-drive benchmark --blind``.

Prints a Markdown table (and writes it to ``--out``, refused if the file exists).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ROOT = Path(__file__).resolve().parents[1]


def stored_searches(paths: list[Path], time_quantum: float | None = None) -> list[dict]:
    """The blind.json files at ``paths`` searched with the blind benchmark's budgets, at
    ``time_quantum`` (s; default the env's, ``TIME_QUANTUM``), one per (seed, size): the first of
    each in sorted path order."""
    from mdr_drive_agents.blind import CMA_BUDGET, CYCLE_SEARCH
    from mdr_drive_agents.evaluate import TIME_QUANTUM

    time_quantum = TIME_QUANTUM if time_quantum is None else time_quantum

    seen, out = set(), []
    for path in sorted(paths):
        res = json.loads(path.read_text())
        if not isinstance(res, dict) or not {"seed", "n", "points", "trapezoid", "best"} <= set(res):
            raise ValueError(f"{path} is not a blind benchmark's blind.json")
        search = res.get("search", {})
        if (search.get("fixed_action_cma_evaluations"), search.get("two_action_cycle_cma_evaluations_per_start")) != (
                CMA_BUDGET, CYCLE_SEARCH["budget"]) or (res["seed"], res["n"]) in seen:
            continue
        if search.get("time_quantum_s", TIME_QUANTUM) != time_quantum:  # other action units: another reference
            continue
        seen.add((res["seed"], res["n"]))
        out.append({"path": path, **res})
    return out


def pooled_points(searches: list[dict]) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """The points of all ``searches`` pooled: (k, load kg) tuples, each point's seed, the search's
    best velocity there and the trapezoid's (m/s)."""
    from mdr_drive_env.files import nan_array

    points = [(float(k), float(m)) for res in searches for k, m in res["points"]]
    seeds = np.concatenate([[res["seed"]] * len(res["points"]) for res in searches])
    best = np.concatenate([nan_array([b["velocity"] for b in res["best"]]) for res in searches])
    trapezoid = np.concatenate([nan_array(res["trapezoid"]) for res in searches])
    return points, seeds, best, trapezoid


def pooled(policy_path: str, searches: list[dict]) -> dict:
    """The blind velocity statistics of one policy over the points of all ``searches`` (one rollout)."""
    from mdr_drive_agents.blind import velocity_statistics
    from mdr_drive_agents.evaluate import load_policy, policy_rollout, steady_velocity_of

    points, _, best, trapezoid = pooled_points(searches)
    disp, _, runaway = policy_rollout(load_policy(policy_path), points)
    stats = velocity_statistics(trapezoid, best, steady_velocity_of(disp, runaway=runaway))
    return {"points": len(points), **stats}


def stored_scans(searches: list[dict]) -> list[dict]:
    """The distinct critical-load scans of ``searches`` (by their k values; the first file's of each):
    {"seed", "k", "best cycle", "trapezoid"} (kg)."""
    from mdr_drive_agents.blind import stored_scan

    scans: dict = {}
    for res in searches:
        scan = stored_scan(res)
        if scan is not None:
            scans.setdefault(tuple(scan["k"]), {"seed": res["seed"], **scan})
    return list(scans.values())


def critical_load_target(policy_path: str, scan: dict) -> dict:
    """The policy's critical load over the best cycle's at each k of ``scan``
    (``agents.blind.critical_load_on_scan``: the k values at the blind benchmark's target, the minimum
    ratio and the k values under it, the smallest ratio to the trapezoid's)."""
    from mdr_drive_agents.blind import critical_load_on_scan
    from mdr_drive_agents.evaluate import load_policy, policy_velocity

    policy = load_policy(policy_path)
    return critical_load_on_scan(lambda pts: policy_velocity(policy, pts), scan)


def critical_table(rows: dict, scans: list[dict]) -> str:
    from mdr_drive_agents.blind import format_under

    lines = ["", "Critical load over the best two-action cycle's, per stored scan: k values at >= 0.97; the minimum; "
             "the k values under 0.97 (ratio); the smallest ratio to the trapezoid's critical load.", "",
             "| policy | " + " | ".join(
                 f"{len(s['k'])}-k scan (seed {s['seed']})" for s in scans) + " |", "|---|" + "---|" * len(scans)]
    for name, results in rows.items():
        cells = [f"{r['at_target']} of {r['scanned']}; {r['min']:.3f}; "
                 + format_under(r["under"])
                 + f"; trapezoid x {r['min_over_trapezoid']:.3f}" for r in results]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def table(rows: dict, searches: list[dict]) -> str:
    seeds = ", ".join(str(r["seed"]) for r in searches)
    lines = [f"Pooled blind statistics over {len(searches)} stored searches (seeds {seeds}); velocities in mm/s.", "",
             "| policy | points | below the trapezoid | worst vs the trapezoid | scored | under 0.85 | "
             "fraction of the best: mean | min |", "|---|---|---|---|---|---|---|---|"]
    for name, s in rows.items():
        worst = s["worst_difference_to_trapezoid_mm_s"]
        lines.append(f"| {name} | {s['points']} | {s['points_below_trapezoid']} | "
                     f"{'-' if worst is None else f'{worst:+.2f}'} | {s['points_scored']} | "
                     f"{s['points_under_fraction_target']} | {s['fraction_of_best_mean']:.4f} | "
                     f"{s['fraction_of_best_min']:.3f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, run_command
    from mdr_drive_env.files import write_text

    p = Parser(description=__doc__)
    p.add_argument("policies", nargs="+", type=folder_with("model.zip"), help="policy folders (with model.zip)")
    p.add_argument("--searches", nargs="+", type=input_file, default=None, metavar="BLIND.json",
                   help="stored blind.json files (default: every results/blind/*/blind.json with the benchmark's "
                        "search budgets, one per seed and size)")
    p.add_argument("--critical-load", action="store_true",
                   help="also the critical-load target on each distinct stored scan (about 10 s a scan and policy)")
    p.add_argument("--out", default=None, help="also write the table to this Markdown file (refused if it exists)")
    a = p.parse_args(argv)
    if a.out and Path(a.out).exists():
        p.error(f"--out {a.out} exists: choose another file")

    def go() -> int:
        paths = [Path(f) for f in a.searches] if a.searches else list((ROOT / "results" / "blind").glob("*/blind.json"))
        from mdr_drive_agents.evaluate import load_policy, play_time_quantum

        quantum = play_time_quantum([load_policy(policy) for policy in a.policies])
        searches = stored_searches(paths, quantum)
        if not searches:
            raise ValueError(f"no stored blind search with the benchmark's budgets at {quantum:g} s among --searches")
        text = table({policy: pooled(policy, searches) for policy in a.policies}, searches)
        if a.critical_load:
            scans = stored_scans(searches)
            text += critical_table({policy: [critical_load_target(policy, scan) for scan in scans]
                                    for policy in a.policies}, scans)
        print(text, end="")
        if a.out:
            write_text(a.out, text)
        return 0

    return run_command(p.prog, go, "nothing was written")


if __name__ == "__main__":
    raise SystemExit(main())
