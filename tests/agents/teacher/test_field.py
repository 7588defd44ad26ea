"""The teacher's drive field (mdr_drive_agents.teacher.field) and the work of its stages
(mdr_drive_agents.teacher.refine), on synthetic fields: each stage searches the nodes it names, keeps
only gains, and records velocities its drives play at."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.drive import PAPER_DRIVE
from mdr_drive_agents.protocol import trapezoid_action
from mdr_drive_agents.student.distill import DistillConfig
from mdr_drive_agents.teacher import FieldConfig, refine
from mdr_drive_agents.teacher.config import (Audit, ExchangeAll, PolishBand, PolishStall, RefineBand, RefineK,
                                             RefineLoad, RefineSteep)
from mdr_drive_agents.yaml_config import build
from tests.agents.fields import synthetic_field

STAGES = {"refine_k": RefineK, "refine_load": RefineLoad, "refine_steep": RefineSteep, "polish_stall": PolishStall,
          "polish_band": PolishBand, "refine_band": RefineBand, "audit": Audit, "exchange_all": ExchangeAll}


def stage_config(name: str, values: tuple) -> FieldConfig:
    """A FieldConfig with stage ``name`` set from ``values`` in its fields' order, as the YAML gives it."""
    return build(FieldConfig, {name: dict(zip([f.name for f in fields(STAGES[name])], values))}, "teacher")


def test_the_teachers_neighbourhood_grows_with_its_radius_and_stays_on_the_grid():
    field = synthetic_field()
    inside, corner = (0.3, 0.03), (0.0, 0.0)  # a cell in the middle of the grid; the grid's first cell
    assert len(field.candidates(*inside)) == 5  # the interpolation and the cell's four corners
    assert len(field.candidates(*inside, radius=2)) == 1 + 16
    assert len(field.candidates(*corner, radius=2)) == 1 + 9  # nodes past the grid's edge left out
    first = field.candidates(*inside)
    assert np.array_equal(field.candidates(*inside, radius=2)[:5], first)  # the same five first
    with pytest.raises(ValueError, match="radius"):
        field.best([inside], radius=0)
    with pytest.raises(ValueError, match="teacher_radius"):
        DistillConfig(teacher_radius=0)


def test_polish_searches_from_each_node_and_its_distinct_neighbours_and_keeps_only_gains(monkeypatch):
    from mdr_drive_agents.teacher import node_search as field_search
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=3, ns=3)
    field.drives[1, 2] = field.drives[1, 1]  # a neighbour with the node's own drive is not a second start
    field.velocities[:] = 0.01
    seen = {}

    def fake_slice(args):  # a stand-in search: node (1, 1) finds a faster drive, (0, 0) a slower one
        nodes, budget, sigma, *_ = args
        out = []
        for k, load, starts in nodes:
            i = int(np.argmin(np.abs(field.ks - k)))
            j = int(np.argmin(np.abs(field.fractions * field.trapezoid_critical[i] - load)))
            seen[(i, j)] = len(starts)
            assert np.array_equal(starts[0], field.drives[i, j]) and (budget, sigma) == (8, 0.1)
            out.append((np.full((2, 5), 0.3), {(1, 1): 0.02, (0, 0): 0.005}.get((i, j), 0.01)))
        return out

    monkeypatch.setattr(field_search, "polish_slice", fake_slice)
    assert refine.polish(field, 8, 0.1, executor=Executor(workers=1, progress=False)) == 1
    assert len(seen) == 9 and seen[(0, 0)] == 3 and seen[(1, 0)] == 4 and seen[(1, 1)] == 4  # itself + its distinct neighbours
    assert field.velocities[1, 1] == 0.02 and np.all(field.drives[1, 1] == 0.3)
    assert field.velocities[0, 0] == 0.01 and not np.all(field.drives[0, 0] == 0.3)  # a slower drive is not taken
    assert field.meta["polished"] == [{"budget": 8, "sigma": 0.1, "changed": 1}]


def test_polishing_one_node_per_task_finds_what_one_line_per_task_finds():
    from mdr_drive_agents.teacher.node_search import map_polish_by_node, polish_slice
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=3)
    field.trapezoid_critical[:] = 0.02
    lines = [([(*field.point(i, j)[:2], field.drives[i, j:j + 2]) for j in range(2)], 16, 0.2, 7 + 100 * i,
              field.friction, field.drive) for i in range(2)]
    by_line = [polish_slice(task) for task in lines]
    by_node = map_polish_by_node(lines, "test", Executor(workers=2, progress=False))
    assert [len(line) for line in by_node] == [2, 2]
    for line_a, line_b in zip(by_line, by_node):
        for (drive_a, v_a), (drive_b, v_b) in zip(line_a, line_b):
            assert np.array_equal(drive_a, drive_b) and v_a == v_b  # the same seeds: the same drives, bit for bit


def test_a_polished_node_plays_at_the_velocity_it_records():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=2)
    field.trapezoid_critical[:] = 0.02
    points = [field.point(i, j) for i in range(2) for j in range(2)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(4, 2, 5)).reshape(2, 2)
    before = field.velocities.copy()
    refine.polish(field, 32, 0.2, executor=Executor(workers=1, progress=False))
    assert np.all(field.velocities >= before)
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(4, 2, 5)), field.velocities.ravel())


def test_refine_k_adds_a_k_line_between_every_two_and_plays_what_it_records(monkeypatch):
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=2)
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(2) for j in range(2)],
                                          field.drives.reshape(4, 2, 5)).reshape(2, 2)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    monkeypatch.setattr(refine, "trapezoid_critical_load", lambda ks, drive: np.full(len(ks), 0.03))
    refine.refine_k(field, 8, 0.1, executor=Executor(workers=1, progress=False))
    assert np.allclose(field.ks, [0.0, 0.3, 0.6]) and field.velocities.shape == (3, 2)
    assert np.allclose(field.trapezoid_critical, [0.02, 0.03, 0.02])
    assert np.array_equal(field.drives[::2], old_drives) and np.array_equal(field.velocities[::2], old_velocities)
    points = [field.point(1, j) for j in range(2)]  # the new nodes, at the new line's critical load
    assert np.allclose(open_loop_velocity(points, field.drives[1]), field.velocities[1])
    for j in range(2):  # never slower than a drive it started from: the k neighbours' drives
        started = open_loop_velocity([points[j]] * 2, old_drives[:, j])
        assert field.velocities[1, j] >= started.max() - 1e-12
    assert field.meta["refined_k"] == {"budget": 8, "sigma": 0.1, "k_max": None, "new_nodes": 2}
    assert refine.refine_k(field, 8, 0.1, executor=Executor(workers=1, progress=False), k_max=0.2) == 2  # only below k_max
    assert np.allclose(field.ks, [0.0, 0.15, 0.3, 0.6]) and field.drives.shape == (4, 2, 2, 5)
    assert np.allclose(field.trapezoid_critical, [0.02, 0.03, 0.03, 0.02])
    assert refine.refine_k(field, 8, 0.1, k_max=0.01) == 0 and len(field.ks) == 4
    with pytest.raises(ValueError, match="refine_k budget"):
        stage_config("refine_k", (0, 0.1))
    with pytest.raises(ValueError, match=r"refine_k: missing key\(s\) \['sigma'\]"):
        stage_config("refine_k", (10,))
    with pytest.raises(ValueError, match="refine_k k_max"):
        stage_config("refine_k", (10, 0.1, 0.9))  # outside k_range


def test_refine_load_adds_load_lines_in_its_band_and_plays_what_it_records():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=3)  # fractions 0, 0.6, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(2) for j in range(3)],
                                          field.drives.reshape(6, 2, 5)).reshape(2, 3)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    assert refine.refine_load(field, 8, 0.1, (0.5, 1.0), executor=Executor(workers=1, progress=False)) == 2  # 0.9 only
    assert np.allclose(field.fractions, [0.0, 0.6, 0.9, 1.2]) and field.velocities.shape == (2, 4)
    assert np.array_equal(field.drives[:, [0, 1, 3]], old_drives)
    assert np.array_equal(field.velocities[:, [0, 1, 3]], old_velocities)
    points = [field.point(i, 2) for i in range(2)]  # the new nodes, at 0.9 of the critical load
    assert np.isclose(points[0][1], 0.9 * 0.02)
    assert np.allclose(open_loop_velocity(points, field.drives[:, 2]), field.velocities[:, 2])
    for i in range(2):  # never slower than a drive it started from: the lighter and heavier neighbours'
        started = open_loop_velocity([points[i]] * 2, old_drives[i, 1:])
        assert field.velocities[i, 2] >= started.max() - 1e-12
    assert field.meta["refined_load"] == {"budget": 8, "sigma": 0.1, "band": [0.5, 1.0], "k_max": None,
                                          "new_nodes": 2, "searched": 2}
    i, j, _, ws = field._cell(0.0, 0.95 * 0.02)  # queries read the uneven fractions
    assert j == 2 and np.isclose(ws, (0.95 - 0.9) / 0.3)
    assert refine.refine_load(field, 8, 0.1, (1.3, 1.4)) == 0
    # above k_max the new nodes are not searched: each keeps its lighter or heavier neighbour's drive
    assert refine.refine_load(field, 8, 0.1, (0.7, 0.8), executor=Executor(workers=1, progress=False), k_max=0.3) == 1
    assert np.allclose(field.fractions, [0.0, 0.6, 0.75, 0.9, 1.2])
    upper = field.point(1, 2)
    neighbours = open_loop_velocity([upper] * 2, field.drives[1, [1, 3]])
    assert any(np.array_equal(field.drives[1, 2], align_phase(field.drives[1, b], field.drives[1, 1])) for b in (1, 3))
    assert np.isclose(field.velocities[1, 2], neighbours.max())
    assert field.meta["refined_load"]["searched"] == 1 and field.meta["refined_load"]["new_nodes"] == 2
    for bad, match in (((0, 0.1, 0.5, 1.0), "refine_load budget"), ((10, 0.1, 0.5), "refine_load"),
                       ((10, 0.1, 1.0, 0.5), "refine_load high"), ((10, 0.1, 0.5, 9.0), "refine_load high"),
                       ((10, 0.1, 0.5, 1.0, 0.9), "refine_load k_max")):
        with pytest.raises(ValueError, match=match):
            stage_config("refine_load", bad)


def test_refine_steep_adds_load_lines_only_where_the_velocity_falls_steeply():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=4)  # fractions 0, 0.4, 0.8, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = np.array([[9e-3, 8e-3, 2e-3, -5e-3],    # falls by 6 mm/s from 0.4 to 0.8, then to a stall
                                 [9e-3, 7e-3, 5e-3, -1e-3]])   # 2 mm/s, then 5 (backwards counts as a stop)
    assert np.allclose(field.velocity_drops(), [[1e-3, 6e-3, 2e-3], [2e-3, 2e-3, 5e-3]])
    ex = Executor(workers=1, progress=False)
    # 0.2 (1 and 2 mm/s) and 1.0 (5 mm/s, not more) stay cells; 0.6 falls by more than 5 on line 0
    assert refine.refine_load(field, 8, 0.1, (0.1, 1.1), executor=ex, min_drop=5e-3, record="refined_steep") == 2
    assert np.allclose(field.fractions, [0.0, 0.4, 0.6, 0.8, 1.2])
    assert field.meta["refined_steep"] == {"budget": 8, "sigma": 0.1, "band": [0.1, 1.1], "k_max": None,
                                           "min_drop": 5e-3, "fractions": [0.6], "new_nodes": 2, "searched": 2}
    assert "refined_load" not in field.meta
    assert np.allclose(open_loop_velocity([field.point(i, 2) for i in range(2)], field.drives[:, 2]),
                       field.velocities[:, 2])
    before = field.fractions.copy()
    assert refine.refine_load(field, 8, 0.1, (0.1, 1.1), executor=ex, min_drop=0.05, record="refined_steep") == 0
    assert np.array_equal(field.fractions, before)
    for bad, match in (((300, 0.1, 0.6, 1.5), "refine_steep"), ((0, 0.1, 0.6, 1.5, 0.005), "refine_steep budget"),
                       ((300, 0.1, 1.0, 0.6, 0.3), "refine_steep high"),
                       ((300, 0.1, 0.6, 1.2, 0.0), "refine_steep relative_drop"),
                       ((300, 0.1, 0.6, 1.2, 5.0), "refine_steep relative_drop")):
        with pytest.raises(ValueError, match=match):
            stage_config("refine_steep", bad)


def test_refine_steep_reads_its_drop_in_the_drives_stroke_speed():
    from mdr_drive_agents.drive import PAPER_DRIVE, DriveDescription
    from mdr_drive_env.sweep import Executor

    assert PAPER_DRIVE.stroke_speed == pytest.approx(0.015)  # 30 um over 2 ms
    small = DriveDescription.from_mapping({"period": 1e-3, "x_amplitude_max": 20e-6})
    assert small.stroke_speed == pytest.approx(0.02)
    for drive, found in ((PAPER_DRIVE, [0.6]), (small, [])):  # drops of 6 and 5 mm/s: 0.35 x 15 = 5.25, 0.35 x 20 = 7
        field = synthetic_field(nk=2, ns=4)
        field.drive = drive
        field.trapezoid_critical[:] = 0.02
        field.velocities = np.array([[9e-3, 8e-3, 2e-3, -5e-3], [9e-3, 7e-3, 5e-3, -1e-3]])
        stage_config("refine_steep", (8, 0.1, 0.1, 1.1, 0.35)).refine_steep.run(
            field, Executor(workers=1, progress=False), seed=0)
        if found:
            assert field.meta["refined_steep"]["fractions"] == found
            assert field.meta["refined_steep"]["relative_drop"] == pytest.approx(0.35)
        else:
            assert "refined_steep" not in field.meta and len(field.fractions) == 4


def test_polish_stall_searches_the_nodes_either_side_of_each_stall_and_plays_what_it_records():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=3, ns=4)
    field.velocities[:] = [[3.0, 2.0, 1.0, -1.0],   # moves up to node 2: nodes 2 and 3
                           [-1.0, -2.0, -3.0, -4.0],  # moves nowhere: the lightest and the next
                           [3.0, -1.0, 2.0, 1.0]]     # moves at the heaviest: the two heaviest
    assert field.stall_nodes() == [(0, 2), (0, 3), (1, 0), (1, 1), (2, 2), (2, 3)]
    assert field.stall_nodes(k_max=0.3) == [(0, 2), (0, 3), (1, 0), (1, 1)]  # k lines 0, 0.3, 0.6
    field.trapezoid_critical[:] = 0.02
    points = [field.point(i, j) for i in range(3) for j in range(4)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(12, 2, 5)).reshape(3, 4)
    before_d, before_v = field.drives.copy(), field.velocities.copy()
    stall = field.stall_nodes()
    changed = refine.polish_stall(field, 8, 0.1, executor=Executor(workers=1, progress=False))
    assert field.meta["polished_stall"] == {"budget": 8, "sigma": 0.1, "k_max": None, "nodes": len(stall),
                                            "changed": changed}
    untouched = [(i, j) for i in range(3) for j in range(4) if (i, j) not in stall]
    for i, j in untouched:  # only the stall nodes search
        assert np.array_equal(field.drives[i, j], before_d[i, j]) and field.velocities[i, j] == before_v[i, j]
    assert np.all(field.velocities >= before_v) and changed == int((field.velocities > before_v).sum())
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(12, 2, 5)), field.velocities.ravel())
    for bad, match in (((0, 0.1), "polish_stall budget"), ((10, 0.0), "polish_stall sigma"), ((10,), "polish_stall"),
                       ((10, 0.1, 0.7), "polish_stall k_max")):
        with pytest.raises(ValueError, match=match):
            stage_config("polish_stall", bad)


def test_polish_band_searches_the_nodes_of_its_band_only_and_plays_what_it_records():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=3, ns=4)  # k 0, 0.3, 0.6; fractions 0, 0.4, 0.8, 1.2
    field.trapezoid_critical[:] = 0.02
    assert field.band_nodes((0.3, 0.6), (0.4, 0.8)) == [(1, 1), (1, 2), (2, 1), (2, 2)]
    assert field.band_nodes((0.1, 0.2), (0.0, 1.2)) == []
    points = [field.point(i, j) for i in range(3) for j in range(4)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(12, 2, 5)).reshape(3, 4)
    before_d, before_v = field.drives.copy(), field.velocities.copy()
    band = field.band_nodes((0.3, 0.6), (0.4, 0.8))
    changed = refine.polish_band(field, 8, 0.1, (0.3, 0.6), (0.4, 0.8), executor=Executor(workers=1, progress=False))
    assert field.meta["polished_band"] == {"budget": 8, "sigma": 0.1, "k_band": [0.3, 0.6], "fraction_band": [0.4, 0.8],
                                           "starts": 2, "nodes": len(band), "changed": changed}
    for i, j in [(i, j) for i in range(3) for j in range(4) if (i, j) not in band]:
        assert np.array_equal(field.drives[i, j], before_d[i, j]) and field.velocities[i, j] == before_v[i, j]
    assert np.all(field.velocities >= before_v) and changed == int((field.velocities > before_v).sum())
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(12, 2, 5)), field.velocities.ravel())
    assert refine.polish_band(field, 8, 0.1, (0.1, 0.2), (0.0, 1.2), executor=Executor(workers=1, progress=False)) == 0
    for bad, match in (((0, 0.1, 0.1, 0.3, 0.8, 1.4), "polish_band budget"), ((10, 0.0, 0.1, 0.3, 0.8, 1.4), "polish_band sigma"),
                       ((10, 0.1, 0.1, 0.3), "polish_band"), ((10, 0.1, 0.3, 0.1, 0.8, 1.4), "polish_band k_high"),
                       ((10, 0.1, 0.1, 0.7, 0.8, 1.4), "polish_band k_high"), ((10, 0.1, 0.1, 0.3, 0.8, 0.5), "polish_band high"),
                       ((10, 0.1, 0.1, 0.3, -0.1, 1.0), "polish_band low")):
        with pytest.raises(ValueError, match=match):
            stage_config("polish_band", bad)


def test_refine_band_searches_its_new_load_lines_in_its_k_band_only_and_from_the_bands_drives():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=4, ns=3)  # k 0, 0.2, 0.4, 0.6; fractions 0, 0.6, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(4) for j in range(3)],
                                          field.drives.reshape(12, 2, 5)).reshape(4, 3)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    assert refine.refine_band(field, 8, 0.1, (0.2, 0.6), (0.5, 1.0), executor=Executor(workers=1, progress=False)) == 3
    assert np.allclose(field.fractions, [0.0, 0.6, 0.9, 1.2]) and field.velocities.shape == (4, 4)
    assert np.array_equal(field.drives[:, [0, 1, 3]], old_drives)  # the old nodes as they were
    assert np.array_equal(field.velocities[:, [0, 1, 3]], old_velocities)
    points = [field.point(i, 2) for i in range(4)]
    assert np.allclose(open_loop_velocity(points, field.drives[:, 2]), field.velocities[:, 2])
    # k = 0 lies outside the band: its new node keeps its lighter or heavier neighbour's drive
    assert np.isclose(field.velocities[0, 2], open_loop_velocity([points[0]] * 2, old_drives[0, 1:]).max())
    # a searched node is never slower than any drive of the band on its two load lines (wide trials),
    # here the node at k = 0.2 against the drives of k = 0.6, two k lines away
    far = open_loop_velocity([points[1]] * 2, old_drives[3, 1:])
    assert field.velocities[1, 2] >= far.max() - 1e-12
    for i in range(4):  # each new cycle in the phase closest to its lighter neighbour's
        assert np.array_equal(field.drives[i, 2], align_phase(field.drives[i, 2], field.drives[i, 1]))
    assert field.meta["refined_band"] == {"budget": 8, "sigma": 0.1, "band": [0.5, 1.0], "k_max": 0.6, "k_min": 0.2,
                                          "starts": 2, "wide_trials": True, "new_nodes": 4, "searched": 3}
    for bad, match in (((0, 0.1, 0.1, 0.3, 0.8, 1.4), "refine_band budget"), ((10, 0.1, 0.1, 0.3), "refine_band"),
                       ((10, 0.1, 0.3, 0.1, 0.8, 1.4), "refine_band k_high"),
                       ((10, 0.1, 0.1, 0.3, 0.8, 0.5), "refine_band high")):
        with pytest.raises(ValueError, match=match):
            stage_config("refine_band", bad)


def test_the_teachers_reach_in_load_can_differ_from_its_reach_in_k():
    from mdr_drive_agents.student.data import teacher_drives

    field = synthetic_field(nk=6, ns=9)  # fractions 0, 0.15, ..., 1.2
    inside = (0.3, 0.6 * 0.05)  # the cell at k 0.24-0.36 and fractions 0.6-0.75
    assert len(field.candidates(*inside, radius=2, load_radius=3)) == 1 + 4 * 6
    assert len(field.candidates(*inside, radius=2, load_radius=2)) == len(field.candidates(*inside, radius=2))
    wide = field.candidates(*inside, radius=2, load_radius=3)
    assert all(any(np.array_equal(c, w) for w in wide) for c in field.candidates(*inside, radius=2))
    config = DistillConfig(teacher_radius=2, teacher_load_radius=3, quantum_centres=True, action_codebook=True)
    drives, _ = teacher_drives(field, [inside], config)
    assert any(np.array_equal(drives[0], w) for w in wide[1:])  # one of the grid's own drives
    with pytest.raises(ValueError, match="teacher_load_radius"):
        DistillConfig(teacher_load_radius=-1)


def test_keeping_phases_leaves_the_nodes_a_stage_did_not_change_as_they_were():
    from mdr_drive_agents.teacher import DriveField

    a, b = np.full(5, 0.5), np.full(5, -0.5)
    c, d = np.array([0.9, 0.9, -0.9, -0.9, 0.0]), np.array([-0.9, -0.9, 0.9, 0.9, 0.0])
    line = np.array([[a, b], [c, d], [c, d], [c, d]])  # a light drive, then a heavy family, aligned
    before = np.stack([line, line])

    def field_with(drives):
        return DriveField(np.array([0.0, 0.6]), np.linspace(0.0, 1.2, 4), np.full(2, 0.05), drives.copy(), np.zeros((2, 4)))

    field = field_with(before)
    field.align()
    assert np.array_equal(field.drives, before)
    # a stage gives node (0, 1) a new drive, closer to the light drive as written and to the heavy
    # family swapped: align's chain along the line then turns every heavier node's phase
    new = np.array([0.6 * a + 0.4 * d, 0.6 * b + 0.4 * c])
    changed = before.copy()
    changed[0, 1] = new
    chained = field_with(changed)
    chained.align()
    assert all(np.array_equal(chained.drives[0, j], before[0, j, ::-1]) for j in (2, 3))
    kept = field_with(changed)
    kept.keep_phases(before)
    untouched = [(i, j) for i in range(2) for j in range(4) if (i, j) != (0, 1)]
    assert all(np.array_equal(kept.drives[i, j], before[i, j]) for i, j in untouched)
    assert np.array_equal(kept.drives[0, 1], align_phase(new, before[0, 1]))  # the new drive, in its node's old phase
    with pytest.raises(ValueError, match="keep_phases"):
        kept.keep_phases(before[:1])


def test_a_wider_teacher_never_plays_a_slower_drive():
    field = synthetic_field()
    points = [(0.25, 0.02), (0.45, 0.04)]
    _, narrow = field.best(points, prefer_interpolation=0.0)
    _, wide = field.best(points, prefer_interpolation=0.0, radius=2)
    assert np.all(wide >= narrow)



def test_audit_mends_the_cells_where_a_stronger_search_beats_the_teacher_and_records_it():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=3, ns=4)  # k 0, 0.3, 0.6; fractions 0, 0.4, 0.8, 1.2
    field.trapezoid_critical[:] = 0.02
    field.drives[:] = 0.0  # a poor teacher: every node plays the zero action
    points = [field.point(i, j) for i in range(3) for j in range(4)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(12, 2, 5)).reshape(3, 4)
    before_v = field.velocities.copy()
    ex = Executor(workers=1, progress=False)
    record = refine.audit(field, 6, 16, 0.3, (0.2, 1.0), 8, executor=ex, seed=5)
    assert field.meta["audited"] is record and record["points"] == 6 and record["band"] == [0.2, 1.0]
    assert record["short"] > 0 and record["mean_shortfall_m_s"] > 0.01 * field.drive.stroke_speed
    assert 0 < record["nodes"] <= 4 * record["short"] and 0 <= record["still_short"] <= record["short"]
    assert np.all(field.velocities >= before_v) and record["changed"] == int((field.velocities > before_v).sum())
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(12, 2, 5)), field.velocities.ravel())
    again = synthetic_field(nk=3, ns=4)
    again.trapezoid_critical[:] = 0.02
    again.drives[:] = 0.0
    again.velocities = before_v.copy()
    refine.audit(again, 6, 16, 0.3, (0.2, 1.0), 8, executor=ex, seed=5)
    assert np.array_equal(again.drives, field.drives)  # seeded: the same audit mends the same way
    for bad, match in (((0, 10, 0.3, 0.2, 1.0, 10), "audit points"), ((5, 10, 0.0, 0.2, 1.0, 10), "audit sigma"),
                       ((5, 10, 0.3, 0.2, 9.0, 10), "audit high"), ((5, 10, 0.3, 0.2, 1.0, 0), "audit polish_budget"),
                       ((5, 10, 0.3, 0.2, 1.0, 10, 2.0), "audit gain"), ((5, 10, 0.3), "audit")):
        with pytest.raises(ValueError, match=match):
            stage_config("audit", bad)


def test_exchange_all_gives_each_node_the_fastest_drive_of_the_field_and_keeps_only_gains():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=2, ns=3)  # k 0, 0.6; fractions 0, 0.6, 1.2 of 0.05 kg
    points = [field.point(i, j) for i in range(2) for j in range(3)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(6, 2, 5)).reshape(2, 3)
    field.add_point_drives([(0.3, 0.03)], np.tile(trapezoid_action(PAPER_DRIVE), (1, 2, 1)))
    before_d, before_v = field.drives.copy(), field.velocities.copy()
    record = refine.exchange_all(field, 6, 2, 3, executor=Executor(workers=1, progress=False))
    assert field.meta["exchanged_all"] is record and record["nodes"] == 6 and record["drives"] == 13  # 7 drives, 6 swapped
    assert np.all(field.velocities >= before_v) and record["changed"] == int((field.velocities > before_v).sum())
    assert record["changed"] > 0  # random drives: some node has a faster one elsewhere in the field
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(6, 2, 5)), field.velocities.ravel())
    table = np.concatenate([before_d.reshape(6, 2, 5), field.point_drives])
    for i, j in zip(*np.nonzero(field.velocities > before_v)):  # a drive of the field, in the node's own phase
        assert any(np.array_equal(field.drives[i, j], align_phase(d, before_d[i, j])) for d in table)
    unchanged = field.velocities == before_v
    assert np.array_equal(field.drives[unchanged], before_d[unchanged])
    again = synthetic_field(nk=2, ns=3)
    again.velocities = before_v.copy()
    again.add_point_drives([(0.3, 0.03)], np.tile(trapezoid_action(PAPER_DRIVE), (1, 2, 1)))
    refine.exchange_all(again, 6, 2, 3, executor=Executor(workers=1, progress=False))
    assert np.array_equal(again.drives, field.drives)  # no randomness
    for bad, match in (((1, 1, 8), "exchange_all screen_periods"), ((12, 12, 8), "exchange_all screen_average"),
                       ((12, 4, 0), "exchange_all finalists")):
        with pytest.raises(ValueError, match=match):
            stage_config("exchange_all", bad)


def test_a_point_drive_is_offered_near_where_it_was_found_and_survives_a_save(tmp_path):
    from mdr_drive_agents.student.checkpoint import field_digest
    from mdr_drive_agents.student.data import grid_actions
    from mdr_drive_agents.teacher.field import DriveField

    field = synthetic_field(nk=7)  # k 0, 0.1, ..., 0.6; fractions 0, 0.3, ..., 1.2 of a critical load of 0.05 kg
    near, far = (0.35, 0.5 * 0.05), (0.05, 0.1 * 0.05)  # cells (3, 1) and (0, 0)
    before_near, before_far = len(field.candidates(*near, radius=2)), len(field.candidates(*far, radius=2))
    digest, actions = field_digest(field), grid_actions(field)
    found = np.full((1, 2, 5), 0.123)
    field.add_point_drives([near], found)
    assert np.allclose(field.point_at, [[0.35, 0.5]])
    assert len(field.candidates(*near, radius=2)) == before_near + 1  # in its own cell and the cells around
    assert np.allclose(field.candidates(*near, radius=2)[-1], align_phase(found[0], field.candidates(*near)[1]))
    assert len(field.candidates(*near)) == 6  # radius 1: the cell's corners and its own point drives
    assert len(field.candidates(*far, radius=2)) == before_far  # not three cells away
    assert field_digest(field) != digest and len(grid_actions(field)) == len(actions) + 1
    field.save(tmp_path / "f.npz")
    loaded = DriveField.load(tmp_path / "f.npz")
    assert np.array_equal(loaded.point_drives, field.point_drives) and field_digest(loaded) == field_digest(field)
    with pytest.raises(ValueError, match="point_at"):
        DriveField(field.ks, field.fractions, field.trapezoid_critical, field.drives, field.velocities,
                   point_at=np.zeros((2, 2)), point_drives=found)


def test_an_audit_keeps_the_drive_it_found_where_the_mended_nodes_still_fall_short(monkeypatch):
    from mdr_drive_env.sweep import Executor

    field = synthetic_field(nk=3, ns=4)
    field.trapezoid_critical[:] = 0.02
    field.drives[:] = 0.0  # a poor teacher, as above
    monkeypatch.setattr(refine, "polish_nodes", lambda *a, **k: 0)  # the mending changes nothing
    record = refine.audit(field, 6, 16, 0.3, (0.2, 1.0), 8, executor=Executor(workers=1, progress=False), seed=5,
                          keep_found=True)
    assert record["still_short"] == record["short"] > 0 and record["point_drives"] == record["short"]
    assert len(field.point_drives) == record["short"]
    with pytest.raises(ValueError, match="keep_found"):
        stage_config("audit", (5, 10, 0.3, 0.2, 1.0, 10, 0.03, 0.01, 2, "yes"))


def test_the_grid_searches_each_node_from_its_lighter_neighbour_the_trapezoid_push_clamp_and_throw_coast(monkeypatch):
    from mdr_drive_agents.search import PUSH_CLAMP, THROW_COAST
    from mdr_drive_agents.teacher import node_search

    seen = []

    def fake_search_point(k, load, *args, cycle_starts, **kwargs):
        seen.append([np.array(s) for s in cycle_starts])
        return type("Found", (), {"drive": np.zeros((2, 5)), "velocity": 0.0})()

    monkeypatch.setattr(node_search, "search_point", fake_search_point)
    config = FieldConfig(k_values=2, load_fractions=2)
    node_search.search_slice((0.1, np.array([0.0, 0.01]), config, 0, PAPER_DRIVE))
    unloaded, loaded = seen
    assert len(unloaded) == 3 and len(loaded) == 4  # the unloaded point has no lighter one
    assert np.array_equal(loaded[0], np.zeros((2, 5)))  # the lighter point's drive (continuation)
    for starts in seen:
        assert np.array_equal(starts[-3], np.tile(trapezoid_action(PAPER_DRIVE), (2, 1)))
        assert np.array_equal(starts[-2], PUSH_CLAMP) and np.array_equal(starts[-1], THROW_COAST)


def test_a_teacher_searched_on_a_coarser_solver_keeps_the_velocities_its_drives_play_at_on_the_envs():
    from mdr_drive_agents.protocol import open_loop_velocity
    from mdr_drive_agents.teacher import DriveField
    from mdr_drive_env.sweep import Executor

    slow = PAPER_DRIVE.with_settings(period=4e-3)
    config = FieldConfig(k_values=2, k_range=(0.2, 0.4), load_fractions=2, fixed_budget=4, cycle_budget=4,
                         search_steps_per_period=100)
    with pytest.raises(ValueError, match=r"search_steps_per_period=20 is outside the allowed range \[50, inf\)"):
        FieldConfig(search_steps_per_period=20)
    field = DriveField.search(config, drive=slow, executor=Executor(workers=1, progress=False))
    assert field.drive.search_steps_per_period is None and "env_replay" in field.meta["stage_wall_time_s"]
    points = [field.point(i, j) for i in range(2) for j in range(2)]
    on_env = open_loop_velocity(points, field.drives.reshape(-1, 2, 5), drive=slow).reshape(2, 2)
    np.testing.assert_array_equal(field.velocities, on_env)
    on_search = open_loop_velocity(points, field.drives.reshape(-1, 2, 5), drive=slow.with_search_solver(100))
    assert not np.array_equal(on_search.reshape(2, 2), on_env)  # the search played on another solver


def test_throw_coast_throws_on_xs_fastest_edge_at_full_depth_then_lets_the_slider_coast_out_of_contact():
    from mdr_drive_agents.search import THROW_COAST

    amap = PAPER_DRIVE.action_map()
    throw, coast = (amap.to_waveform(a) for a in THROW_COAST)
    assert throw.x.amplitude == amap.x_amplitude_max and throw.z.amplitude == amap.z_amplitude_max
    assert throw.x.rise_time == pytest.approx(amap.min_rise_fraction * amap.period)  # forward on the fastest edge
    assert throw.z.fall_time == pytest.approx((1.0 - amap.max_rise_fraction) * amap.period)  # let go fast
    assert coast.z.amplitude == 0.0 and coast.x.amplitude == amap.x_amplitude_max
