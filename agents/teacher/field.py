"""The teacher: the best open-loop drive found on a grid of (k, load), as a field one can query anywhere.

The best drive at one (k, load) point is what CMA-ES finds over fixed actions and over two-action
cycles (``mdr_drive_agents.search.search_point``). Searched point by point from the same start, neighbouring points
land in different local optima (the steady velocity is a rugged function of the action), so a network
fitted to such points averages drives that each work and gets one that does not. The field is
searched so that neighbours stay neighbours:

- a grid of ``k`` values times load fractions ``s = load / trapezoid's critical load at k`` (the
  load range that matters scales by orders of magnitude over k, its fraction does not);
- along each k, loads from light to heavy, every search starting from the lighter point's drive
  (continuation) as well as from the trapezoid and the push/clamp and throw/coast cycles
  (``PUSH_CLAMP``, ``THROW_COAST``), keeping the best;
- then every point tries its grid neighbours' drives and keeps a better one (``exchange``), and
  every cycle is written in the phase (which of its two actions comes first) closest to its
  neighbour's, so interpolation does not mix a push period with a clamp period.
- then the stages ``FieldConfig`` names, each followed by an exchange: polish passes, refinements
  (a k line, load lines between the grid's) and, last, a stronger search at the nodes either side
  of each k line's stall (``polish_stall``), where the teacher's critical load is decided, then at
  the nodes of a band of k and load (``polish_band``), and load lines between them searched in that
  band (``refine_band``).

``DriveField.candidates(k, load)`` returns, for any point, the bilinear interpolation of the four
surrounding grid drives and the grid drives around the point (the cell's four corners, or with
``radius`` R the 2R x 2R nodes around the cell); ``DriveField.best(points)`` plays all of them at
the points (batched) and keeps the best: the label the student is trained on
(``mdr_drive_agents.student.distill``). Its settings, ``FieldConfig``, live in
``mdr_drive_agents.teacher.config``; the work of the polish passes and the refinement stages (new k
and load lines, the stall and band polishes) in ``mdr_drive_agents.teacher.refine``.
"""

from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_int
from mdr_drive_env.files import atomic_path

from ..cycles import align_phase
from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import open_loop_velocity, trapezoid_critical_load
from .config import PAPER_FRICTION, FieldConfig
from .load_band import LoadBand
from .node_search import search_slice


class DriveField:
    """Grid drives (n_k, n_s, 2, 5), their velocities (m/s) and the trapezoid's critical load (kg) per k,
    and point drives: drives found at single points between the nodes (``point_at`` (n, 2): k and
    load fraction of each; ``point_drives`` (n, 2, 5)), offered as candidates near where they were
    found (``add_point_drives``)."""

    def __init__(self, ks, fractions, trapezoid_critical, drives, velocities, meta: dict | None = None,
                 point_at=None, point_drives=None):
        self.ks = np.asarray(ks, dtype=np.float64)
        self.fractions = np.asarray(fractions, dtype=np.float64)
        self.trapezoid_critical = np.asarray(trapezoid_critical, dtype=np.float64)
        self.drives = np.asarray(drives, dtype=np.float64)
        self.velocities = np.asarray(velocities, dtype=np.float64)
        self.point_at = np.zeros((0, 2)) if point_at is None else np.asarray(point_at, dtype=np.float64).reshape(-1, 2)
        self.point_drives = (np.zeros((0, 2, 5)) if point_drives is None
                             else np.asarray(point_drives, dtype=np.float64).reshape(-1, 2, 5))
        if len(self.point_at) != len(self.point_drives):
            raise ValueError(f"point_at has {len(self.point_at)} rows, point_drives {len(self.point_drives)}")
        self.meta = dict(meta or {})
        self.friction = tuple(float(f) for f in self.meta.get("config", {}).get("friction", PAPER_FRICTION))
        drive = self.meta.get("drive")
        #: The drive its drives were searched on (meta ``drive``; the paper's for a field without one).
        self.drive = PAPER_DRIVE if drive is None else DriveDescription.from_record(drive)

    # ------------------------------------------------------------------ building
    @classmethod
    def search(cls, config: FieldConfig, seed: int = 0, executor=None, store=None,
               drive: DriveDescription = PAPER_DRIVE) -> "DriveField":
        """Search the grid on ``drive`` (at ``config``'s friction), one task per k slice on ``executor`` (``mdr_drive_env.sweep``; default
        the cores available), each slice kept in ``store`` as it finishes; then exchange drives
        between neighbours, consolidate, polish and run ``config``'s refinement stages in turn."""
        from mdr_drive_env.sweep import Executor

        from .refine import polish

        t0 = time.perf_counter()
        ks, fractions = config.ks, config.fractions
        searched_on = drive.with_search_solver(config.search_steps_per_period)
        crit = trapezoid_critical_load([float(k) for k in ks], searched_on)
        tasks = [(float(k), fractions * c, config, seed + 1000 * i, searched_on) for i, (k, c) in enumerate(zip(ks, crit))]
        found = (executor or Executor()).map(search_slice, tasks, "teacher: k slices", store=store)
        field = cls(ks, fractions, crit, np.array([f[0] for f in found]), np.array([f[1] for f in found]),
                    {"config": asdict(config), "seed": seed, **drive_meta(drive)})
        field.drive = searched_on  # every stage plays on the search solver; the env's keeps the velocities
        field.exchange()
        if config.consolidate_tolerance > 0.0:
            field.consolidate(config.consolidate_tolerance)
        times = {"grid": round(time.perf_counter() - t0, 1)}  # wall time of each stage (s)
        for n, stage in enumerate(config.polish):
            t1 = time.perf_counter()
            polish(field, int(stage.budget), float(stage.sigma), executor=executor, seed=seed + 100_000 * (n + 1))
            field.exchange()
            times[f"polish_{n + 1}"] = round(time.perf_counter() - t1, 1)
        field.align()  # the polish passes exchange after each pass and align once
        for name, stage in config.named_stages():
            t1 = time.perf_counter()
            stage.run(field, executor, seed + stage.SEED_OFFSET)
            times[name] = round(time.perf_counter() - t1, 1)
        field.drive = drive
        if searched_on.numerics != drive.numerics:  # the nodes' velocities as the env plays their drives
            t1 = time.perf_counter()
            field.velocities = field.node_velocities()
            times["env_replay"] = round(time.perf_counter() - t1, 1)
        field.meta["stage_wall_time_s"] = times
        field.meta["wall_time_s"] = round(time.perf_counter() - t0, 1)
        return field

    def settle(self, keep_phases_of: np.ndarray | None = None) -> None:
        """After a stage adds or changes nodes: offer each node its neighbours' drives
        (``exchange``), then write every cycle in the phase closest to its neighbours' (``align``), so
        that interpolating between nodes blends like with like; with ``keep_phases_of`` (the drives
        before a stage that added no node), in the phase of each node's drive before it instead
        (``keep_phases``)."""
        self.exchange()
        if keep_phases_of is None:
            self.align()
        else:
            self.keep_phases(keep_phases_of)

    def keep_phases(self, before: np.ndarray) -> None:
        """Write every cycle in the phase closest to the same node's drive in ``before`` (the field's
        drives (n_k, n_s, 2, 5) before a stage that changed some of them): a node the stage left
        alone keeps its phase exactly. ``align`` instead chains along each k line from the lightest
        node, so one new drive can turn the phase of every heavier node on its line, and a student
        is taught opposite first actions between that line and its neighbours
        ."""
        if before.shape != self.drives.shape:
            raise ValueError(f"keep_phases: drives before the stage have shape {before.shape}, the field's "
                             f"{self.drives.shape}")
        shape = self.drives.shape
        self.drives = align_phase(self.drives.reshape(-1, 2, 5), before.reshape(-1, 2, 5)).reshape(shape)

    def point(self, i: int, j: int) -> tuple[float, float, float, float]:
        """(k, load kg, mu, mu1) of grid node (i, j): its point at the field's friction."""
        return float(self.ks[i]), float(self.fractions[j] * self.trapezoid_critical[i]), *self.friction

    def node_velocities(self) -> np.ndarray:
        """Every node's drive played at the node (one batched call): velocities (n_k, n_s) (m/s)."""
        nk, ns = self.velocities.shape
        return open_loop_velocity([self.point(i, j) for i in range(nk) for j in range(ns)],
                                  self.drives.reshape(-1, 2, 5), drive=self.drive).reshape(nk, ns)

    def grid_neighbours(self, i: int, j: int):
        """The indices of node (i, j)'s four grid neighbours that lie on the grid."""
        nk, ns = self.velocities.shape
        for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1)):
            if 0 <= i + di < nk and 0 <= j + dj < ns:
                yield i + di, j + dj

    def _neighbour_trials(self) -> tuple[list, list, np.ndarray]:
        """Every node's four grid neighbours' drives (those that differ from its own), played at the
        node in one batched call: (nodes (i, j), drives, velocities m/s)."""
        nk, ns = self.velocities.shape
        drives, owner = [], []
        for i in range(nk):
            for j in range(ns):
                for a, b in self.grid_neighbours(i, j):
                    if not np.array_equal(self.drives[a, b], self.drives[i, j]):
                        drives.append(self.drives[a, b].copy())  # not a view: the node may change first
                        owner.append((i, j))
        if not owner:
            return [], [], np.zeros(0)
        return owner, drives, open_loop_velocity([self.point(i, j) for i, j in owner], np.array(drives),
                                                 drive=self.drive)

    def keep_if_faster(self, i: int, j: int, drive: np.ndarray, velocity: float) -> bool:
        """Node (i, j) takes ``drive`` (2, 5) and its ``velocity`` (m/s) if that beats the node's own by
        more than 0.1 % and 1e-6 m/s (a search's rounding is no gain); returns whether it did."""
        if velocity > self.velocities[i, j] * (1.0 + 1e-3) + 1e-6:
            self.drives[i, j], self.velocities[i, j] = drive, velocity
            return True
        return False

    def exchange(self) -> int:
        """Every node plays its four grid neighbours' drives and keeps the best; returns how many changed."""
        changed = 0
        for (i, j), drive, vel in zip(*self._neighbour_trials()):
            changed += self.keep_if_faster(i, j, drive, vel)
        self.meta["exchanged"] = changed
        return changed

    def consolidate(self, tolerance: float, passes: int = 4) -> int:
        """Spread drives between grid neighbours so that the teacher's drive changes at fewer places:
        in each pass, every node plays its four neighbours' drives and takes the one most of them
        share (ties: the fastest) if it reaches at least ``1 - tolerance`` of the node's velocity
        before consolidation (any drive at least as fast, where nothing moved). Returns the nodes
        changed. A student fitted to a teacher whose drive jumps between optima plays a mixture of
        them near each jump, and a mixture of two optima is not one."""
        if not 0.0 <= tolerance < 1.0:
            raise ValueError(f"tolerance={tolerance!r} is outside the allowed range [0, 1)")
        nk, ns = self.velocities.shape
        original = self.velocities.copy()
        changed = 0
        for _ in range(passes):
            owner, drives, v = self._neighbour_trials()
            if not owner:
                break
            options: dict = {}
            for node, drive, vel in zip(owner, drives, v):
                v0 = original[node]
                if vel >= (v0 * (1.0 - tolerance) if v0 > 0.0 else v0):
                    options.setdefault(node, []).append((drive, vel))
            changes = 0
            for (i, j), found in options.items():
                votes = [sum(np.array_equal(d, e) for e, _ in found) for d, _ in found]
                drive, vel = max(zip(found, votes), key=lambda x: (x[1], x[0][1]))[0]
                self.drives[i, j], self.velocities[i, j] = drive, vel
                changes += 1
            changed += changes
            if not changes:
                break
        self.meta["consolidated"] = {"tolerance": tolerance, "changed": changed,
                                     "distinct_drives": int(len(np.unique(self.drives.reshape(nk * ns, -1), axis=0)))}
        return changed

    def align(self) -> None:
        """Write every cycle in the phase closest to its lighter neighbour's (along each k), and each
        k's unloaded cycle in the phase closest to the previous k's."""
        nk, ns = self.velocities.shape
        for i in range(nk):
            if i:
                self.drives[i, 0] = align_phase(self.drives[i, 0], self.drives[i - 1, 0])
            for j in range(1, ns):
                self.drives[i, j] = align_phase(self.drives[i, j], self.drives[i, j - 1])

    # ------------------------------------------------------------------ queries
    def velocity_drops(self) -> np.ndarray:
        """Per k line and load cell (n_k, n_s - 1), how much the forward velocity falls from the
        cell's lighter node to its heavier, ``max(v[i, j], 0) - max(v[i, j + 1], 0)`` (m/s)."""
        v = np.maximum(self.velocities, 0.0)
        return v[:, :-1] - v[:, 1:]

    def stall_nodes(self, k_max: float | None = None) -> list[tuple[int, int]]:
        """Two nodes (i, j) per k line (up to ``k_max``, if given), on either side of its stall: its
        heaviest node that moves and the next heavier (the two heaviest if the heaviest moves, the two
        lightest if none does)."""
        nodes = []
        for i, line in enumerate(self.velocities):
            if k_max is not None and self.ks[i] > k_max:
                continue
            moving = np.flatnonzero(line > 0.0)
            first = min(int(moving[-1]) if len(moving) else 0, len(line) - 2)
            nodes += [(i, first), (i, first + 1)]
        return nodes

    def band_nodes(self, k_band: tuple[float, float], fraction_band: tuple[float, float]) -> list[tuple[int, int]]:
        """The nodes (i, j) whose k lies in ``k_band`` and whose load fraction lies in ``fraction_band``
        (both closed)."""
        tol = 1e-9
        return [(i, j) for i, k in enumerate(self.ks) if k_band[0] - tol <= k <= k_band[1] + tol
                for j, f in enumerate(self.fractions) if fraction_band[0] - tol <= f <= fraction_band[1] + tol]

    def _k_cell(self, k: float) -> tuple[int, float]:
        """The k line below ``k`` (clipped to the grid) and the weight of the one above: (i, wk)."""
        k = float(np.clip(k, self.ks[0], self.ks[-1]))
        i = int(first_line_of_cell(self.ks, k))
        return i, (k - self.ks[i]) / (self.ks[i + 1] - self.ks[i])

    def load_fraction(self, k: float, load: float) -> float:
        """``load`` (kg) over the trapezoid's critical load at ``k`` (interpolated between k lines) (-)."""
        i, wk = self._k_cell(k)
        crit = (1.0 - wk) * self.trapezoid_critical[i] + wk * self.trapezoid_critical[i + 1]
        return float(load / crit) if crit > 0.0 else 0.0

    def _cell(self, k: float, load: float):
        """Indices and weights of the grid cell around (k, load): (i, j, wk, ws)."""
        i, wk = self._k_cell(k)
        s = float(np.clip(self.load_fraction(k, load), self.fractions[0], self.fractions[-1]))
        j = int(first_line_of_cell(self.fractions, s))
        ws = (s - self.fractions[j]) / (self.fractions[j + 1] - self.fractions[j])
        return i, j, wk, ws

    def add_point_drives(self, points, drives) -> None:
        """Keep ``drives`` (n, 2, 5), found at ``points`` (k, load kg), as point drives: each is offered
        by :meth:`candidates` at every point whose cell is within ``radius - 1`` cells of the cell it
        was found in. A grid node must serve its whole cell, and near the stall a drive that is best at
        one point between nodes can lose at every node (the audit's mending then keeps the nodes'
        own), so such a drive is kept where it was found."""
        drives = np.asarray(drives, dtype=np.float64).reshape(-1, 2, 5)
        at = np.array([(float(k), self.load_fraction(k, m)) for k, m in points]).reshape(-1, 2)
        if len(at) != len(drives):
            raise ValueError(f"add_point_drives: {len(at)} points but {len(drives)} drives")
        self.point_at = np.concatenate([self.point_at, at])
        self.point_drives = np.concatenate([self.point_drives, drives])

    def _point_cells(self) -> np.ndarray:
        """The grid cell (i, j) each point drive lies in (n, 2); the grid may have gained lines since."""
        return np.stack([first_line_of_cell(self.ks, np.clip(self.point_at[:, 0], self.ks[0], self.ks[-1])),
                         first_line_of_cell(self.fractions, np.clip(self.point_at[:, 1], self.fractions[0],
                                                                    self.fractions[-1]))], axis=1)

    def candidates(self, k: float, load: float, radius: int = 1, load_radius: int | None = None) -> np.ndarray:
        """(c, 2, 5): the bilinear interpolation of the four surrounding grid drives (each aligned to
        the cell's first corner), then the grid drives of the (2 radius) x (2 radius) nodes around the
        cell (``radius`` 1: its four corners; with ``load_radius``, (2 radius) k lines by
        (2 load_radius) load lines), each aligned to that corner, nodes past the grid's edge left out;
        then the point drives found in the cells within ``radius - 1`` (``load_radius - 1``) cells of
        this one (``add_point_drives``), aligned alike."""
        load_radius = radius if load_radius is None else load_radius
        i, j, wk, ws = self._cell(k, load)
        first = self.drives[i, j]
        corners = [first] + [align_phase(c, first) for c in
                             (self.drives[i + 1, j], self.drives[i, j + 1], self.drives[i + 1, j + 1])]
        w = [(1 - wk) * (1 - ws), wk * (1 - ws), (1 - wk) * ws, wk * ws]
        mixed = sum(wi * c for wi, c in zip(w, corners))
        nk, ns = self.velocities.shape
        ring = [align_phase(self.drives[a, b], first)
                for a in range(max(i - radius + 1, 0), min(i + radius + 1, nk))
                for b in range(max(j - load_radius + 1, 0), min(j + load_radius + 1, ns))
                if not (i <= a <= i + 1 and j <= b <= j + 1)]
        if len(self.point_drives):
            cells = self._point_cells()
            near = (np.abs(cells[:, 0] - i) <= radius - 1) & (np.abs(cells[:, 1] - j) <= load_radius - 1)
            ring += [align_phase(d, first) for d in self.point_drives[near]]
        return np.array([mixed, *corners, *ring])

    def with_friction(self, points) -> list[tuple[float, float, float, float]]:
        """``points`` as (k, load kg, mu, mu1): (k, load) points at the field's friction."""
        return with_friction(points, self.friction)

    def field_load(self, point) -> float:
        """The load (kg) at the field's friction that matches ``point`` (k, load kg, mu, mu1): the same
        load over mu F_ref (the load scales with mu at a given ratio of mu1 to mu)."""
        return float(point[1]) * self.friction[0] / float(point[2])

    def best(self, points, prefer_interpolation: float = 0.02, radius: int = 1,
             interpolation: bool = True, load_radius: int | None = None,
             load_band: LoadBand | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The teacher's drive (n, 2, 5) and its velocity (n,) at each (k, load kg) point, or (k, load
        kg, mu, mu1) point at other friction (the grid is read at the same load over mu F_ref,
        ``field_load``): the best of :meth:`candidates` (with ``radius``, ``load_radius``) played at the point, the
        interpolation unless another candidate is better by more than ``prefer_interpolation``
        (relative), so neighbouring labels stay smooth. Without ``interpolation``: the best of the
        grid's own drives around the point (the candidates but the first), so every drive is one of
        the grid's (what a student that picks among them can be taught). With ``load_band``, the
        candidate that holds best over a band of load around each point (``LoadBand``)."""
        check_int("radius", radius, 1)
        points = self.with_friction(points)
        cands = [self.candidates(p[0], self.field_load(p), radius, load_radius)[0 if interpolation else 1:]
                 for p in points]  # c may differ at the edge
        return pick_best(points, cands, prefer_interpolation if interpolation else 0.0, self.drive, load_band)

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> None:
        import json

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, ks=self.ks, fractions=self.fractions,
                                    trapezoid_critical=self.trapezoid_critical, drives=self.drives,
                                    velocities=self.velocities, point_at=self.point_at,
                                    point_drives=self.point_drives, meta=np.array(json.dumps(self.meta)))

    @classmethod
    def load(cls, path: str | Path) -> "DriveField":
        import json

        with np.load(path) as f:  # fields saved before point drives existed have none
            points = {name: f[name] for name in ("point_at", "point_drives") if name in f.files}
            return cls(f["ks"], f["fractions"], f["trapezoid_critical"], f["drives"], f["velocities"],
                       json.loads(str(f["meta"])), **points)


def first_line_of_cell(lines: np.ndarray, x):
    """The index of the grid line at or below ``x`` (a value or an array within ``lines``' range),
    at most the last but one: the first line of the cell ``x`` lies in."""
    return np.minimum(np.searchsorted(lines, x, side="right") - 1, len(lines) - 2)


def with_friction(points, friction) -> list[tuple[float, float, float, float]]:
    """``points`` as (k, load kg, mu, mu1) tuples of floats: (k, load) points at ``friction`` (mu, mu1)."""
    return [tuple(map(float, p)) if len(p) == 4 else (float(p[0]), float(p[1]), *map(float, friction)) for p in points]


def drive_meta(drive: DriveDescription) -> dict:
    """A field's meta entry for the drive it is searched on (none for the paper's, so its files are as before)."""
    return {} if drive == PAPER_DRIVE else {"drive": drive.to_record()}


def pick_best(points, cands: list, prefer_interpolation: float,
              drive: DriveDescription = PAPER_DRIVE,
              load_band: LoadBand | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the best of its candidate drives ``cands[i]`` (c_i, 2, 5) played there (one batched
    call), the first (an interpolation) unless another is better by more than
    ``prefer_interpolation`` (relative): drives (n, 2, 5) and velocities (n,) m/s at the points.
    With ``load_band`` (a ``LoadBand``), the candidate whose worst ratio to the best candidate over
    the band's loads is highest (``LoadBand.scores``) instead."""
    if load_band is not None:
        return load_band.pick(points, cands, prefer_interpolation, drive)
    v = open_loop_velocity([p for p, c in zip(points, cands) for _ in c], np.concatenate(cands), drive=drive)
    drives, velocities, start = [], [], 0
    for c in cands:
        vc = v[start:start + len(c)]
        pick = int(np.argmax(vc))
        if vc[pick] <= vc[0] + prefer_interpolation * abs(vc[0]):
            pick = 0
        drives.append(c[pick])
        velocities.append(vc[pick])
        start += len(c)
    return np.array(drives), np.array(velocities)


__all__ = ["PAPER_FRICTION", "DriveField", "FieldConfig", "LoadBand", "pick_best", "with_friction"]
