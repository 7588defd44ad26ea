"""The teacher's searches at its grid nodes: CMA-ES (``mdr_drive_agents.search``) from the starts the
drive field gives them, one k slice per task so that an executor (``mdr_drive_env.sweep.Executor``) can
spread the slices over processes or a Ray cluster (``DriveField.search``); the polish passes and the
refinements (``mdr_drive_agents.teacher.refine``) one node per task.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import open_loop_velocity, trapezoid_action
from ..search import PUSH_CLAMP, THROW_COAST, best_cma_run, search_point

class NodeSearchSettings(Protocol):
    """What a node's search reads of the teacher's settings (``teacher.config.FieldConfig`` has it):
    CMA-ES evaluations over fixed actions and per cycle start, the first step size, and (mu, mu1)."""

    fixed_budget: int
    cycle_budget: int
    sigma0: float
    friction: tuple[float, float]


def search_node(k: float, load: float, previous: np.ndarray | None, config: NodeSearchSettings,
                seed: int = 0, drive: DriveDescription = PAPER_DRIVE) -> tuple[np.ndarray, float]:
    """The best drive (2, 5) found at (k, load kg) and its steady velocity (m/s): ``search_point``
    with ``config``'s budgets and step size, over fixed actions from the lighter point's first action
    (or the trapezoid) and over two-action cycles from the lighter point's drive, the trapezoid,
    the push/clamp cycle and the throw/coast cycle (``THROW_COAST``); on ``drive``."""
    starts = ([] if previous is None else [previous]) + [np.tile(trapezoid_action(drive), (2, 1)), PUSH_CLAMP,
                                                          THROW_COAST]
    found = search_point(k, load, config.fixed_budget, config.cycle_budget, fixed_sigma=config.sigma0,
                         cycle_sigma=config.sigma0, fixed_start=None if previous is None else previous[0],
                         cycle_starts=starts, seed=seed, friction=tuple(config.friction), drive=drive)
    return found.drive, found.velocity


def search_slice(args) -> tuple[np.ndarray, np.ndarray]:
    """Drives (n_loads, 2, 5) and velocities (n_loads,) along one k, light to heavy (continuation);
    ``args``: (k, loads kg, settings (``NodeSearchSettings``), seed, DriveDescription)."""
    k, loads, config, seed, drive_description = args
    drives, velocities, previous = [], [], None
    for j, load in enumerate(loads):
        drive, v = search_node(float(k), float(load), previous, config, seed=seed + j, drive=drive_description)
        drives.append(drive)
        velocities.append(v)
        previous = drive
    return np.array(drives), np.array(velocities)


def polish_slice(args) -> list[tuple[np.ndarray, float]]:
    """Per node of one k slice, the best two-action cycle (2, 5) and its velocity (m/s) found by
    CMA-ES from each of its starts (``DriveField.polish``); ``args``: (nodes, budget, sigma, seed,
    friction (mu, mu1), DriveDescription)."""
    nodes, budget, sigma, seed, friction, drive = args
    out = []
    for j, (k, load, starts) in enumerate(nodes):
        run = best_cma_run(k, load, list(starts), budget, popsize=16, sigma0=sigma, cycle=2, seed=seed + 31 * j,
                           friction=tuple(friction), drive=drive)
        out.append((np.asarray(run.action, dtype=np.float64), float(run.velocity)))
    return out


def map_polish_by_node(line_tasks: list, desc: str, executor=None) -> list:
    """What ``executor.map(polish_slice, line_tasks, desc)`` returns (per line task, its nodes' drives
    and velocities), computed one task per node: node ``j`` of a line seeded ``seed`` runs as the
    line's task runs it (``seed + 31 j``), so the results are the same bit for bit, but the workers
    stay busy to the end instead of waiting on the last, longest lines."""
    from mdr_drive_env.sweep import Executor

    node_tasks, owner = [], []
    for n, (nodes, budget, sigma, seed, friction, drive) in enumerate(line_tasks):
        for j, node in enumerate(nodes):
            node_tasks.append(([node], budget, sigma, seed + 31 * j, friction, drive))
            owner.append(n)
    found = (executor or Executor()).map(polish_slice, node_tasks, desc)
    lines: list = [[] for _ in line_tasks]
    for n, result in zip(owner, found):
        lines[n].extend(result)
    return lines


def search_new_nodes(lines: list, budget: int, sigma: float, starts: int, seed: int, friction, label: str,
                     executor=None, drive: DriveDescription = PAPER_DRIVE) -> tuple[list, list]:
    """Per line, drives (n, 2, 5) and velocities (n,) m/s of new grid nodes (``DriveField.refine_k``,
    ``refine_load``), ``lines`` of [((k, load kg), trial drives (t, 2, 5)), ...] at ``friction`` (mu,
    mu1) on ``drive``: every node plays its trials (one batched call), CMA-ES over two-action cycles runs from the
    ``starts`` fastest of them (``budget`` evaluations each, step ``sigma``; one task per node on
    ``executor``) and the node keeps the fastest drive found or played. Lines may differ in length."""
    tasks, trial_d, trial_v = [], [], []  # per line: its task, its nodes' fastest trial drives and velocities
    for n, line in enumerate(lines):
        played = open_loop_velocity([(*node, *friction) for node, t in line for _ in t],
                                    np.concatenate([t for _, t in line]), drive=drive)
        nodes, fastest_d, fastest_v, at = [], [], [], 0
        for node, t in line:
            order = np.argsort(-played[at:at + len(t)])
            fastest_d.append(t[order[0]])
            fastest_v.append(played[at + order[0]])
            nodes.append((*node, t[order[:starts]]))
            at += len(t)
        tasks.append((nodes, budget, sigma, seed + 7919 * (n + 1), friction, drive))
        trial_d.append(fastest_d)
        trial_v.append(fastest_v)
    found = map_polish_by_node(tasks, label, executor)
    drives, velocities = [], []
    for line, fastest_d, fastest_v in zip(found, trial_d, trial_v):
        searched_v = np.array([v for _, v in line], dtype=np.float64)
        keep = searched_v > np.array(fastest_v, dtype=np.float64)
        drives.append(np.array([d if k else t for (d, _), t, k in zip(line, fastest_d, keep)]))
        velocities.append(np.where(keep, searched_v, fastest_v))
    return drives, velocities


def exchange_all_line(args) -> list[tuple[int, float]]:
    """Per node of one k line, the index of its fastest drive among ``drives`` and that drive's steady
    velocity (m/s) over the full evaluation (``refine.exchange_all``): every drive is screened over
    ``screen_periods`` periods (velocity over the last ``screen_average``), the ``finalists`` fastest
    are played again over ``EVAL_PERIODS``; ``args``: (points (k, load kg, mu, mu1), drives (d, 2, 5),
    screen_periods, screen_average, finalists, DriveDescription)."""
    points, drives, screen_periods, screen_average, finalists, drive = args
    n, d = len(points), len(drives)
    screened = open_loop_velocity([p for p in points for _ in range(d)], np.tile(drives, (n, 1, 1)),
                                  periods=screen_periods, average=screen_average, drive=drive).reshape(n, d)
    top = np.argsort(-screened, axis=1)[:, :min(finalists, d)]
    full = open_loop_velocity([p for p, row in zip(points, top) for _ in row], drives[top.ravel()],
                              drive=drive).reshape(top.shape)
    best = np.argmax(full, axis=1)
    return [(int(top[i, b]), float(full[i, b])) for i, b in enumerate(best)]


__all__ = ["exchange_all_line", "map_polish_by_node", "polish_slice", "search_new_nodes", "search_node", "search_slice"]
