"""Speed-up of the sweeps from 1 to N workers, and their expected wall time on larger clusters.

    python scripts/scaling.py --out results/scaling          # about 4 minutes on 2 cores
    python scripts/scaling.py --ray-address auto --out ...   # the same sweeps on a Ray cluster

Five sweeps, each a representative slice of the real one, run first on 1 worker, then on
``--workers`` (default: the cores available), same tasks, same results (checked):

- the paper reproduction at paper numerics (``mdr-drive reproduce --quick``'s Fig. 5 cases);
- the shipped recipe's teacher (``mdr_drive_agents.teacher.node_search.search_slice``: two of its 13 k
  slices);
- the blind benchmark's per-point search (``mdr_drive_agents.benchmarks.point_search.best_drive`` at the first
  points of a seed);
- the recipe's sensor table searches (``mdr_drive_agents.teacher.drive_table.search_drives`` at hidden draws,
  the shipped recipe's budgets);
- the recipe's sensor episode values (``mdr_drive_agents.teacher.drive_table.values_task``: 16 hidden points a
  task, every drive of a 256-drive table; the told student's labels are the same tasks over its library).

Every task's own duration is measured in the worker, the 1-worker run's on one thread (its batched
simulators would otherwise step large batches on every core), so the projection to P CPUs uses measured
costs of one CPU: the full sweep's task count times the measured mean cost, scheduled longest first on P
workers (a lower bound that ignores the driver), plus the driver's measured overhead per task
(the 1-worker wall time minus the sum of the task times, per task). What stops the scaling is
printed beside each: the longest task (no sweep finishes before it), or the driver.
Writes ``scaling.json`` and ``scaling.md``.
"""

from __future__ import annotations

import argparse
import heapq
import json
import sys
import time
from pathlib import Path

import numpy as np

from mdr_drive_env.core.batch import set_process_threads
from mdr_drive_env.files import write_text
from mdr_drive_env.sweep import Executor, available_cores


def timed_call(args):
    """(seconds, result) of ``fn(task)``, timed where it runs."""
    fn, task = args
    t0 = time.perf_counter()
    result = fn(task)
    return time.perf_counter() - t0, result


def same(a, b) -> bool:
    """Whether two results are equal value for value (floats exactly, NaN equal to NaN; pickles of
    equal results can differ in how they share objects, so they are not compared)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (a != a and b != b)
    return a == b


def makespan(costs: list[float], cpus: int) -> float:
    """Wall time (s) of tasks with these costs, longest first onto ``cpus`` workers."""
    loads = [0.0] * min(cpus, len(costs))
    heapq.heapify(loads)
    for c in sorted(costs, reverse=True):
        heapq.heappush(loads, heapq.heappop(loads) + c)
    return max(loads)


def reproduce_sweep(n: int):
    from mdr_drive_env.core import DriveParams
    from mdr_drive_env.reproduce import (FIG4_KS, FIG5_KS, FIG5_LEFT_KS, FIG5_LEFT_MASSES, FIG5_MASSES,
                                         SENSITIVITY_SCALES, fig5_case)

    cases = [(k, m) for m in FIG5_MASSES[::4] for k in FIG5_KS[::6]][:n]
    # the full reproduction's fig5_case tasks: both panels of Fig. 5, Fig. 4's points, the sensitivity
    # (plus 9 traces of Figs. 3-4, not counted)
    full = (len(FIG5_KS) * len(FIG5_MASSES) + len(FIG5_LEFT_KS) * len(FIG5_LEFT_MASSES) + len(FIG4_KS)
            + 3 * len(SENSITIVITY_SCALES))
    return fig5_case, [(DriveParams.paper(k=k, cargo_mass=m), "paper") for k, m in cases], full


def teacher_sweep(n: int):
    from mdr_drive_agents.drive import PAPER_DRIVE
    from mdr_drive_agents.protocol import trapezoid_critical_load
    from mdr_drive_agents.teacher.node_search import search_slice
    from mdr_drive_agents.train.recipe import DEFAULT_CONFIG, load_recipe

    config = load_recipe(DEFAULT_CONFIG).teacher
    ks = config.ks[1::max(1, len(config.ks) // n)][:n]  # k slices of the shipped recipe's grid
    drive = PAPER_DRIVE.with_search_solver(config.search_steps_per_period)  # the solver the teacher searches on
    crit = trapezoid_critical_load([float(k) for k in ks], drive)
    return search_slice, [(float(k), config.fractions * c, config, i, drive) for i, (k, c) in enumerate(zip(ks, crit))], \
        config.k_values


def blind_sweep(n: int):
    from mdr_drive_agents.benchmarks.blind import draw_points
    from mdr_drive_agents.benchmarks.point_search import PointTask, best_drive
    from mdr_drive_agents.search import CMA_BUDGET, CYCLE_SEARCH

    points, _ = draw_points(n, seed=1)
    return best_drive, [PointTask(k, m, CMA_BUDGET, CYCLE_SEARCH["budget"]) for k, m in points], 24


def sensor_table_sweep(n: int):
    from mdr_drive_agents.protocol import draw_hidden, hidden_point
    from mdr_drive_agents.teacher.drive_table import SearchTask, search_drives
    from mdr_drive_agents.train.recipe import DEFAULT_CONFIG, load_recipe

    table = load_recipe(DEFAULT_CONFIG).sensor_policy.table
    start = np.load(Path(__file__).parents[1] / "agents/pretrained/ppo_sensor/action_codebook.npy")[2:4]  # a cycle
    tasks = [SearchTask(hidden_point(d), table.fixed_budget, table.cycle_budget, table.polish_budget, start)
             for d in draw_hidden(n, 1)]
    return search_drives, tasks, table.points


def episode_values_sweep(n: int):
    from mdr_drive_agents.protocol import draw_hidden, hidden_point
    from mdr_drive_agents.teacher.drive_table import VALUE_CHUNK, ValuesTask, values_task
    from mdr_drive_agents.train.recipe import DEFAULT_CONFIG, load_recipe

    sensor = load_recipe(DEFAULT_CONFIG).sensor_policy
    drives = np.load(Path(__file__).parents[1] / "agents/pretrained/ppo_sensor/action_codebook.npy").reshape(-1, 2, 5)
    points = [hidden_point(d) for d in draw_hidden(n * VALUE_CHUNK, 1)]
    tasks = [ValuesTask(tuple(points[i:i + VALUE_CHUNK]), drives.astype(np.float64))
             for i in range(0, len(points), VALUE_CHUNK)]
    episodes = sensor.sensor.episodes
    full_points = episodes + int(round(sensor.sensor.load_step_share * episodes))  # a load step adds its second point
    return values_task, tasks, -(-full_points // VALUE_CHUNK)


#: sweep name: (its slice, tasks measured per --tasks 8)
SWEEPS = {"paper reproduction (paper numerics)": (reproduce_sweep, 2), "recipe teacher (k slices)": (teacher_sweep, 0.25),
          "blind benchmark searches": (blind_sweep, 1),
          "recipe sensor table searches": (sensor_table_sweep, 1),
          "recipe sensor episode values (256 drives)": (episode_values_sweep, 1)}


def measure(name: str, fn, tasks, full: int, executors: dict[str, Executor]) -> dict:
    out: dict = {"tasks_measured": len(tasks), "tasks_full_sweep": full, "wall_s": {}}
    results = {}
    for label, ex in executors.items():
        set_process_threads(1 if label == "1 worker" else None)  # one CPU: the in-process run's batches on one thread
        t0 = time.perf_counter()
        timed = ex.map(timed_call, [(fn, t) for t in tasks], f"{name} ({label})")
        out["wall_s"][label] = time.perf_counter() - t0
        set_process_threads(None)
        results[label] = [r for _, r in timed]
        if label == "1 worker":
            costs = [c for c, _ in timed]
    labels = list(executors)
    out["same_results"] = all(same(r, results["1 worker"]) for r in results.values())
    out["speedup"] = out["wall_s"][labels[0]] / out["wall_s"][labels[-1]]
    out["task_s"] = {"mean": float(np.mean(costs)), "max": float(np.max(costs)), "sum": float(np.sum(costs))}
    out["driver_overhead_per_task_s"] = max(0.0, (out["wall_s"][labels[0]] - sum(costs)) / len(tasks))
    rng = np.random.default_rng(0)
    full_costs = list(rng.choice(costs, full))  # the full sweep's costs, resampled from the measured ones
    out["projected_wall_s"] = {}
    for cpus in (2, 8, 64, 512):
        compute = makespan(full_costs, cpus)
        driver = out["driver_overhead_per_task_s"] * full
        out["projected_wall_s"][str(cpus)] = {"wall": compute + driver, "limited_by": (
            "longest task" if compute <= max(full_costs) * 1.01 else
            ("driver" if driver > compute else "CPUs"))}
    return out


def markdown(res: dict) -> str:
    lines = [f"Sweep scaling (`{res['command']}`), {res['cores']} cores; speed-up = wall(1 worker) / "
             f"wall({res['workers']} {'Ray' if res['ray'] else 'local'} workers), same tasks and results.", "",
             "| sweep | tasks measured | wall 1 worker (s) | wall N workers (s) | speed-up | same results | "
             "task mean / max (s) |", "|---|---|---|---|---|---|---|"]
    for name, r in res["sweeps"].items():
        w = list(r["wall_s"].values())
        lines.append(f"| {name} | {r['tasks_measured']} | {w[0]:.1f} | {w[-1]:.1f} | {r['speedup']:.2f} | "
                     f"{r['same_results']} | {r['task_s']['mean']:.2f} / {r['task_s']['max']:.2f} |")
    lines += ["", "Projected wall time of the full sweep (measured task costs resampled to its task count, "
              "longest first on P CPUs, plus the measured driver overhead per task):", "",
              "| sweep | tasks | 2 CPUs | 8 CPUs | 64 CPUs | 512 CPUs | limited at 512 by |", "|---|---|---|---|---|---|---|"]
    for name, r in res["sweeps"].items():
        p = r["projected_wall_s"]
        lines.append(f"| {name} | {r['tasks_full_sweep']} | " + " | ".join(f"{p[c]['wall']:.0f} s" for c in
                                                                           ("2", "8", "64", "512"))
                     + f" | {p['512']['limited_by']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results/scaling", help="output folder")
    ap.add_argument("--workers", type=int, default=available_cores(), help="workers of the parallel run (-)")
    ap.add_argument("--ray-address", default=None, help="run the parallel run on Ray at this address")
    ap.add_argument("--tasks", type=int, default=8, help="tasks measured per sweep (-)")
    a = ap.parse_args(argv)
    executors = {"1 worker": Executor(workers=1),
                 f"{a.workers} workers": Executor(workers=a.workers, ray_address=a.ray_address)}
    executors[f"{a.workers} workers"].check()
    res = {"command": "python scripts/scaling.py " + " ".join(argv if argv is not None else sys.argv[1:]),
           "cores": available_cores(), "workers": a.workers, "ray": a.ray_address is not None, "sweeps": {}}
    for name, (make, share) in SWEEPS.items():
        fn, tasks, full = make(max(2, int(round(a.tasks * share))))
        res["sweeps"][name] = measure(name, fn, tasks, full, executors)
        print(json.dumps({name: res["sweeps"][name]}, indent=1, default=str))
    out = Path(a.out)
    write_text(out / "scaling.json", json.dumps(res, indent=2, default=str))
    write_text(out / "scaling.md", markdown(res))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
