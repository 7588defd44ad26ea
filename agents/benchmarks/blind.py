"""The blind benchmark: policies judged on random points nobody tuned to (``mdr-drive benchmark --blind``).

    mdr-drive benchmark --blind 24 --seed 7 --policies agents/pretrained/ppo_generalist --out runs/blind/seed7

``--seed`` draws N points (k, load) from the training domain: k uniform in [0, 0.6], the cargo
mass uniform from 0 to 1.25 times the trapezoid's critical load at that k. At every point it
reports the trapezoid, each policy (closed loop), and the best drive found by a stated search:
CMA-ES over fixed actions (``CMA_BUDGET`` evaluations) and over two-action cycles
(``CYCLE_SEARCH``, from the trapezoid and from the push/clamp cycle), the better of the two. Then
a critical-load scan over ``--scan-ks`` values of k in [0, 0.6] for the trapezoid, the policies and
the best two-action cycle (bisection with CMA-ES at every trial load, ``cycle_critical_load``):
evenly spaced, the same for every seed, or with ``--scan-draw`` drawn with the seed, one uniform k
in each of ``--scan-ks`` equal cells (``scan_k_values``), so that the critical-load target too is
judged on k values nobody tuned to.
``--reference strong`` then strengthens every point's best drive (``REFERENCES``): three rounds of
CMA-ES from the fastest, played at the point, of every point's best drive so far (and of random
cycles), which finds drives the standard search misses; the policies the recipe builds beat the
standard search on average and not the strong one (docs/results.md).
Every velocity follows the evaluation protocol (``mdr_drive_agents.protocol``: 30 periods, mean of
the last 10, runaways marked). The searches quantise their drives to the time quantum the policies act
at (their run.json's ``time_quantum``, default 10 us; policies with different quanta are refused),
so a policy is compared with drives of its own action units; the trapezoid's corners lie on every
quantum.

Statistics, per policy (``mdr_drive_agents.benchmarks.targets``): points below the trapezoid by more
than ``BELOW_TOLERANCE`` where either moves; the fraction of the best drive, only where the best
drive moves at least ``MOVING_THRESHOLD`` (never a ratio to a near-zero number); critical load over
the trapezoid's and over the best cycle's at every scanned k. Keep one seed for your own choices
and report on another: a result on the seed you tuned on is not a blind result.

Writes ``blind.json``, ``blind.md``, ``points.csv``, ``critical_loads.csv`` and two PNG plots.
The searches run on ``mdr_drive_env.sweep`` (``--workers``, or a Ray cluster with
``--ray-address``); each finished search is kept in ``OUT/.tasks`` as it completes, so after Ctrl-C
(or a lost node) ``--resume`` runs only the searches that are missing.
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np

from mdr_drive_env.files import json_safe, nan_array, write_csv, write_text
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from ..drive import PAPER_DRIVE, DriveDescription
from ..policy import load_policy, policy_label
from ..protocol import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    TIME_QUANTUM,
    critical_loads,
    csv_velocity,
    format_velocity,
    open_loop_velocity,
    play_drive,
    play_time_quantum,
    policy_rollout,
    policy_velocity,
    steady_velocity_of,
    trapezoid_action,
    trapezoid_critical_load,
)
from ..search import CMA_BUDGET, CRITICAL_BISECTIONS, CYCLE_SEARCH
from .plots import plot_blind
from .point_search import PointTask, ScanTask, best_drive, cycle_scan_task, strengthen
from .score import format_aggregate
from .targets import (BELOW_TOLERANCE, CRITICAL_LOAD_TARGET, FRACTION_TARGET, MOVING_THRESHOLD, missed_targets,
                      statistics)

#: The training domain the points are drawn from.
K_RANGE = (0.0, 0.6)
LOAD_FACTOR = 1.25
#: Budgets of the quick mode (CI): tiny searches, a 3-value scan with 1 bisection step.
QUICK = {"fixed_budget": 24, "cycle_budget": 32, "scan_ks": 3, "iterations": 1}
#: The reference searches (``--reference``): ``standard``, ``search_point`` at every point; ``strong``,
#: then ``passes`` rounds at every point of ``pooled_cycle_search`` from every point's best drive so far
#: (and, in the first round, ``random_cycles`` random cycles): CMA-ES from the ``starts`` fastest of
#: them there, ``budget`` evaluations each. Good drives are shared across the domain, and a search
#: from the trapezoid and push/clamp alone misses many of them. ``QUICK_STRONG``: its CI size.
REFERENCES = {"standard": None, "strong": {"passes": 3, "random_cycles": 1000, "starts": 2, "budget": 1000}}
QUICK_STRONG = {"passes": 1, "random_cycles": 8, "starts": 1, "budget": 16}
#: How a scan's k values were chosen (``blind.json``'s ``scan``; files without the key: evenly spaced).
EVEN_SCAN, DRAWN_SCAN = "evenly spaced", "drawn with the seed, one per equal cell"
#: The second entry of the seed sequence that draws a scan's k values (``scan_k_values``).
SCAN_STREAM = 1


def draw_points(n: int, seed: int, drive: DriveDescription = PAPER_DRIVE) -> tuple[list[tuple[float, float]], np.ndarray]:
    """``n`` (k, cargo mass) points of the drive's domain (its k range; the paper drive's is
    ``K_RANGE``) from ``seed``, and the trapezoid's critical load at each k."""
    rng = np.random.default_rng(seed)
    ks = [float(round(k, 6)) for k in rng.uniform(*drive.k_range, n)]
    crit = trapezoid_critical_load(ks, drive)
    masses = rng.uniform(0.0, 1.0, n) * LOAD_FACTOR * crit
    return [(k, float(m)) for k, m in zip(ks, masses)], crit


def scan_of(res: dict) -> str:
    """How the scan of a blind benchmark's result ``res`` chose its k values: ``EVEN_SCAN`` or
    ``DRAWN_SCAN`` (files written before ``--scan-draw`` have no key: evenly spaced)."""
    return res.get("scan", EVEN_SCAN)


def scan_k_values(count: int, seed: int | None = None, k_range: tuple[float, float] = K_RANGE) -> list[float]:
    """The k values of the critical-load scan: ``count`` evenly spaced over ``k_range`` (``seed``
    None), or drawn with ``seed``, one uniform k in each of ``count`` equal cells of it (a stream of
    its own: the points ``draw_points`` draws with the same seed are unchanged). Rounded to 1e-6."""
    low, high = k_range
    if seed is None:
        return [float(k) for k in np.round(np.linspace(low, high, count), 6)]
    offsets = np.random.default_rng([seed, SCAN_STREAM]).uniform(size=count)
    return [float(k) for k in np.round(in_k_cells(offsets, k_range), 6)]


def in_k_cells(offsets, k_range: tuple[float, float] = K_RANGE) -> np.ndarray:
    """One k in each of ``len(offsets)`` equal cells of ``k_range`` (default ``K_RANGE``), at
    ``offsets`` (0 ... 1) of its cell (0.5: the cells' midpoints)."""
    low, high = k_range
    offsets = np.asarray(offsets, dtype=np.float64)
    return low + (np.arange(len(offsets)) + offsets) * (high - low) / len(offsets)


def reusable_search(path: str | Path, res: dict, scan_ks: int) -> dict:
    """The earlier ``blind.json`` at ``path`` if it was drawn and searched as ``res`` asks, else
    ``ValueError`` saying what differs."""
    previous = json.loads(Path(path).read_text())
    for key in ("seed", "n", "search", "drive"):
        if previous.get(key) != res.get(key):
            raise ValueError(f"--reuse-search {path}: its {key} {previous.get(key)!r} is not this run's {res[key]!r}")
    if len(previous["critical_load_kg"]["k"]) != scan_ks:
        raise ValueError(f"--reuse-search {path}: it scanned {len(previous['critical_load_kg']['k'])} k values, "
                         f"not --scan-ks {scan_ks}")
    if scan_of(previous) != res["scan"]:
        raise ValueError(f"--reuse-search {path}: its scan's k values are {scan_of(previous)}, "
                         f"not {res['scan']}")
    return previous


def run(policies: list[str], n: int, seed: int, out: str | Path, quick: bool = False, scan_ks: int = 25,
        workers: int | None = None, fixed_budget: int = CMA_BUDGET, cycle_budget: int = CYCLE_SEARCH["budget"],
        iterations: int = CRITICAL_BISECTIONS, reuse: str | Path | None = None, executor: Executor | None = None,
        resume: bool = False, scan_draw: bool = False, drive: DriveDescription | None = None,
        reference: str = "standard") -> dict:
    """The blind benchmark (module docstring); returns what ``blind.json`` holds.

    ``reuse``: a ``blind.json`` of the same seed, size, search budgets and scan, whose points,
    trapezoid, best drives and critical loads of the trapezoid and the best cycle are taken as they
    are (the searches are most of the cost); only the policies are run. ``executor`` runs the
    searches (default: ``workers`` local processes); ``resume`` reuses the searches an interrupted
    run into ``out`` finished; ``scan_draw`` draws the scan's k values with ``seed``
    (``scan_k_values``) instead of spacing them evenly. ``drive``: the drive judged on (default the
    paper's, or the one the policies were built for; ``protocol.play_drive``), its k range drawn from.
    ``reference``: the search that finds each point's best drive, a key of ``REFERENCES``.
    """
    if reference not in REFERENCES:
        raise ValueError(f"reference={reference!r} is not one of {list(REFERENCES)}")
    strong = REFERENCES[reference] if not quick or REFERENCES[reference] is None else QUICK_STRONG
    if quick:  # a scan turned off (scan_ks 0) stays off
        fixed_budget, cycle_budget, quick_ks, iterations = (QUICK[key] for key in
                                                            ("fixed_budget", "cycle_budget", "scan_ks", "iterations"))
        scan_ks = min(scan_ks, quick_ks)
    executor = executor or Executor(workers=workers)
    out = Path(out)
    tasks = task_folder(out, resume)
    t0 = time.perf_counter()
    loaded = [load_policy(p) for p in policies]
    drive = play_drive(loaded, drive)
    res: dict = {"seed": seed, "n": n, "domain": {"k": list(drive.k_range), "load": f"0-{LOAD_FACTOR}x trapezoid critical"},
                 "search": {"fixed_action_cma_evaluations": fixed_budget,
                            "two_action_cycle_cma_evaluations_per_start": cycle_budget, "cycle_starts": 2,
                            "cycle_critical_load_bisection_steps": iterations},
                 "protocol": f"fast numerics; mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}",
                 "scan": DRAWN_SCAN if scan_draw else EVEN_SCAN, "policies": list(policies),
                 "policy_labels": [policy_label(p) for p in policies]}  # the plots name them without the folders
    if strong:
        res["search"]["pooled_rounds"] = dict(strong)  # files of the standard search stay reusable as before
    if drive.settings != ():
        res["drive"] = drive.to_record()
    time_quantum = play_time_quantum(loaded)  # the search runs in the action units the policies act in
    if time_quantum != TIME_QUANTUM:  # files of the default quantum stay reusable
        res["search"]["time_quantum_s"] = time_quantum
    previous = reusable_search(reuse, res, scan_ks) if reuse else None
    if previous:
        res["search_reused_from"] = str(reuse)
        points = [tuple(p) for p in previous["points"]]
        trap = nan_array(previous["trapezoid"])
        found = previous["best"]
    else:
        points, _ = draw_points(n, seed, drive)
        trap = open_loop_velocity(points, trapezoid_action(drive), mark_runaway=True, drive=drive)
        found = executor.map(best_drive, [PointTask(k, m, fixed_budget, cycle_budget, time_quantum=time_quantum,
                                                    drive=drive) for k, m in points],
                             "best drive per point", store=TaskStore(tasks / "best_drive"))
        if strong:
            found = strengthen(found, points, strong, time_quantum, drive, executor, tasks)
    res["points"], res["trapezoid"], res["best"] = points, trap.tolist(), found
    best_v = nan_array([f["velocity"] for f in found])
    learned = {}
    for path, pol in zip(policies, loaded):
        disp, _, runaway = policy_rollout(pol, points, drive=drive)
        learned[path] = steady_velocity_of(disp, runaway=runaway, period=drive.period)
    res["learned"] = {p: v.tolist() for p, v in learned.items()}
    if previous:
        old = previous["critical_load_kg"]
        ks, crit_trap, crit_cycle = old["k"], np.array(old["trapezoid"]), old["best cycle"]
    elif scan_ks == 0:  # no critical-load scan: the points alone
        ks, crit_trap, crit_cycle = [], np.array([]), []
    else:
        ks = scan_k_values(scan_ks, seed if scan_draw else None, drive.k_range)
        crit_trap = trapezoid_critical_load(ks, drive)
        crit_cycle = executor.map(cycle_scan_task,
                                  [ScanTask(k, m, iterations, cycle_budget, time_quantum, drive)
                                   for k, m in zip(ks, crit_trap)],
                                  "critical load of the best cycle per k", store=TaskStore(tasks / "cycle_scan"))
    crit = {"k": ks, "trapezoid": crit_trap.tolist(), "best cycle": crit_cycle}
    for path, pol in zip(policies, loaded):
        c = critical_loads(ks, lambda pts, pol=pol: policy_velocity(pol, pts, drive=drive), drive)
        crit[path] = [c[k] for k in ks]
    res["critical_load_kg"] = crit
    res["statistics"] = {p: statistics(trap, best_v, learned[p], {**crit, "policy": crit[p]}, ks)
                         for p in policies}
    res["wall_time_s"] = round(time.perf_counter() - t0, 1)
    if executor.is_ray:
        res["executor"] = f"ray ({executor.ray_address})"
    write_outputs(res, out)
    shutil.rmtree(tasks, ignore_errors=True)  # every output is written: the per-task results are spent
    return res


def pooled_text(rounds: dict | None) -> str:
    """How the ``strong`` reference's rounds (``blind.json``'s ``search.pooled_rounds``) went on, or ''."""
    if not rounds:
        return ""
    return (f", then {rounds['passes']} round(s) at every point of CMA-ES ({rounds['budget']} evaluations from "
            f"each of the {rounds['starts']} fastest there of every point's best drive so far"
            + (f" and, in the first round, {rounds['random_cycles']:,} random cycles" if rounds["random_cycles"] else "")
            + "; the strong reference)")


def markdown(res: dict) -> str:
    drive = res.get("drive")
    settings = ", ".join(f"{k}={v}" for k, v in (drive or {}).items() if k not in ("name", "k", "load_ratio"))
    shown = "" if drive is None else f" on drive {drive['name']} ({settings})"
    lines = [f"Blind benchmark{shown}, seed {res['seed']}: {res['n']} points, k uniform in {res['domain']['k']}, "
             f"load {res['domain']['load']}; {res['protocol']}.",
             f"Best drive: the better of CMA-ES over fixed actions ({res['search']['fixed_action_cma_evaluations']} "
             f"evaluations) and over two-action cycles ({res['search']['two_action_cycle_cma_evaluations_per_start']} "
             "evaluations from each of 2 starts)" + pooled_text(res["search"].get("pooled_rounds")) +
             ". Velocities in mm/s; 'runaway': the load runs away with the slider.",
             "", "| k | m (kg) | trapezoid | best drive (kind) | " + " | ".join(
                 f"policy {i + 1}" for i in range(len(res["policies"]))) + " |",
             "|---|---|---|---|" + "---|" * len(res["policies"])]
    for i, (k, m) in enumerate(res["points"]):
        b = res["best"][i]
        cells = [format_velocity(res["learned"][p][i]) for p in res["policies"]]
        lines.append(f"| {k:.3f} | {m:.4f} | {format_velocity(res['trapezoid'][i])} | "
                     f"{format_velocity(b['velocity'])} ({b['kind']}) | " + " | ".join(cells) + " |")
    crit = res["critical_load_kg"]
    if crit["k"]:
        lines += ["", f"Critical load (kg) per k (k {res.get('scan', EVEN_SCAN)}; best cycle: bisection with CMA-ES "
                  "at every trial load):", "",
                  "| k | trapezoid | best cycle | " + " | ".join(f"policy {i + 1}" for i in range(len(res["policies"])))
                  + " |", "|---|---|---|" + "---|" * len(res["policies"])]
    else:
        lines += ["", "No critical-load scan (--scan-ks 0)."]
    for i, k in enumerate(crit["k"]):
        lines.append(f"| {k:g} | {crit['trapezoid'][i]:.4f} | {crit['best cycle'][i]:.4f} | "
                     + " | ".join(f"{crit[p][i]:.4f}" for p in res["policies"]) + " |")
    lines += ["", "Statistics per policy:", ""]
    for i, p in enumerate(res["policies"]):
        s = res["statistics"][p]
        ratios = [r for r in s["critical_load_over_trapezoid"] if r is not None]
        lines.append(f"* policy {i + 1} (`{p}`): {s['points_below_trapezoid']} points below the trapezoid by more "
                     f"than {BELOW_TOLERANCE * 1e3:g} mm/s (policy minus trapezoid at worst: "
                     f"{_f(s['worst_difference_to_trapezoid_mm_s'])} mm/s); fraction of the best drive where it moves >= {MOVING_THRESHOLD * 1e3:g} mm/s "
                     f"({s['points_scored']} points): mean {_f(s['fraction_of_best_mean'])}, min "
                     f"{_f(s['fraction_of_best_min'])}, {s['points_under_fraction_target']} under "
                     f"{FRACTION_TARGET:g}; normalised score (0 the trapezoid, 1 the best drive; 95 % bootstrap "
                     f"intervals): {format_aggregate(s.get('normalized_score'))}; " + _critical_text(s, ratios)
                     + f"; targets missed: {', '.join(missed_targets(s)) or 'none'}")
    lines += ["", f"wall time {res['wall_time_s']} s"]
    return "\n".join(lines) + "\n"


def _critical_text(s: dict, ratios: list[float]) -> str:
    """The critical-load part of a policy's statistics line (``markdown``)."""
    if not s["critical_load_over_best_cycle"]:
        return "critical load: not scanned"
    return (f"critical load / best cycle's: min {_f(s['critical_load_over_best_cycle_min'])}, >= "
            f"{CRITICAL_LOAD_TARGET:g} at {s['k_values_at_critical_load_target']} of "
            f"{len(s['critical_load_over_best_cycle'])} k; / trapezoid's: "
            + (f"{min(ratios):.3f}-{max(ratios):.3f}" if ratios else "-"))


def _f(x) -> str:
    return "-" if x is None else f"{x:.3f}"


def write_outputs(res: dict, out: Path) -> None:
    write_text(out / "blind.json", json.dumps(json_safe(res), indent=1))
    write_text(out / "blind.md", markdown(res))
    names = [f"policy {i + 1}" for i in range(len(res["policies"]))]
    write_csv(out / "points.csv", ["k", "cargo_mass_kg", "trapezoid_m_s", "best_m_s", "best_kind", *
                                   [f"{n}_m_s" for n in names]],
              [(k, m, csv_velocity(res["trapezoid"][i]), res["best"][i]["velocity"], res["best"][i]["kind"],
                *(csv_velocity(res["learned"][p][i]) for p in res["policies"])) for i, (k, m) in enumerate(res["points"])])
    crit = res["critical_load_kg"]
    write_csv(out / "critical_loads.csv", ["k", "trapezoid_kg", "best_cycle_kg", *[f"{n}_kg" for n in names]],
              [(k, crit["trapezoid"][i], crit["best cycle"][i], *(crit[p][i] for p in res["policies"]))
               for i, k in enumerate(crit["k"])])
    plot_blind(res, out, MOVING_THRESHOLD)

