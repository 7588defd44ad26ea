"""The teacher's searches at its grid nodes: CMA-ES (``agents.baselines``) from the starts the drive
field gives them, one k slice per task so that an executor (``mdr_drive_env.sweep.Executor``) can spread
the slices over processes or a Ray cluster (``DriveField.search``, ``polish``, ``refine_k``, ``refine_load``,
``polish_stall``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .baselines import PUSH_CLAMP, best_cma_run, cma_optimize
from .evaluate import open_loop_velocity, trapezoid_action

if TYPE_CHECKING:
    from .field_config import FieldConfig


def search_point(k: float, load: float, previous: np.ndarray | None, config: FieldConfig,
                 seed: int = 0) -> tuple[np.ndarray, float]:
    """The best drive (2, 5) found at (k, load kg) and its steady velocity (m/s): CMA-ES over fixed
    actions (from the lighter point's first action, or the trapezoid) and over two-action cycles
    (from the lighter point's drive, the trapezoid and the push/clamp cycle)."""
    friction = tuple(config.friction)
    fixed = cma_optimize(k, load, config.fixed_budget, sigma0=config.sigma0, seed=seed,
                         x0=None if previous is None else previous[0], friction=friction)
    starts = ([] if previous is None else [previous]) + [np.tile(trapezoid_action(), (2, 1)), PUSH_CLAMP]
    cycle = best_cma_run(k, load, starts, config.cycle_budget, popsize=16, sigma0=config.sigma0, cycle=2,
                         seed=seed, friction=friction)
    if cycle.velocity > fixed.velocity:
        return np.asarray(cycle.action, dtype=np.float64), cycle.velocity
    return np.tile(fixed.action, (2, 1)), fixed.velocity


def search_slice(args) -> tuple[np.ndarray, np.ndarray]:
    """Drives (n_loads, 2, 5) and velocities (n_loads,) along one k, light to heavy (continuation)."""
    k, loads, config, seed = args
    drives, velocities, previous = [], [], None
    for j, load in enumerate(loads):
        drive, v = search_point(float(k), float(load), previous, config, seed=seed + j)
        drives.append(drive)
        velocities.append(v)
        previous = drive
    return np.array(drives), np.array(velocities)


def polish_slice(args) -> list[tuple[np.ndarray, float]]:
    """Per node of one k slice, the best two-action cycle (2, 5) and its velocity (m/s) found by
    CMA-ES from each of its starts (``DriveField.polish``)."""
    nodes, budget, sigma, seed, friction = args
    out = []
    for j, (k, load, starts) in enumerate(nodes):
        run = best_cma_run(k, load, list(starts), budget, popsize=16, sigma0=sigma, cycle=2, seed=seed + 31 * j,
                           friction=tuple(friction))
        out.append((np.asarray(run.action, dtype=np.float64), float(run.velocity)))
    return out


def search_new_nodes(lines: list, budget: int, sigma: float, starts: int, seed: int, friction, label: str,
                     executor=None) -> tuple[np.ndarray, np.ndarray]:
    """Drives (n_lines, n, 2, 5) and velocities (n_lines, n) m/s of new grid nodes (``DriveField.refine_k``,
    ``refine_load``), ``lines`` of [((k, load kg), trial drives (t, 2, 5)), ...] at ``friction`` (mu,
    mu1): every node plays its trials (one batched call), CMA-ES over two-action cycles runs from the
    ``starts`` fastest of them (``budget`` evaluations each, step ``sigma``; one task per line on
    ``executor``) and the node keeps the fastest drive found or played."""
    from mdr_drive_env.sweep import Executor

    tasks, trial_d, trial_v = [], [], []  # per line: its task, its nodes' fastest trial drives and velocities
    for n, line in enumerate(lines):
        played = open_loop_velocity([(*node, *friction) for node, t in line for _ in t],
                                    np.concatenate([t for _, t in line]))
        nodes, fastest_d, fastest_v, at = [], [], [], 0
        for node, t in line:
            order = np.argsort(-played[at:at + len(t)])
            fastest_d.append(t[order[0]])
            fastest_v.append(played[at + order[0]])
            nodes.append((*node, t[order[:starts]]))
            at += len(t)
        tasks.append((nodes, budget, sigma, seed + 7919 * (n + 1), friction))
        trial_d.append(fastest_d)
        trial_v.append(fastest_v)
    found = (executor or Executor()).map(polish_slice, tasks, label)
    searched_d = np.array([[d for d, _ in line] for line in found])
    searched_v = np.array([[v for _, v in line] for line in found], dtype=np.float64)
    trial_d, trial_v = np.array(trial_d), np.array(trial_v, dtype=np.float64)
    keep_search = searched_v > trial_v
    return np.where(keep_search[:, :, None, None], searched_d, trial_d), np.where(keep_search, searched_v, trial_v)


__all__ = ["polish_slice", "search_new_nodes", "search_point", "search_slice"]
