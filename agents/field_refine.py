"""The teacher's refinement stages, mixed into :class:`agents.drive_field.DriveField`: a k line
between every two of the grid's (``refine_k``), load lines between two of its load lines
(``refine_load``; with ``min_drop``, only where the velocity is steep), a stronger search at the
nodes either side of each k line's stall (``polish_stall``) and at the nodes of a band of k and load
(``polish_band``), and load lines searched in such a band only (``refine_band``). Each searches its
new or chosen nodes with CMA-ES over two-action cycles from the drives around them
(``agents.field_search``), one task per node on an executor; ``DriveField.search`` runs them in the order ``FieldConfig`` gives.
"""

from __future__ import annotations

import numpy as np

from .baselines import PUSH_CLAMP
from .cycles import align_phase
from .evaluate import open_loop_velocity
from .field_search import search_new_nodes


class GridRefinement:
    """The refinement stages of a drive field (``ks``, ``fractions``, ``trapezoid_critical``,
    ``drives``, ``velocities``, ``meta``, ``friction`` and ``point`` come from ``DriveField``)."""

    def refine_k(self, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
                 k_max: float | None = None) -> int:
        """Insert a k line between every two of the grid's (below ``k_max``, if given), at the same load
        fractions: each new node plays the interpolation of its two k neighbours' drives and the drives
        of the six nodes around it (those two and their lighter and heavier neighbours), then CMA-ES
        over two-action cycles runs from the ``starts`` fastest of them (``budget`` evaluations each,
        step ``sigma``) and the node keeps the fastest drive found or played; one task per node
        on ``executor``. The old nodes are unchanged. Returns the new nodes."""
        from .blind import trapezoid_critical

        nk, ns = self.velocities.shape
        all_mids = 0.5 * (self.ks[:-1] + self.ks[1:])
        cells = [i for i in range(nk - 1) if k_max is None or all_mids[i] < k_max]
        if not cells:
            return 0
        mids = all_mids[cells]
        mid_crit = trapezoid_critical([float(k) for k in mids])
        lines = []
        for c, i in enumerate(cells):
            line = []
            for j in range(ns):
                left = self.drives[i, j]
                ring = [align_phase(self.drives[a, b], left) for a in (i, i + 1) for b in (j - 1, j, j + 1) if 0 <= b < ns]
                line.append(((float(mids[c]), float(self.fractions[j] * mid_crit[c])),
                             np.array([0.5 * (left + align_phase(self.drives[i + 1, j], left)), *ring])))
            lines.append(line)
        new_drives, new_velocities = search_new_nodes(lines, budget, sigma, starts, seed, self.friction,
                                                       "teacher: refine k", executor)
        at = [i + 1 for i in cells]  # each new line goes before the old line above it
        self.ks = np.insert(self.ks, at, mids)
        self.trapezoid_critical = np.insert(self.trapezoid_critical, at, mid_crit)
        self.drives = np.insert(self.drives, at, new_drives, axis=0)
        self.velocities = np.insert(self.velocities, at, new_velocities, axis=0)
        self.meta["refined_k"] = {"budget": budget, "sigma": sigma, "k_max": k_max, "new_nodes": len(cells) * ns}
        return len(cells) * ns

    def refine_load(self, budget: int, sigma: float, band: tuple[float, float], executor=None, seed: int = 0,
                    starts: int = 3, k_max: float | None = None, min_drop: float = 0.0,
                    record: str = "refined_load", k_min: float | None = None, wide_trials: bool = False) -> int:
        """Insert a load line between every two of the grid's whose midpoint fraction lies in ``band``
        (low, high; load / the trapezoid's critical load), on every k line: each new node plays the
        interpolation of its lighter and heavier neighbours' drives and the drives of the six nodes
        around it (those two and their neighbours in k), then CMA-ES over two-action cycles runs from
        the ``starts`` fastest (``budget`` evaluations each, step ``sigma``) and the node keeps the
        fastest drive found or played; one task per node on ``executor``. Above ``k_max`` (if given)
        (and below ``k_min``) the new nodes are not searched: each keeps the faster of its lighter and
        heavier neighbours' drives, so the teacher's drives there stay the grid's. With ``wide_trials``,
        each searched node also plays the drives of every searched k line's nodes on its two load
        lines, not only its k neighbours'. The old nodes are unchanged; the load
        fractions are no longer evenly spaced. With ``min_drop`` > 0, only the cells across which the
        forward velocity falls by more than ``min_drop`` (m/s) on at least one k line
        (:meth:`velocity_drops`) get a line. The settings and node counts go to ``meta[record]``.
        Returns the new nodes searched."""
        nk, ns = self.velocities.shape
        all_mids = 0.5 * (self.fractions[:-1] + self.fractions[1:])
        steep = self.velocity_drops().max(axis=0) > min_drop if min_drop > 0.0 else np.ones(ns - 1, dtype=bool)
        cells = [j for j in range(ns - 1) if band[0] <= all_mids[j] <= band[1] and steep[j]]
        if not cells:
            return 0
        mids = all_mids[cells]
        tol = 1e-9
        searched = [i for i in range(nk) if (k_max is None or self.ks[i] <= k_max + tol)
                    and (k_min is None or self.ks[i] >= k_min - tol)]
        lines = []
        for i in searched:
            line = []
            for c, j in enumerate(cells):
                light = self.drives[i, j]
                around = [a for a in (i - 1, i, i + 1) if 0 <= a < nk]
                if wide_trials:
                    around += [a for a in searched if a not in around]
                ring = [align_phase(self.drives[a, b], light) for a in around for b in (j, j + 1)]
                line.append(((float(self.ks[i]), float(mids[c] * self.trapezoid_critical[i])),
                             np.array([0.5 * (light + align_phase(self.drives[i, j + 1], light)), *ring])))
            lines.append(line)
        new_drives = np.zeros((nk, len(cells), *self.drives.shape[2:]))
        new_velocities = np.zeros((nk, len(cells)))
        if searched:
            new_drives[searched], new_velocities[searched] = search_new_nodes(
                lines, budget, sigma, starts, seed, self.friction, "teacher: refine load", executor)
        copied = [i for i in range(nk) if i not in searched]
        if copied:  # the faster of the lighter and heavier neighbours' drives, played at the new node
            pairs = [(i, c, d) for i in copied for c, j in enumerate(cells)
                     for d in (self.drives[i, j], align_phase(self.drives[i, j + 1], self.drives[i, j]))]
            v = open_loop_velocity([(float(self.ks[i]), float(mids[c] * self.trapezoid_critical[i]), *self.friction)
                                    for i, c, _ in pairs], np.array([d for *_, d in pairs]))
            for n in range(0, len(pairs), 2):
                i, c, _ = pairs[n]
                pick = n if v[n] >= v[n + 1] else n + 1
                new_drives[i, c], new_velocities[i, c] = pairs[pick][2], v[pick]
        at = [j + 1 for j in cells]  # each new line goes before the old line above it
        self.fractions = np.insert(self.fractions, at, mids)
        self.drives = np.insert(self.drives, at, new_drives, axis=1)
        self.velocities = np.insert(self.velocities, at, new_velocities, axis=1)
        self.meta[record] = {"budget": budget, "sigma": sigma, "band": list(band), "k_max": k_max,
                             **({"k_min": k_min} if k_min is not None else {}),
                             **({"starts": starts, "wide_trials": True} if wide_trials else {}),
                             **({"min_drop": min_drop, "fractions": mids.tolist()} if min_drop > 0.0 else {}),
                             "new_nodes": len(cells) * nk, "searched": len(cells) * len(searched)}
        return len(cells) * len(searched)

    def refine_band(self, budget: int, sigma: float, k_band: tuple[float, float],
                    fraction_band: tuple[float, float], executor=None, seed: int = 0, starts: int = 2) -> int:
        """A load line between every two whose midpoint fraction lies in ``fraction_band``, searched
        only at the k lines in ``k_band`` (elsewhere each new node keeps the faster of its lighter and
        heavier neighbours' drives): :meth:`refine_load` with ``wide_trials``, ``starts`` starts of
        ``budget`` evaluations (record ``refined_band``). Near the trapezoid's critical load at
        k = 0.18-0.22 the band-polished grid's drives were up to 20 % short of a per-point search
        between its load lines (results/blind/dense_band_decision/TEACHER_PROBE.md). Each new node's cycle is written in the phase closest to
        its lighter neighbour's. Returns the new nodes searched."""
        old = self.fractions.copy()
        searched = self.refine_load(budget, sigma, fraction_band, executor, seed, starts, k_max=k_band[1],
                                    record="refined_band", k_min=k_band[0], wide_trials=True)
        for j in np.flatnonzero(~np.isin(self.fractions, old)):
            self.drives[:, j] = align_phase(self.drives[:, j], self.drives[:, j - 1])
        return searched

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

    def polish_stall(self, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
                     k_max: float | None = None) -> int:
        """At each of :meth:`stall_nodes` (``k_max``): :meth:`polish_nodes` (record ``polished_stall``).
        Returns the nodes changed."""
        record = {"k_max": k_max}
        changed = self.polish_nodes(self.stall_nodes(k_max), budget, sigma, executor, seed, starts, "stall", record)
        self.meta["polished_stall"] = record
        return changed

    def band_nodes(self, k_band: tuple[float, float], fraction_band: tuple[float, float]) -> list[tuple[int, int]]:
        """The nodes (i, j) whose k lies in ``k_band`` and whose load fraction lies in ``fraction_band``
        (both closed)."""
        tol = 1e-9
        return [(i, j) for i, k in enumerate(self.ks) if k_band[0] - tol <= k <= k_band[1] + tol
                for j, f in enumerate(self.fractions) if fraction_band[0] - tol <= f <= fraction_band[1] + tol]

    def polish_band(self, budget: int, sigma: float, k_band: tuple[float, float],
                    fraction_band: tuple[float, float], executor=None, seed: int = 0, starts: int = 2) -> int:
        """At each of :meth:`band_nodes`: :meth:`polish_nodes` (record ``polished_band``). Near the
        critical load at k = 0.18-0.24 the grid's drives were up to 17 % slower than the blind
        benchmark's per-point search (results/blind/teacher_band_decision). Returns the nodes changed."""
        record = {"k_band": list(k_band), "fraction_band": list(fraction_band), "starts": starts}
        changed = self.polish_nodes(self.band_nodes(k_band, fraction_band), budget, sigma, executor, seed, starts,
                                    "band", record)
        self.meta["polished_band"] = record
        return changed

    def polish_nodes(self, nodes, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
                     label: str = "", record: dict | None = None) -> int:
        """At each node (i, j) of ``nodes``: play its own drive, its lighter and its two k neighbours'
        (aligned to it) and the push/clamp cycle, run CMA-ES over two-action cycles from the
        ``starts`` fastest (``budget`` evaluations each, step ``sigma``; one task per node on
        ``executor``) and keep the fastest drive found if it beats the node's own. ``record``, if
        given, gets the search's settings and counts. Returns the nodes changed."""
        nk = len(self.ks)
        lines: dict = {}
        for i, j in nodes:
            own = self.drives[i, j]
            trials = [own, align_phase(PUSH_CLAMP, own)] + [align_phase(self.drives[a, b], own) for a, b in
                                                            ((i, j - 1), (i - 1, j), (i + 1, j)) if 0 <= a < nk and 0 <= b]
            lines.setdefault(i, []).append(((j, self.point(i, j)[:2]), np.array(trials)))
        changed = 0
        if lines:
            found_d, found_v = search_new_nodes([[(p, t) for (_, p), t in line] for line in lines.values()], budget,
                                                sigma, starts, seed, self.friction, f"teacher: polish {label}".strip(),
                                                executor)
            for (i, line), drives, velocities in zip(lines.items(), found_d, found_v):
                for ((j, _), _), drive, vel in zip(line, drives, velocities):
                    if vel > self.velocities[i, j] * (1.0 + 1e-3) + 1e-6:
                        self.drives[i, j], self.velocities[i, j] = drive, vel
                        changed += 1
        if record is not None:
            record.update({"budget": budget, "sigma": sigma, "nodes": sum(map(len, lines.values())), "changed": changed})
        return changed


__all__ = ["GridRefinement"]
