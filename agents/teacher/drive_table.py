"""A table of whole drives for a drive that does not know its k, load and friction: what a sensor
policy picks from (``mdr_drive_agents.train.sensor``).

Each drive of the table is a fixed action or a two-action cycle (a push, then a clamp, played in
turn), as the blind benchmark's searches find them. ``build`` makes the table in three sweeps (local
processes or Ray, each kept as it finishes so that ``resume`` continues it):

1. **Searches** (``search_drives``) at ``points`` draws of ``MDRDriveSensor-v0``'s hidden parameters
   (k, the load, mu and mu1, as the env draws them): CMA-ES over fixed actions and over two-action
   cycles from the trapezoid, the push/clamp and the throw/coast starts
   (``mdr_drive_agents.search``), and from the cycle the full-observation policy (``polish_from``,
   told the hidden values) settles into there. The ``keep_per_point`` fastest of them at each point
   are the candidates.
2. **Values** (``drive_values``): every candidate's steady velocity (the evaluation protocol: 30
   periods from rest, the mean of the last 10) at those points and at ``selection_points`` more draws.
3. **Selection** (``select``): ``size`` drives, the trapezoid first, then each time the drive that
   most raises the mean of ``coverage_utility`` over the points, the utility of the best picked
   drive's fraction of the best candidate there: the table covers the hidden range with few drives.

A sensor policy plays the drives of the table as rows of an action table (``rows``: each drive's two
actions, played in turn): ``MDRDriveSensor-v0(action_codebook=table.rows)``.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_int
from mdr_drive_env.files import atomic_path
from mdr_drive_env.sweep import Executor, TaskStore

from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import MOVING_THRESHOLD, TIME_QUANTUM, draw_hidden, hidden_point, open_loop_velocity, policy_rollout, trapezoid_action
from ..search import CMA_BUDGET, CYCLE_SEARCH, PUSH_CLAMP, THROW_COAST, best_cycle, cma_optimize

#: Starts of the cycle searches besides the full-observation policy's own cycle (None: the trapezoid).
CYCLE_STARTS = (None, PUSH_CLAMP, THROW_COAST)
#: Points per values task (each task plays every candidate at each of its points in one batch).
VALUE_CHUNK = 16


@dataclass(frozen=True)
class DriveTableConfig:
    """How the table is made (module docstring).

    Attributes:
        points: hidden-parameter draws searched (-).
        seed: seed of those draws (-); the selection's further draws use ``seed + 1``.
        fixed_budget: CMA-ES evaluations of the fixed-action search at each point (-).
        cycle_budget: CMA-ES evaluations of each cycle search at each point (-), one per start of
            ``CYCLE_STARTS``.
        polish_budget: CMA-ES evaluations of the cycle search from the full-observation policy's drive (-).
        polish_from: folder of the full-observation policy (told k, the load and mu1 / mu) whose
            drive at each point starts a search; None: no such search.
        keep_per_point: the fastest drives of each point kept as candidates (-).
        selection_points: further draws the candidates are valued at for the selection (-).
        size: drives in the table (-).
    """

    points: int = 800
    seed: int = 5150
    fixed_budget: int = CMA_BUDGET
    cycle_budget: int = CYCLE_SEARCH["budget"]
    polish_budget: int = 1000
    polish_from: str | None = None
    keep_per_point: int = 2
    selection_points: int = 400
    size: int = 256

    def __post_init__(self) -> None:
        for name in ("points", "keep_per_point", "size"):
            check_int(name, getattr(self, name), 1)
        for name in ("seed", "selection_points"):
            check_int(name, getattr(self, name), 0)
        check_int("polish_budget", self.polish_budget, 2)
        for name in ("fixed_budget", "cycle_budget"):  # 0: no such search
            check_int(name, getattr(self, name), 0)
            if getattr(self, name) == 1:
                raise ValueError(f"{name}=1 is outside the allowed range: 0 (no such search) or >= 2")


@dataclass(frozen=True)
class SearchTask:
    """The searches at one hidden point (k, cargo mass kg, mu, mu1) of ``drive``: ``search_drives``.
    ``start``: the cycle its polishing search starts from there (2, 5), or None."""

    point: tuple[float, float, float, float]
    fixed_budget: int
    cycle_budget: int
    polish_budget: int
    start: np.ndarray | None = None
    drive: DriveDescription = PAPER_DRIVE


def search_drives(task: SearchTask) -> dict:
    """The drives found at one point and their steady velocities there (m/s): ``{"drives": (n, 2, 5),
    "velocities": (n,)}``, the fixed action (both rows equal), one cycle per start of
    ``CYCLE_STARTS`` and, with a ``start``, the cycle searched from it; a budget of 0 skips its
    searches."""
    k, mass, mu, mu1 = task.point
    drive, found = task.drive, []
    if task.fixed_budget:
        fixed = cma_optimize(k, mass, task.fixed_budget, friction=(mu, mu1), drive=drive)
        found.append((np.tile(fixed.action, (2, 1)), fixed.velocity))
    for i, start in enumerate(CYCLE_STARTS if task.cycle_budget else ()):
        c = best_cycle(k, mass, (start,), task.cycle_budget, seed=i, friction=(mu, mu1), drive=drive)
        found.append((np.asarray(c.action), c.velocity))
    if task.start is not None:
        c = best_cycle(k, mass, (np.asarray(task.start),), task.polish_budget, seed=len(CYCLE_STARTS), friction=(mu, mu1),
                       drive=drive)
        found.append((np.asarray(c.action), c.velocity))
    return {"drives": np.array([d for d, _ in found]), "velocities": np.array([v for _, v in found])}


@dataclass(frozen=True)
class ValuesTask:
    """Every drive of ``drives`` (n, 2, 5) played at each of ``points`` (k, cargo mass kg, mu, mu1) of
    ``drive``, its rises and z phase in steps of ``time_quantum`` (s)."""

    points: tuple
    drives: np.ndarray
    time_quantum: float = TIME_QUANTUM
    drive: DriveDescription = PAPER_DRIVE


def values_task(task: ValuesTask) -> np.ndarray:
    """Steady velocities (len(points), n) m/s of ``task`` (a runaway: its mean, a large negative number)."""
    drives = np.asarray(task.drives)
    points = [tuple(p) for p in task.points for _ in range(len(drives))]
    return open_loop_velocity(points, np.tile(drives, (len(task.points), 1, 1)),
                              time_quantum=task.time_quantum, drive=task.drive).reshape(len(task.points), -1)


def drive_values(points, drives: np.ndarray, executor: Executor, store: TaskStore | None = None,
                 desc: str = "drive table: values", time_quantum: float = TIME_QUANTUM,
                 drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """Steady velocity (m/s) of every drive (n, 2, 5) at every hidden point (k, cargo mass kg, mu, mu1)
    of ``drive``, its rises and z phase in steps of ``time_quantum`` (s): (len(points), n), in tasks of
    ``VALUE_CHUNK`` points."""
    points = [tuple(float(x) for x in p) for p in points]
    drives = np.asarray(drives, dtype=np.float64)
    tasks = [ValuesTask(tuple(points[i:i + VALUE_CHUNK]), drives, time_quantum, drive)
             for i in range(0, len(points), VALUE_CHUNK)]
    return np.concatenate([np.asarray(v) for v in executor.map(values_task, tasks, desc, store=store)])


def coverage_utility(fraction: np.ndarray) -> np.ndarray:
    """How much a point's fraction of the best candidate is worth to the selection: the fraction, at
    most 1, less twice its shortfall below 0.9 (a point covered badly costs more than a point covered
    a little less well)."""
    return np.minimum(fraction, 1.0) - 2.0 * np.maximum(0.9 - fraction, 0.0)


def select(values: np.ndarray, size: int, first: int = 0) -> tuple[list[int], list[float]]:
    """``size`` columns of ``values`` (points, drives) m/s picked greedily, ``first`` first, each the
    one that most raises the mean ``coverage_utility`` of the best picked drive's velocity over the
    best candidate's (at least ``MOVING_THRESHOLD``) at each point; and that mean after each pick."""
    best = np.maximum(values.max(axis=1), MOVING_THRESHOLD)
    fraction = values / best[:, None]
    chosen, covered = [first], fraction[:, first].copy()
    history = [float(coverage_utility(covered).mean())]
    for _ in range(min(size, values.shape[1]) - 1):
        gain = coverage_utility(np.maximum(covered[:, None], fraction)).mean(axis=0)
        gain[chosen] = -np.inf
        j = int(np.argmax(gain))
        chosen.append(j)
        covered = np.maximum(covered, fraction[:, j])
        history.append(float(gain[j]))
    return chosen, history


@dataclass(frozen=True)
class DriveTable:
    """Whole drives for a sensor policy (module docstring).

    Attributes:
        drives: (n, 2, 5) Box actions, each a two-action cycle (a fixed action: both rows equal); drive 0
            is the trapezoid.
        record: how it was made (the config, the searches' and the selection's figures).
    """

    drives: np.ndarray
    record: dict

    @property
    def rows(self) -> np.ndarray:
        """The action table a sensor policy picks from (2 n, 5), ``MDRDriveSensor-v0(action_codebook=rows)``:
        each drive's two actions in turn (rows 2 i and 2 i + 1 are drive i's; a fixed action twice)."""
        return np.ascontiguousarray(np.asarray(self.drives, dtype=np.float64).reshape(-1, 5))

    @property
    def partners(self) -> np.ndarray:
        """(2 n, 5): the action each row's drive plays after it (the other row of its pair)."""
        return np.ascontiguousarray(np.asarray(self.drives, dtype=np.float64)[:, ::-1].reshape(-1, 5))

    def save(self, path: str | Path) -> None:
        """The drives and the record as numbers and JSON text (``.npz``, written atomically)."""
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, drives=np.asarray(self.drives, dtype=np.float64), record=np.array(json.dumps(self.record)))

    @classmethod
    def load(cls, path: str | Path) -> "DriveTable":
        """The table :meth:`save` wrote (read without unpickling anything); ``ValueError`` for a file
        that is not one."""
        try:
            with np.load(path, allow_pickle=False) as f:
                drives, record = np.asarray(f["drives"], dtype=np.float64), json.loads(str(f["record"]))
        except (OSError, KeyError, ValueError) as e:
            raise ValueError(f"{path}: not a drive table ({type(e).__name__}: {e})") from None
        if drives.ndim != 3 or drives.shape[1:] != (2, 5) or not np.all(np.isfinite(drives)):
            raise ValueError(f"{path}: not a drive table (drives of shape {drives.shape})")
        return cls(drives, record)


def policy_cycles(folder: str | Path, points) -> np.ndarray:
    """The two-action cycle (n, 2, 5) the full-observation policy at ``folder`` plays over the last two
    of the protocol's 30 periods at each hidden point (k, cargo mass kg, mu, mu1), told the values."""
    from ..policy import load_policy

    _, actions, _ = policy_rollout(load_policy(folder), [tuple(p) for p in points])
    return np.stack([actions[-2], actions[-1]], axis=1).astype(np.float64)


def build(config: DriveTableConfig, executor: Executor, tasks: Path, library: DriveTable | None = None,
          drive: DriveDescription = PAPER_DRIVE) -> DriveTable:
    """The table of ``config`` for a sensor policy of ``drive`` (module docstring: its hidden parameters
    drawn as ``DriveDescription.sensor_env_kwargs`` says); each sweep's finished tasks are kept under
    ``tasks`` (``resume``: the same folder again). With a ``library`` (drives found before, such as a
    teacher field's, ``student.field_library``), each point's polishing search starts from the library's
    fastest drive there instead of ``polish_from``'s, and every drive of the library is a candidate too."""
    points = [hidden_point(d) for d in draw_hidden(config.points, config.seed, drive=drive)]
    sample = points + [hidden_point(d) for d in draw_hidden(config.selection_points, config.seed + 1, drive=drive)]
    candidates = [np.tile(trapezoid_action(drive), (2, 1))]
    known = {}  # a library drive's values over the sample, played once
    if library is not None:
        if config.polish_from is not None:
            raise ValueError(f"polish_from={config.polish_from!r}: a table built from a library starts its polishing "
                             "searches from the library's drives; set polish_from to null")
        drives = np.asarray(library.drives, dtype=np.float64)
        values = drive_values(sample, drives, executor, TaskStore(tasks / "library"), "drive table: library", drive=drive)
        starts = list(drives[np.argmax(values[:len(points)], axis=1)])
        candidates += list(drives)
        known = {d.tobytes(): v for d, v in zip(drives, values.T)}
    elif config.polish_from is not None:
        if not drive.is_paper:
            raise ValueError(f"polish_from={config.polish_from!r} plays on the paper's drive, not on {drive.name}")
        starts = list(policy_cycles(config.polish_from, points))
    else:
        starts = [None] * len(points)
    found = executor.map(search_drives, [SearchTask(p, config.fixed_budget, config.cycle_budget, config.polish_budget, s,
                                                    drive)
                                         for p, s in zip(points, starts)],
                         "drive table: searches", store=TaskStore(tasks / "searches"))
    for f in found:
        order = np.argsort(-np.asarray(f["velocities"]), kind="stable")[:config.keep_per_point]
        candidates += [np.asarray(f["drives"], dtype=np.float64)[i] for i in order]
    candidates = np.array(candidates, dtype=np.float64)
    _, first = np.unique(candidates.reshape(len(candidates), -1), axis=0, return_index=True)
    candidates = candidates[np.sort(first)]  # the trapezoid stays first
    new = [i for i, c in enumerate(candidates) if c.tobytes() not in known]
    values = np.empty((len(sample), len(candidates)))
    if new:
        values[:, new] = drive_values(sample, candidates[new], executor, TaskStore(tasks / "values"), drive=drive)
    for i, c in enumerate(candidates):
        if c.tobytes() in known:
            values[:, i] = known[c.tobytes()]
    chosen, history = select(values, config.size)
    best = values.max(axis=1)
    moving = best >= MOVING_THRESHOLD
    fraction = values[:, chosen].max(axis=1)[moving] / best[moving]
    record = {"config": asdict(config), "drive": drive.to_record(), "library": None if library is None else len(library.drives),
              "candidates": len(candidates), "sample_points": len(sample),
              "selection_utility": history,
              "coverage": {"points_moving": int(moving.sum()), "mean_fraction_of_best_candidate": float(fraction.mean()),
                           "min_fraction_of_best_candidate": float(fraction.min())}}
    return DriveTable(candidates[chosen], record)


__all__ = ["CYCLE_STARTS", "DriveTable", "DriveTableConfig", "SearchTask", "ValuesTask", "build", "coverage_utility",
           "drive_values", "policy_cycles", "search_drives", "select", "values_task"]
