"""The teacher's pick over a band of load (mdr_drive_agents.teacher.load_band): it scores candidates by
their worst ratio to the fastest over the band, never loses more than its limit at the point, and a
student's config passes it to the labels."""

from __future__ import annotations

import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.protocol import open_loop_velocity
from mdr_drive_agents.student.data import teacher_drives
from mdr_drive_agents.student.distill import DistillConfig
from mdr_drive_agents.teacher import LoadBand
from tests.agents.fields import synthetic_field

STROKE = 0.015  # m/s, a stroke speed for the scores


def test_a_drive_that_holds_over_the_band_outscores_one_that_falls_off_it():
    band = LoadBand((0.92, 1.08), max_loss=0.1, floor=0.1)
    # rows: the point's load, x0.92, x1.08; columns: fast but steep, a little slower but steady, far slower
    v = np.array([[10.0, 9.5, 5.0],
                  [10.5, 10.0, 5.5],
                  [2.0, 9.0, 4.5]]) * 1e-3
    score = band.scores(v, STROKE)
    assert score[1] > score[0]
    assert score[1] == pytest.approx(0.95)  # its worst ratio: 9.5 / 10 at the point's own load
    assert score[2] == -np.inf  # loses half at the point: never picked however steady
    assert int(np.argmax(score)) == 1


def test_loads_where_nothing_moves_do_not_count():
    band = LoadBand((1.08,), floor=0.1)  # 0.1 x 15 mm/s = 1.5 mm/s
    v = np.array([[3.0, 2.9], [1.0, 0.1]]) * 1e-3  # at x1.08 the fastest moves 1 mm/s: below the floor
    assert band.scores(v, STROKE) == pytest.approx([1.0, 2.9 / 3.0])


def test_a_banded_pick_holds_at_least_as_well_and_loses_at_most_its_limit_at_the_point():
    field = synthetic_field()
    points = [(0.25, 0.02), (0.45, 0.035), (0.1, 0.05)]
    band = LoadBand((0.92, 1.08), max_loss=0.1, floor=0.0)
    plain_d, plain_v = field.best(points, prefer_interpolation=0.0, radius=2)
    band_d, band_v = field.best(points, prefer_interpolation=0.0, radius=2, load_band=band)
    scales = band.all_scales
    for p, dp, db, vp, vb in zip(points, plain_d, band_d, plain_v, band_v):
        cands = field.candidates(*p, radius=2)
        at = [(p[0], p[1] * s, *field.friction) for s in scales for _ in cands]
        v = open_loop_velocity(at, np.concatenate([cands] * len(scales))).reshape(len(scales), len(cands))
        top = v.max(axis=1)

        def worst(drive):
            c = int(np.flatnonzero([np.array_equal(drive, x) for x in cands])[0])
            return np.min(v[:, c] / top)

        assert vb >= top[0] - 0.1 * abs(top[0]) - 1e-12  # within max_loss of the fastest at the point
        assert vp == pytest.approx(top[0])
        assert worst(db) >= worst(dp) - 1e-12
        assert vb == pytest.approx(open_loop_velocity([(p[0], p[1], *field.friction)], db[None])[0])


def test_a_band_is_checked_and_named():
    with pytest.raises(ValueError, match="must not hold 1"):
        LoadBand((1.0,))
    with pytest.raises(ValueError, match="load_band scales"):
        LoadBand((0.9, 2.5))
    with pytest.raises(ValueError, match="empty"):
        LoadBand(())
    with pytest.raises(ValueError, match="load_band max_loss"):
        LoadBand((0.9,), max_loss=1.0)
    with pytest.raises(ValueError, match="teacher_load_band"):
        DistillConfig(teacher_load_band=(0.0, 1.1))
    with pytest.raises(ValueError, match="teacher_load_band.*must not hold 1"):
        DistillConfig(teacher_load_band=(1.0,))
    with pytest.raises(ValueError, match="teacher_load_loss"):
        DistillConfig(teacher_load_band=(0.92, 1.08), teacher_load_loss=-0.1)


def test_a_students_labels_use_its_load_band():
    class Recorder:
        def best(self, points, **reach):
            self.reach = reach
            return np.zeros((len(points), 2, 5)), np.zeros(len(points))

    field = Recorder()
    teacher_drives(field, [(0.3, 0.01)], DistillConfig(teacher_load_band=(0.92, 1.08), teacher_load_loss=0.05))
    assert field.reach["load_band"] == LoadBand((0.92, 1.08), max_loss=0.05)
    teacher_drives(field, [(0.3, 0.01)], DistillConfig())
    assert "load_band" not in field.reach
    assert DistillConfig().load_band() is None
