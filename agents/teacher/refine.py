"""The work of the teacher's stages on a drive field (``mdr_drive_agents.teacher.field.DriveField``):
polish passes (``polish``), a k line between every two of the grid's (``refine_k``), load lines
between two of its load lines (``refine_load``; with ``min_drop``, only where the velocity is
steep), a stronger search at the nodes either side of each k line's stall (``polish_stall``) and at
the nodes of a band of k and load (``polish_band``), and load lines searched in such a band only
(``refine_band``), and an audit against a stronger search at random points that mends the cells
where the teacher falls short (``audit``), and an exchange in which every node plays every drive
of the field (``exchange_all``). Each but the last searches its new or chosen nodes with CMA-ES over
two-action cycles from the drives around them (``mdr_drive_agents.teacher.node_search``), one task
per node on an executor; ``DriveField.search`` runs them in the order ``FieldConfig`` gives (its stage dataclasses).
"""

from __future__ import annotations

import numpy as np

from ..cycles import align_phase
from ..protocol import open_loop_velocity, trapezoid_action, trapezoid_critical_load
from ..search import PUSH_CLAMP
from .node_search import exchange_all_line, map_polish_by_node, search_new_nodes


def polish(field, budget: int, sigma: float, executor=None, seed: int = 0) -> int:
    """Every node runs CMA-ES over two-action cycles (``budget`` evaluations, step ``sigma``) from
    its own drive and from each of its four grid neighbours' that differs from it, and keeps the
    fastest drive found if it beats its own; one task per node on ``executor``. Returns the
    nodes changed. The grid's searches start from the lighter node's drive and the two hand-made
    cycles, and the velocity is so rugged in the action that they miss drives that a search from
    a neighbour's drive, in k as well as in the load, finds."""
    nk, ns = field.velocities.shape
    tasks = []
    for i in range(nk):
        nodes = []
        for j in range(ns):
            starts = [field.drives[i, j]]
            for a, b in field.grid_neighbours(i, j):
                if not any(np.array_equal(field.drives[a, b], d) for d in starts):
                    starts.append(field.drives[a, b])
            nodes.append((*field.point(i, j)[:2], np.array(starts)))
        tasks.append((nodes, budget, sigma, seed + 7919 * (i + 1), field.friction, field.drive))
    found = map_polish_by_node(tasks, "teacher: polish", executor)
    changed = 0
    for i, slice_ in enumerate(found):
        for j, (drive, vel) in enumerate(slice_):
            changed += field.keep_if_faster(i, j, drive, vel)
    field.meta.setdefault("polished", []).append({"budget": budget, "sigma": sigma, "changed": changed})
    return changed


def refine_k(field, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
             k_max: float | None = None) -> int:
    """Insert a k line between every two of the grid's (below ``k_max``, if given), at the same load
    fractions: each new node plays the interpolation of its two k neighbours' drives and the drives
    of the six nodes around it (those two and their lighter and heavier neighbours), then CMA-ES
    over two-action cycles runs from the ``starts`` fastest of them (``budget`` evaluations each,
    step ``sigma``) and the node keeps the fastest drive found or played; one task per node
    on ``executor``. The old nodes are unchanged. Returns the new nodes."""
    nk, ns = field.velocities.shape
    all_mids = 0.5 * (field.ks[:-1] + field.ks[1:])
    cells = [i for i in range(nk - 1) if k_max is None or all_mids[i] < k_max]
    if not cells:
        return 0
    mids = all_mids[cells]
    mid_crit = trapezoid_critical_load([float(k) for k in mids], field.drive)
    lines = []
    for c, i in enumerate(cells):
        line = []
        for j in range(ns):
            left = field.drives[i, j]
            ring = [align_phase(field.drives[a, b], left) for a in (i, i + 1) for b in (j - 1, j, j + 1) if 0 <= b < ns]
            line.append(((float(mids[c]), float(field.fractions[j] * mid_crit[c])),
                         np.array([0.5 * (left + align_phase(field.drives[i + 1, j], left)), *ring])))
        lines.append(line)
    new_drives, new_velocities = map(np.array, search_new_nodes(lines, budget, sigma, starts, seed, field.friction,
                                                                "teacher: refine k", executor, field.drive))
    at = [i + 1 for i in cells]  # each new line goes before the old line above it
    field.ks = np.insert(field.ks, at, mids)
    field.trapezoid_critical = np.insert(field.trapezoid_critical, at, mid_crit)
    field.drives = np.insert(field.drives, at, new_drives, axis=0)
    field.velocities = np.insert(field.velocities, at, new_velocities, axis=0)
    field.meta["refined_k"] = {"budget": budget, "sigma": sigma, "k_max": k_max, "new_nodes": len(cells) * ns}
    return len(cells) * ns


def refine_load(field, budget: int, sigma: float, band: tuple[float, float], executor=None, seed: int = 0,
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
    (``field.velocity_drops``) get a line. The settings and node counts go to ``meta[record]``.
    Returns the new nodes searched."""
    nk, ns = field.velocities.shape
    all_mids = 0.5 * (field.fractions[:-1] + field.fractions[1:])
    steep = field.velocity_drops().max(axis=0) > min_drop if min_drop > 0.0 else np.ones(ns - 1, dtype=bool)
    cells = [j for j in range(ns - 1) if band[0] <= all_mids[j] <= band[1] and steep[j]]
    if not cells:
        return 0
    mids = all_mids[cells]
    tol = 1e-9
    searched = [i for i in range(nk) if (k_max is None or field.ks[i] <= k_max + tol)
                and (k_min is None or field.ks[i] >= k_min - tol)]
    lines = []
    for i in searched:
        line = []
        for c, j in enumerate(cells):
            light = field.drives[i, j]
            around = [a for a in (i - 1, i, i + 1) if 0 <= a < nk]
            if wide_trials:
                around += [a for a in searched if a not in around]
            ring = [align_phase(field.drives[a, b], light) for a in around for b in (j, j + 1)]
            line.append(((float(field.ks[i]), float(mids[c] * field.trapezoid_critical[i])),
                         np.array([0.5 * (light + align_phase(field.drives[i, j + 1], light)), *ring])))
        lines.append(line)
    new_drives = np.zeros((nk, len(cells), *field.drives.shape[2:]))
    new_velocities = np.zeros((nk, len(cells)))
    if searched:
        new_drives[searched], new_velocities[searched] = map(np.array, search_new_nodes(
            lines, budget, sigma, starts, seed, field.friction, "teacher: refine load", executor, field.drive))
    copied = [i for i in range(nk) if i not in searched]
    if copied:  # the faster of the lighter and heavier neighbours' drives, played at the new node
        pairs = [(i, c, d) for i in copied for c, j in enumerate(cells)
                 for d in (field.drives[i, j], align_phase(field.drives[i, j + 1], field.drives[i, j]))]
        v = open_loop_velocity([(float(field.ks[i]), float(mids[c] * field.trapezoid_critical[i]), *field.friction)
                                for i, c, _ in pairs], np.array([d for *_, d in pairs]))
        for n in range(0, len(pairs), 2):
            i, c, _ = pairs[n]
            pick = n if v[n] >= v[n + 1] else n + 1
            new_drives[i, c], new_velocities[i, c] = pairs[pick][2], v[pick]
    at = [j + 1 for j in cells]  # each new line goes before the old line above it
    field.fractions = np.insert(field.fractions, at, mids)
    field.drives = np.insert(field.drives, at, new_drives, axis=1)
    field.velocities = np.insert(field.velocities, at, new_velocities, axis=1)
    field.meta[record] = {"budget": budget, "sigma": sigma, "band": list(band), "k_max": k_max,
                         **({"k_min": k_min} if k_min is not None else {}),
                         **({"starts": starts, "wide_trials": True} if wide_trials else {}),
                         **({"min_drop": min_drop, "fractions": mids.tolist()} if min_drop > 0.0 else {}),
                         "new_nodes": len(cells) * nk, "searched": len(cells) * len(searched)}
    return len(cells) * len(searched)


def refine_band(field, budget: int, sigma: float, k_band: tuple[float, float],
                fraction_band: tuple[float, float], executor=None, seed: int = 0, starts: int = 2) -> int:
    """A load line between every two whose midpoint fraction lies in ``fraction_band``, searched
    only at the k lines in ``k_band`` (elsewhere each new node keeps the faster of its lighter and
    heavier neighbours' drives): :func:`refine_load` with ``wide_trials``, ``starts`` starts of
    ``budget`` evaluations (record ``refined_band``). Each new node's cycle is written in the phase
    closest to its lighter neighbour's. Returns the new nodes searched."""
    old = field.fractions.copy()
    searched = refine_load(field, budget, sigma, fraction_band, executor, seed, starts, k_max=k_band[1],
                           record="refined_band", k_min=k_band[0], wide_trials=True)
    for j in np.flatnonzero(~np.isin(field.fractions, old)):
        field.drives[:, j] = align_phase(field.drives[:, j], field.drives[:, j - 1])
    return searched


def polish_stall(field, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
                 k_max: float | None = None) -> int:
    """At each of ``field.stall_nodes(k_max)``: :func:`polish_nodes` (record ``polished_stall``).
    Returns the nodes changed."""
    record = {"k_max": k_max}
    changed = polish_nodes(field, field.stall_nodes(k_max), budget, sigma, executor, seed, starts, "stall", record)
    field.meta["polished_stall"] = record
    return changed


def polish_band(field, budget: int, sigma: float, k_band: tuple[float, float],
                fraction_band: tuple[float, float], executor=None, seed: int = 0, starts: int = 2) -> int:
    """At each of ``field.band_nodes``: :func:`polish_nodes` (record ``polished_band``). Returns the
    nodes changed."""
    record = {"k_band": list(k_band), "fraction_band": list(fraction_band), "starts": starts}
    changed = polish_nodes(field, field.band_nodes(k_band, fraction_band), budget, sigma, executor, seed, starts,
                           "band", record)
    field.meta["polished_band"] = record
    return changed


def polish_nodes(field, nodes, budget: int, sigma: float, executor=None, seed: int = 0, starts: int = 3,
                 label: str = "", record: dict | None = None, extra: dict | None = None) -> int:
    """At each node (i, j) of ``nodes``: play its own drive, its lighter and its two k neighbours'
    (aligned to it), the push/clamp cycle and the drives ``extra`` gives it (a mapping of nodes to
    lists of drives), run CMA-ES over two-action cycles from the ``starts`` fastest (``budget``
    evaluations each, step ``sigma``; one task per node on ``executor``) and keep the fastest drive
    found or played if it beats the node's own. ``record``, if given, gets the search's settings and
    counts. Returns the nodes changed."""
    nk = len(field.ks)
    lines: dict = {}
    for i, j in nodes:
        own = field.drives[i, j]
        trials = [own, align_phase(PUSH_CLAMP, own)] + [align_phase(field.drives[a, b], own) for a, b in
                                                        ((i, j - 1), (i - 1, j), (i + 1, j)) if 0 <= a < nk and 0 <= b]
        trials += [align_phase(d, own) for d in (extra or {}).get((i, j), ())]
        lines.setdefault(i, []).append(((j, field.point(i, j)[:2]), np.array(trials)))
    changed = 0
    if lines:
        found_d, found_v = search_new_nodes([[(p, t) for (_, p), t in line] for line in lines.values()], budget,
                                            sigma, starts, seed, field.friction, f"teacher: polish {label}".strip(),
                                            executor, field.drive)
        for (i, line), drives, velocities in zip(lines.items(), found_d, found_v):
            for ((j, _), _), drive, vel in zip(line, drives, velocities):
                changed += field.keep_if_faster(i, j, drive, vel)
    if record is not None:
        record.update({"budget": budget, "sigma": sigma, "nodes": sum(map(len, lines.values())), "changed": changed})
    return changed


def audit(field, points: int, budget: int, sigma: float, band: tuple[float, float], polish_budget: int,
          gain: float = 0.03, floor: float = 0.01, starts: int = 2, executor=None, seed: int = 0,
          keep_found: bool = False) -> dict:
    """Check the teacher against a stronger search and mend it where it falls short (``config.Audit``).

    ``points`` points drawn from ``seed``: k uniform over the grid's k range, the load uniform in
    ``band`` (low, high) times the trapezoid's critical load at k. At each, the teacher's drive as
    the student is taught it (``field.best`` over the grid drives of the 4 x 4 nodes around the
    point) is searched again: CMA-ES over two-action cycles from the ``starts`` fastest of those
    drives, the trapezoid and the push/clamp cycle (``budget`` evaluations each, step ``sigma``).
    Where the search beats the teacher by more than ``gain`` (relative) and ``floor`` times the
    drive's stroke speed, the four nodes of the point's cell play the drive found and are polished
    from it (``polish_nodes``, ``polish_budget`` evaluations per start). With ``keep_found``, the drive
    found at each point that still falls short after the mending is kept as a point drive
    (``DriveField.add_point_drives``), offered to the student's labels around that point.
    ``field.meta["audited"]`` keeps the counts: the points that fell short, their mean shortfall,
    the nodes searched and changed, how many of those points still fall short after the mending
    and, with ``keep_found``, the point drives kept. Returns that record."""
    rng = np.random.default_rng(seed)
    ks = rng.uniform(field.ks[0], field.ks[-1], points)
    loads = rng.uniform(*band, points) * np.interp(ks, field.ks, field.trapezoid_critical)
    at = [(float(k), float(m)) for k, m in zip(ks, loads)]
    taught_d, taught_v = field.best(at, radius=2, interpolation=False)
    trapezoid = np.tile(trapezoid_action(field.drive), (2, 1))
    lines = [[(p, np.array([d, *field.candidates(*p, radius=2)[1:], align_phase(trapezoid, d),
                            align_phase(PUSH_CLAMP, d)]))] for p, d in zip(at, taught_d)]
    found_d, found_v = search_new_nodes(lines, budget, sigma, starts, seed, field.friction, "teacher: audit",
                                        executor, field.drive)
    found_d, found_v = np.array([d[0] for d in found_d]), np.array([v[0] for v in found_v])
    threshold = np.maximum(gain * np.abs(taught_v), floor * field.drive.stroke_speed)
    short = np.flatnonzero(found_v - taught_v > threshold)
    offers: dict = {}
    for n in short:
        i, j, _, _ = field._cell(*at[n])
        for node in ((i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)):
            offers.setdefault(node, []).append(found_d[n])
    record = {"points": points, "band": list(band), "gain": gain, "floor": floor, "starts": starts,
              "polish_budget": polish_budget, "short": int(len(short)),
              "mean_shortfall_m_s": float(np.mean(found_v[short] - taught_v[short])) if len(short) else 0.0}
    polish_nodes(field, sorted(offers), polish_budget, sigma, executor, seed + 1, starts, "audit", record, offers)
    record["search_budget"] = budget
    if len(short):
        _, mended_v = field.best([at[n] for n in short], radius=2, interpolation=False)
        still = short[found_v[short] - mended_v > threshold[short]]
        record["still_short"] = int(len(still))
        if keep_found and len(still):
            field.add_point_drives([at[n] for n in still], found_d[still])
    if keep_found:
        record["point_drives"] = int(len(field.point_drives))
    field.meta["audited"] = record
    return record


def exchange_all(field, screen_periods: int, screen_average: int, finalists: int, executor=None) -> dict:
    """Every node plays every distinct drive of the field, its grid drives and its point drives, each
    cycle in both phases (``config.ExchangeAll``): screened over ``screen_periods`` periods, the node's
    ``finalists`` fastest over the full evaluation; a node keeps the fastest (in its own phase) if it
    beats its own drive. One task per k line on ``executor``; no randomness. ``field.meta["exchanged_all"]``
    keeps the drives played, the nodes and those changed. Returns that record."""
    from mdr_drive_env.sweep import Executor

    drives = np.concatenate([field.drives.reshape(-1, 2, 5), field.point_drives.reshape(-1, 2, 5)])
    both = np.concatenate([drives, drives[:, ::-1]])
    table = np.unique(both.reshape(len(both), -1), axis=0).reshape(-1, 2, 5)
    nk, ns = field.velocities.shape
    tasks = [([field.point(i, j) for j in range(ns)], table, screen_periods, screen_average, finalists, field.drive)
             for i in range(nk)]
    found = (executor or Executor()).map(exchange_all_line, tasks, "teacher: exchange all")
    changed = 0
    for i, line in enumerate(found):
        for j, (index, velocity) in enumerate(line):
            changed += field.keep_if_faster(i, j, align_phase(table[index], field.drives[i, j]), velocity)
    record = {"drives": int(len(table)), "nodes": int(nk * ns), "changed": changed, "screen_periods": screen_periods,
              "screen_average": screen_average, "finalists": finalists}
    field.meta["exchanged_all"] = record
    return record


__all__ = ["audit", "exchange_all", "polish", "polish_band", "polish_nodes", "polish_stall", "refine_band", "refine_k",
           "refine_load"]
