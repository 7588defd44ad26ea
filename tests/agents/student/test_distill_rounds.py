"""The distillation's rounds (mdr_drive_agents.student.distill): holes, stall probes, focus bands."""

from __future__ import annotations

import re

import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.student.distill import DistillConfig
from tests.agents.fields import StepTeacher, synthetic_field

def test_a_hole_is_a_probe_short_of_the_teacher_by_the_share_and_the_floor(monkeypatch):
    from mdr_drive_agents.student import distill

    field = synthetic_field()
    teacher = np.array([20e-3, 20e-3, 0.7e-3, 0.7e-3, 5e-3])
    student = np.array([17e-3, 19.5e-3, -0.02e-3, 0.65e-3, 4.4e-3])
    monkeypatch.setattr(field, "best", lambda points, radius=1: (np.zeros((len(points), 2, 5)), teacher))
    monkeypatch.setattr(distill, "student_velocity", lambda student_, points: student)

    def holes(floor):
        config = DistillConfig(hole_probes=5, hole_floor=floor)
        found, probe = distill.find_holes(None, field, config, np.random.default_rng(0))
        return probe["holes"]

    assert holes(1e-3) == 1  # 3 mm/s short of 20; a stall where the teacher moves at 0.7 mm/s is not seen
    assert holes(1e-4) == 3  # ... now it is, and 0.6 mm/s short of 5 too; 0.05 of 0.7 and 0.5 of 20 are not
    with pytest.raises(ValueError, match="hole_floor"):
        DistillConfig(hole_floor=-1e-3)


def test_at_a_stall_probe_a_student_that_stalls_where_the_teacher_crawls_is_a_hole(monkeypatch):
    from mdr_drive_agents.student import distill

    field = synthetic_field()
    field.velocities[:] = np.linspace(1.0, -1.0, 5)  # every k line stalls halfway
    # 2 random probes, then 3 stall probes; the teacher crawls at 0.05 mm/s at the last four
    teacher = np.array([20e-3, 0.05e-3, 0.05e-3, 0.05e-3, -0.01e-3])
    student = np.array([20e-3, -0.01e-3, -0.01e-3, 0.04e-3, -0.02e-3])
    monkeypatch.setattr(field, "best", lambda points, radius=1: (np.zeros((len(points), 2, 5)), teacher[:len(points)]))
    monkeypatch.setattr(distill, "student_velocity", lambda student_, points: student[:len(points)])
    config = DistillConfig(hole_probes=2, hole_floor=1e-4, stall_probes=3)
    found, probe = distill.find_holes(None, field, config, np.random.default_rng(0))
    # the random probe 1 is no hole (0.06 mm/s under the floor); stall probe 2 is; 3 moves; 4: neither moves
    assert probe["probes"] == 5 and probe["holes"] == 1 and probe["stall_holes"] == 1 and len(found) == 1
    no_stall = distill.find_holes(None, field, DistillConfig(hole_probes=2, hole_floor=1e-4), np.random.default_rng(0))
    assert no_stall[1]["holes"] == 0 and "stall_holes" not in no_stall[1]
    for bad, match in (((1.0, 0.9), r"stall_band\[1\]"), ((0.0, 1.0), r"stall_band\[0\]"), ((0.9,), "stall_band")):
        with pytest.raises(ValueError, match=match):
            DistillConfig(stall_band=bad)
    with pytest.raises(ValueError, match="stall_probes"):
        DistillConfig(stall_probes=-1)
    with pytest.raises(ValueError, match="stall_probes"):
        distill.find_holes(None, field, config, np.random.default_rng(0), friction=((0.2, 0.4), (0.1, 0.2)))


def test_focus_points_add_round_0_episodes_in_their_k_band_and_leave_the_default_draw_unchanged(monkeypatch):
    from mdr_drive_agents.student import distill as distill_module
    from mdr_drive_agents.student.data import draw_points

    teacher = StepTeacher()
    config = DistillConfig(load_factor=1.7, no_load_share=0.0)
    band = draw_points(teacher, 200, np.random.default_rng(1), config, k_range=(0.22, 0.32))
    ks = np.array([p[0] for p in band])
    assert ks.min() >= 0.22 and ks.max() <= 0.32 and ks.max() - ks.min() > 0.08
    loads = np.array([p[1] for p in band])
    assert loads.min() >= 0.0 and loads.max() <= 1.7 * 0.1 and loads.max() > 0.15  # loads drawn as for `points`
    clipped = draw_points(teacher, 50, np.random.default_rng(1), config, k_range=(0.5, 0.9))  # clipped to the field
    assert max(p[0] for p in clipped) <= 0.6
    with pytest.raises(ValueError, match=r"k range \[0.7, 0.9\] lies outside the teacher's k range \[0, 0.6\]"):
        draw_points(teacher, 5, np.random.default_rng(1), config, k_range=(0.7, 0.9))
    a = draw_points(teacher, 20, np.random.default_rng(2), config)
    assert a == draw_points(teacher, 20, np.random.default_rng(2), config, k_range=None)

    seen = []  # the points round 0 asks the teacher about
    real = distill_module.teacher_drives
    monkeypatch.setattr(distill_module, "teacher_drives", lambda f, pts, c: (seen.append(list(pts)), real(f, pts, c))[1])
    tiny = dict(net_arch=(8,), points=12, periods=2, steps=2, batch=8)
    hyper = {"n_envs": 2, "n_steps": 8, "batch_size": 16}
    plain = distill_module.distill(teacher, DistillConfig(**tiny), 0, hyperparameters=hyper, progress=False)
    focused = distill_module.distill(teacher, DistillConfig(**tiny, focus_points=6, focus_k=(0.22, 0.32)), 0,
                                     hyperparameters=hyper, progress=False)
    assert [len(s) for s in seen] == [12, 18]
    assert seen[1][:12] == seen[0]  # the uniform draw is the same; the band's points follow it
    assert all(0.22 <= p[0] <= 0.32 for p in seen[1][12:])
    assert plain.history[0]["samples"] == 12 * 2 and focused.history[0]["samples"] == 18 * 2
    inner = distill_module.distill(teacher, DistillConfig(**tiny, focus_points=6, focus_k=(0.22, 0.32),
                                                          inner_focus_points=4, inner_focus_k=(0.25, 0.27)), 0,
                                   hyperparameters=hyper, progress=False)
    assert len(seen[2]) == 22 and seen[2][:18] == seen[1]  # the second band's points follow the first's
    assert all(0.25 <= p[0] <= 0.27 for p in seen[2][18:]) and inner.history[0]["samples"] == 22 * 2
    for bad in ({"focus_k": (0.7, 0.9)}, {"inner_focus_points": 3, "inner_focus_k": (0.7, 0.9)}):
        with pytest.raises(ValueError, match="lies outside the teacher's k range"):  # before any work
            distill_module.distill(teacher, DistillConfig(**tiny, **{"focus_points": 6, **bad}), 0,
                                   hyperparameters=hyper, progress=False)
    assert len(seen) == 3


@pytest.mark.parametrize("bad, name", [({"focus_points": -1}, "focus_points"), ({"focus_k": (0.3, 0.2)}, "focus_k[1]"),
                                       ({"focus_k": (0.1,)}, "focus_k"), ({"focus_k": (-0.1, 0.2)}, "focus_k[0]"),
                                       ({"inner_focus_points": -1}, "inner_focus_points"),
                                       ({"inner_focus_k": (0.3, 0.2)}, "inner_focus_k[1]")])
def test_a_bad_focus_option_is_an_error_naming_it(bad, name):
    with pytest.raises(ValueError, match=re.escape(name)):
        DistillConfig(**bad)


def test_quantum_centres_must_be_a_boolean():
    with pytest.raises(ValueError, match=r"quantum_centres='yes' must be true or false"):
        DistillConfig(quantum_centres="yes")
    assert DistillConfig(quantum_centres=True).quantum_centres is True


@pytest.mark.parametrize("hole_dagger", [False, True])
def test_a_hole_round_adds_the_teachers_episodes_and_with_hole_dagger_the_students_labelled_by_the_teacher(
        monkeypatch, hole_dagger):
    from types import SimpleNamespace

    from mdr_drive_agents.student import distill

    field = synthetic_field()
    drives = np.arange(3 * 10, dtype=float).reshape(3, 2, 5) / 100.0
    calls = []
    monkeypatch.setattr(distill, "find_holes", lambda *a, **k: ([(0.2, 0.01)], {"probes": 4, "holes": 1}))
    monkeypatch.setattr(distill, "teacher_drives", lambda field_, points, config: (drives[:len(points)], None))

    def episodes(field_, points, act, config, seed, z_phase_origin, time_quantum, drives=None):
        calls.append((act, drives))
        return np.full((len(points), 14), len(calls), dtype=np.float32), drives

    monkeypatch.setattr(distill, "labelled_episodes", episodes)
    monkeypatch.setattr(distill, "fit", lambda student, obs, drive, *a, **k: float(len(obs)))
    student = SimpleNamespace(act=lambda obs: obs[:, :5], z_phase_origin=0.0, time_quantum=5e-6)
    obs_all, drive_all = [np.zeros((5, 14), dtype=np.float32)], [np.zeros((5, 2, 5))]
    config = DistillConfig(hole_neighbours=2, hole_dagger=hole_dagger)
    record = distill.hole_round(student, field, config, 1, np.random.default_rng(0), 0, obs_all, drive_all)
    assert [act for act, _ in calls] == ([None, student.act] if hole_dagger else [None])
    for _, given in calls:  # the hole and its two neighbours, each labelled with its own teacher drive
        assert given is not None and np.array_equal(given, drives)
    assert len(obs_all) == len(drive_all) == (3 if hole_dagger else 2)
    assert record["samples"] == 5 + 3 * len(calls) and record["loss"] == record["samples"]
    with pytest.raises(ValueError, match=r"hole_dagger='yes' must be true or false"):
        DistillConfig(hole_dagger="yes")
