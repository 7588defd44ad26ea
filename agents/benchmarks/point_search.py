"""The searches of the blind benchmark (and of the adaptation report) as sweep tasks: one point's best
drive (``best_drive``), one round of the ``strong`` reference at a point (``pooled_drive``, run over
every point by ``strengthen``), and the best two-action cycle's critical load at one k
(``cycle_scan_task``). Each task is a frozen dataclass, so an executor (``mdr_drive_env.sweep``)
can send it to a process or a Ray worker and its store can fingerprint it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mdr_drive_env.sweep import TaskStore

from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import TIME_QUANTUM, open_loop_velocity
from ..search import cycle_critical_load, pooled_cycle_search, search_point


@dataclass(frozen=True)
class PointTask:
    """One point's search (``best_drive``): at k and ``cargo_mass`` (kg), CMA-ES over fixed actions
    (``fixed_budget`` evaluations) and over two-action cycles (``cycle_budget`` per start), at
    ``friction`` (mu, mu1; None: the drive's own), the drives quantised to ``time_quantum`` (s), on
    ``drive``."""

    k: float
    cargo_mass: float
    fixed_budget: int
    cycle_budget: int
    friction: tuple[float, float] | None = None
    time_quantum: float = TIME_QUANTUM
    drive: DriveDescription = PAPER_DRIVE

    @property
    def point(self) -> tuple:
        """The point as the protocol takes it: (k, load) or (k, load, mu, mu1)."""
        return (self.k, self.cargo_mass) if self.friction is None else (self.k, self.cargo_mass, *self.friction)


@dataclass(frozen=True)
class PooledTask:
    """One point's round of the ``strong`` reference (``pooled_drive``): ``pooled_cycle_search`` at k
    and ``cargo_mass`` (kg) from ``pool`` (n, 2, 5), its ``starts`` fastest and ``random_cycles``
    random cycles drawn with ``seed``, ``budget`` evaluations per start; ``own`` is the point's drive
    so far (a ``best_drive`` record)."""

    k: float
    cargo_mass: float
    pool: np.ndarray
    starts: int
    budget: int
    random_cycles: int
    seed: int
    own: dict
    time_quantum: float = TIME_QUANTUM
    drive: DriveDescription = PAPER_DRIVE


@dataclass(frozen=True)
class ScanTask:
    """One k of the critical-load scan (``cycle_scan_task``): the best cycle's critical load by
    ``iterations`` bisection steps from ``trapezoid_critical`` (kg), ``budget`` evaluations per
    search."""

    k: float
    trapezoid_critical: float
    iterations: int
    budget: int
    time_quantum: float = TIME_QUANTUM
    drive: DriveDescription = PAPER_DRIVE


def best_drive(task: PointTask) -> dict:
    """The best drive found at one point (``search_point``: CMA-ES over fixed actions and over
    two-action cycles, the blind benchmark's settings), its velocity played again with runaways
    marked."""
    t = task
    found = search_point(t.k, t.cargo_mass, t.fixed_budget, t.cycle_budget, friction=t.friction,
                         time_quantum=t.time_quantum, drive=t.drive)
    fixed, cyc = found.fixed, found.cycle
    best = cyc if found.cycle_wins else fixed
    actions = np.asarray(best.action).reshape(1, -1, 5)
    velocity = float(open_loop_velocity([t.point], actions, mark_runaway=True,  # NaN if the load runs away
                                        time_quantum=t.time_quantum, drive=t.drive)[0])
    return {"velocity": velocity, "kind": "two-action cycle" if best is cyc else "fixed action",
            "action": np.asarray(best.action).tolist(), "fixed_velocity": fixed.velocity,
            "cycle_velocity": cyc.velocity, "evaluations": fixed.evaluations + cyc.evaluations}


def pooled_drive(task: PooledTask) -> dict:
    """One point's best drive after a round of the ``strong`` reference: the pooled search's drive
    where it beats the point's own, its velocity played again with runaways marked."""
    t, own = task, task.own
    found = pooled_cycle_search(t.k, t.cargo_mass, t.pool, t.starts, t.budget, t.random_cycles, t.seed,
                                time_quantum=t.time_quantum, drive=t.drive)
    record = {**own, "evaluations": own.get("evaluations", 0) + found.evaluations}
    if not found.velocity > (own["velocity"] if np.isfinite(own["velocity"]) else -np.inf):
        return record
    velocity = float(open_loop_velocity([(t.k, t.cargo_mass)], np.asarray(found.action)[None], mark_runaway=True,
                                        time_quantum=t.time_quantum, drive=t.drive)[0])
    if not np.isfinite(velocity):
        return record
    return {**record, "velocity": velocity, "kind": "two-action cycle", "action": np.asarray(found.action).tolist(),
            "cycle_velocity": max(found.velocity, own.get("cycle_velocity", -np.inf))}


def as_cycle(action) -> np.ndarray:
    """A found drive's action as a two-action cycle (2, 5): a fixed action played twice."""
    a = np.asarray(action, dtype=np.float64)
    return np.tile(a, (2, 1)) if a.ndim == 1 else a


def strengthen(found: list[dict], points, settings: dict, time_quantum: float, drive: DriveDescription, executor,
               tasks: Path) -> list[dict]:
    """The ``strong`` reference's rounds (``REFERENCES``) over every point's ``best_drive`` record:
    ``settings["passes"]`` rounds of ``pooled_drive``, each round's pool the best drives after the last."""
    for round_index in range(settings["passes"]):
        pool = np.array([as_cycle(f["action"]) for f in found])
        random_cycles = settings["random_cycles"] if round_index == 0 else 0
        found = executor.map(pooled_drive, [PooledTask(k, m, pool, settings["starts"], settings["budget"], random_cycles,
                                                       round_index * 100_003 + i, own, time_quantum, drive)
                                            for i, ((k, m), own) in enumerate(zip(points, found))],
                             f"strong reference: round {round_index + 1} of {settings['passes']}",
                             store=TaskStore(tasks / f"pooled_{round_index}"))
    return found


def cycle_scan_task(task: ScanTask) -> float:
    """The best cycle's critical load (kg) at one k."""
    t = task
    return cycle_critical_load(t.k, t.trapezoid_critical, t.iterations, t.budget, time_quantum=t.time_quantum,
                               drive=t.drive)[0]


__all__ = ["PointTask", "PooledTask", "ScanTask", "as_cycle", "best_drive", "cycle_scan_task", "pooled_drive",
           "strengthen"]
