"""Refine the CMA-ES teacher where its lookup fails: new CMA-ES points at probe points (DAgger-style).

    python -m agents.lookup_refine runs/teacher4.npz --probe-points 384 --rounds 3 --out runs/teacher7.npz

The teacher's lookup (``agents.residual.TeacherLookup``) plays the drive of the nearest teacher
point. Between two points whose drives differ, the nearest one's drive can be a poor fit: at k =
0.1 and 0.2 kg the recipe's teacher makes 7.5 mm/s where the trapezoid makes 11.0, and at k = 0
it stalls in a window of loads below 1.3 times the trapezoid's critical load. Like DAgger (Ross
et al. 2011), which asks the expert where the learner goes, each round samples fresh probe points
(k uniform in [0, 0.6], load a uniform multiple of the trapezoid's critical load in
[0, ``PROBE_RANGE[1]``]), plays the lookup there, and runs the teacher's CMA-ES search
(``agents.teacher``: fixed actions and two-action cycles, same budgets) at the probes where the
lookup is slower than the trapezoid, or does not move a load the teacher's stall points cover
(up to 1.5 times the trapezoid's critical load). A found drive faster than the lookup there
becomes a new teacher point. The probes are drawn at random, never on the benchmark's grid, so
the grid stays a test set.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from mdr_drive_env.sweep import Executor, add_executor_arguments, executor_from

from .evaluate import open_loop_velocity, policy_velocity, trapezoid_action
from .residual import TeacherLookup
from .teacher import CMA_BUDGET, CYCLE_BUDGET, STALL_RANGE, _optimize, load_for_update, record_rollouts, save

#: Probe loads, as multiples of the trapezoid's critical load at the probe's k.
PROBE_RANGE = (0.0, 1.6)
#: k range of the probes, and the k values between which the trapezoid's critical load is interpolated.
K_RANGE = (0.0, 0.6)
CRIT_KS = np.round(np.linspace(*K_RANGE, 31), 3)


def trapezoid_critical_load(ks) -> np.ndarray:
    """The trapezoid's critical load (kg) at ``ks``, interpolated between ``CRIT_KS`` (it is smooth in k)."""
    from .benchmark import critical_loads_grid

    crit = critical_loads_grid(list(CRIT_KS), lambda pts: open_loop_velocity(pts, trapezoid_action()))
    return np.interp(ks, CRIT_KS, [crit[k] for k in CRIT_KS])


def failures(lookup: TeacherLookup, points, factors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Probe points where the lookup falls short: slower than the trapezoid (where either moves), or
    stalled at a load up to ``STALL_RANGE[1]`` times the trapezoid's critical load. Returns (mask,
    lookup velocities, trapezoid velocities) in m/s."""
    v_lookup = policy_velocity(lookup, points)
    v_trap = open_loop_velocity(points, trapezoid_action())
    slower = (v_lookup < v_trap) & ((v_trap > 0.0) | (v_lookup > 0.0))
    stalled = (v_lookup <= 0.0) & (np.asarray(factors) <= STALL_RANGE[1])
    return slower | stalled, v_lookup, v_trap


def sweep_failures(lookup: TeacherLookup, ks, trap_crit) -> list[tuple[float, float]]:
    """The benchmark's critical-load search (``agents.benchmark.critical_loads_grid``) run on the lookup
    at ``ks``: the first load it does not move at each k, where that is below ``STALL_RANGE[1]`` times
    the trapezoid's critical load ``trap_crit`` (kg). Narrow windows of loads that a lookup cell does
    not move (between cells whose drives differ) are found by a sweep along the load, rarely by
    scattered probes."""
    from .benchmark import CRITICAL_GRID, critical_loads_grid, upper_mass

    crit = critical_loads_grid(list(ks), lambda pts: policy_velocity(lookup, pts))
    stall = [(float(k), crit[k] + upper_mass(k) / (CRITICAL_GRID - 1) ** 2) for k in ks]
    return [(k, m) for (k, m), c in zip(stall, trap_crit) if m <= STALL_RANGE[1] * c]


def _merge(data: dict, points, actions, velocities) -> dict:
    merged = {"points": np.concatenate([data["points"], points]),
              "actions": np.concatenate([data["actions"], actions]),
              "velocities": np.concatenate([data["velocities"], velocities])}
    return record_rollouts(merged, periods=len(data["obs"]) // len(data["points"]))


def sweep_ks(rng: np.random.Generator, n: int, sampling: str = "uniform") -> np.ndarray:
    """k values of ``n`` critical-load sweeps in ``K_RANGE``: ``"uniform"``, or ``"chebyshev"``
    (``lo + (hi - lo) (1 - cos(pi u)) / 2``, u uniform): denser at both ends of the range, where a
    nearest-neighbour lookup has neighbours on one side only (18 % of the sweeps fall within 2 % of
    the range of an end, against 4 % for uniform k)."""
    u = rng.uniform(0.0, 1.0, n)
    if sampling == "uniform":
        return K_RANGE[0] + (K_RANGE[1] - K_RANGE[0]) * u
    if sampling == "chebyshev":
        return K_RANGE[0] + (K_RANGE[1] - K_RANGE[0]) * (1.0 - np.cos(np.pi * u)) / 2.0
    raise ValueError(f"sampling={sampling!r} must be 'uniform' or 'chebyshev'")


def refine(data: dict, probe_points: int = 384, rounds: int = 3, max_new: int = 128, seed: int = 100,
           workers: int | None = None, budget: int = CMA_BUDGET, cycle_budget: int = CYCLE_BUDGET,
           sweeps: int = 0, sweep_sampling: str = "uniform", executor=None):
    """Rounds of probing the lookup and adding CMA-ES points where it fails. Returns (new data, summary
    per round). ``max_new``: most CMA-ES searches per round at probe points (the worst failures
    first); ``sweeps``: critical-load sweeps per round at random k (``sweep_failures``), searched
    in addition, at k drawn by ``sweep_ks(..., sweep_sampling)``."""
    executor = executor or Executor(workers=workers)
    rng = np.random.default_rng(seed)
    summary = []
    for r in range(rounds):
        t0 = time.perf_counter()
        ks = rng.uniform(*K_RANGE, probe_points)
        factors = rng.uniform(*PROBE_RANGE, probe_points)
        points = [(float(k), float(f * c)) for k, f, c in zip(ks, factors, trapezoid_critical_load(ks))]
        lookup = TeacherLookup.from_teacher(data)
        bad, v_lookup, v_trap = failures(lookup, points, factors)
        idx = np.flatnonzero(bad)
        idx = idx[np.argsort(-(np.maximum(v_trap[idx], 0.0) - v_lookup[idx]))][:max_new]  # worst first
        targets = [points[i] for i in idx]
        floor = list(np.maximum(v_lookup[idx], 0.0))
        if sweeps:
            ks_sweep = sweep_ks(rng, sweeps, sweep_sampling)
            stalls = sweep_failures(lookup, ks_sweep, trapezoid_critical_load(ks_sweep))
            targets, floor = targets + stalls, floor + [0.0] * len(stalls)
        jobs = [(p, budget, cycle_budget) for p in targets]
        desc = f"refine round {r + 1}/{rounds}"
        found = executor.map(_optimize, jobs, desc)
        keep = [j for j, (_, v) in enumerate(found) if v > floor[j]]
        if keep:
            data = _merge(data, np.array([targets[j] for j in keep]), np.array([found[j][0] for j in keep]),
                          np.array([found[j][1] for j in keep]))
        summary.append({"round": r + 1, "probes": probe_points, "failures": int(bad.sum()),
                        "slower_than_trapezoid": int(np.sum(bad & (v_lookup < v_trap))),
                        "sweep_stalls": len(targets) - len(idx), "searched": len(targets),
                        "added": len(keep), "teacher_points": len(data["points"]),
                        "wall_time_s": round(time.perf_counter() - t0, 1)})
        print("refine:", json.dumps(summary[-1]), flush=True)
    return data, summary


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("teacher", help="teacher .npz (python -m agents.teacher)")
    ap.add_argument("--probe-points", type=int, default=384, help="probe points per round (-)")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of probing and adding points (-)")
    ap.add_argument("--max-new", type=int, default=128, help="most CMA-ES searches per round (-)")
    ap.add_argument("--sweeps", type=int, default=0,
                    help="critical-load sweeps of the lookup per round, at random k; the first load it does not "
                         "move is searched too (-)")
    ap.add_argument("--sweep-sampling", choices=("uniform", "chebyshev"), default="uniform",
                    help="k of the sweeps: uniform, or denser at both ends of the k range (chebyshev)")
    ap.add_argument("--seed", type=int, default=100, help="seed of the probe points (-)")
    ap.add_argument("--out", default="runs/teacher_refined.npz", help="output .npz")
    add_executor_arguments(ap, resume=False)  # each round's searches depend on the round before
    a = ap.parse_args(argv)
    try:
        executor = executor_from(a)
    except ValueError as e:
        ap.error(str(e))
    t0 = time.perf_counter()
    data, command, earlier = load_for_update(
        a.teacher, f"python -m agents.lookup_refine {' '.join(argv or sys.argv[1:])}")
    extra = {key: data.pop(key) for key in list(data) if key not in ("points", "actions", "velocities", "obs",
                                                                        "targets")}
    data, summary = refine(data, a.probe_points, a.rounds, a.max_new, a.seed, sweeps=a.sweeps,
                           sweep_sampling=a.sweep_sampling, executor=executor)
    data.update(extra, refine=np.array(json.dumps(summary)))
    save(a.out, data, command, earlier + time.perf_counter() - t0)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
