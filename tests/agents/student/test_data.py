"""The student's data (mdr_drive_agents.student.data): points, episodes and labels of the teacher."""

from __future__ import annotations


import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.student.distill import DistillConfig
from tests.agents.fields import StepTeacher, friction_field, synthetic_field

def test_a_student_in_a_finer_time_quantum_env_is_played_and_probed_there():
    from mdr_drive_agents.student.distill import student_velocity
    from mdr_drive_agents.student.network import make_student
    from mdr_drive_agents.student.data import rollout

    student = make_student((8,), "relu", -3.0, 0, {"time_quantum": 5e-6}, {"n_envs": 2, "n_steps": 8, "batch_size": 16})
    assert student.time_quantum == 5e-6
    assert student.venv.venv.get_attr("action_map")[0].time_quantum == 5e-6
    on = np.array([0.5, 0.2 + 2.0 / 180, 0.8, 0.1, 0.3])
    off = on + np.array([0.0, 0.8 / 180, 0.0, 0.0, 0.0])  # 0.4 of a 10 us rise quantum: a 5 us one apart
    point = [(0.2, 0.1)]
    coarse = [rollout(point, np.zeros((1, 2, 5)), lambda obs, a=a: a[None], 6)[2] for a in (on, off)]
    fine = [rollout(point, np.zeros((1, 2, 5)), lambda obs, a=a: a[None], 6, time_quantum=5e-6)[2] for a in (on, off)]
    np.testing.assert_array_equal(coarse[0], coarse[1])
    assert not np.array_equal(fine[0], fine[1])
    student.act = lambda obs: np.tile(off, (len(obs), 1))  # the hole round measures it in its own env
    np.testing.assert_allclose(student_velocity(student, point)[0],
                               rollout(point, np.zeros((1, 2, 5)), student.act, 30, time_quantum=5e-6)[2][-10:].mean() / 2e-3)


def test_drive_difference_compares_cycles_in_their_closest_phase():
    from mdr_drive_agents.student.data import drive_difference

    A, B = StepTeacher.A[None], StepTeacher.B[None]
    assert drive_difference(B, B[:, ::-1])[0] == 0.0
    # align_phase pair by pair: each drive in the cycle phase of its own reference
    pairs = np.concatenate([B[:, ::-1], A, A[:, ::-1]])
    assert np.array_equal(align_phase(pairs, np.concatenate([B, A, A])), np.concatenate([B, A, A]))
    assert drive_difference(A, A + 0.05)[0] == pytest.approx(0.05)
    assert drive_difference(A, B)[0] == pytest.approx(np.abs(StepTeacher.A - StepTeacher.B).max())


def test_jump_points_bisect_towards_where_the_teachers_drive_jumps():
    from mdr_drive_agents.student.data import drive_difference, jump_points

    rng = np.random.default_rng(3)
    points = [(float(k), float(m)) for k, m in zip(rng.uniform(0.0, 0.6, 400), rng.uniform(0.0, 0.17, 400))]
    teacher = StepTeacher()
    drives, _ = teacher.best(points)
    config = DistillConfig(jump_levels=3, jump_neighbours=6, load_factor=1.7)
    new_points, new_drives = jump_points(teacher, points, drives, config)
    assert teacher.calls == 1 + 3 and len(new_points) == len(new_drives) > 0
    # the pairs that straddle k = 0.3, in the nearest-neighbour graph, as the bisection's brackets
    ks = np.array([p[0] for p in points])
    widest = max(abs(a - b) for a in ks for b in ks if (a < 0.3) != (b < 0.3) and abs(a - b) < 0.1)
    new_k = np.array([p[0] for p in new_points])
    assert np.all(np.abs(new_k - 0.3) <= widest / 2 + 1e-12)  # every midpoint is inside a straddling pair
    assert (new_k < 0.3).any() and (new_k >= 0.3).any()  # on both sides
    # the last level's points are 4 times closer to the jump than the first's
    assert np.median(np.abs(new_k[-len(new_k) // 4:] - 0.3)) < np.median(np.abs(new_k[:len(new_k) // 4] - 0.3)) / 2
    expected, _ = StepTeacher().best(new_points)
    assert np.array_equal(new_drives, expected)  # each added point carries the teacher's drive there
    assert drive_difference(drives[:1], drives[:1])[0] == 0.0
    # no jump: nothing is added and the teacher is not asked again
    flat = StepTeacher(jump=False)
    none, none_drives = jump_points(flat, points, flat.best(points)[0], config)
    assert none == [] and none_drives.shape == (0, 2, 5) and flat.calls == 1


def test_jump_brackets_end_with_pairs_that_straddle_the_jump_closely_and_carry_its_two_drives():
    from mdr_drive_agents.student.data import drive_difference, jump_brackets, jump_points

    rng = np.random.default_rng(4)
    points = [(float(k), float(m)) for k, m in zip(rng.uniform(0.0, 0.6, 300), rng.uniform(0.0, 0.17, 300))]
    config = DistillConfig(jump_levels=4, jump_neighbours=6, load_factor=1.7)
    drives = StepTeacher().best(points)[0]
    added, added_drives, (a, b, da, db) = jump_brackets(StepTeacher(), points, drives, config)
    same, same_drives = jump_points(StepTeacher(), points, drives, config)
    assert added == same and np.array_equal(added_drives, same_drives)  # jump_points is its first two
    assert len(a) == len(b) == len(da) == len(db) > 0
    assert np.all((a[:, 0] < 0.3) != (b[:, 0] < 0.3))  # every last bracket straddles the jump
    assert np.all(drive_difference(da, db) > config.jump_threshold)
    for ends, end_drives in ((a, da), (b, db)):  # each end carries its own drive (in either cycle phase)
        assert np.all(drive_difference(end_drives, StepTeacher().best([tuple(x) for x in ends])[0]) == 0.0)
    # four levels halve the brackets four times: every last bracket is within 1/16 of a neighbour pair
    assert np.abs(a[:, 0] - b[:, 0]).max() <= 0.1 / 16 + 1e-12


def test_friction_points_are_neighbours_by_what_changes_the_drive_not_by_their_load_in_kilograms():
    from mdr_drive_agents.student.data import neighbour_coordinates
    from mdr_drive_agents.teacher import FrictionField

    field = FrictionField([friction_field(0.06, ks=(0.0, 0.6)), friction_field(0.18, ks=(0.0, 0.6))])  # rho 0.2, 0.6
    plain = neighbour_coordinates(field, np.array([[0.3, 0.05], [0.6, 0.0]]), 2.0)
    np.testing.assert_allclose(plain, [[0.5, 0.5], [1.0, 0.0]])  # k over its range, load over 2 x critical (0.05 kg)
    # the same k, load / mu and mu1 / mu: one point; the same load at twice mu: half as heavy
    pts = np.array([[0.3, 0.05, 0.3, 0.12], [0.3, 0.05 / 1.5, 0.2, 0.08], [0.3, 0.05, 0.6, 0.24], [0.3, 0.05, 0.3, 0.06]])
    coords = neighbour_coordinates(field, pts, 2.0)
    np.testing.assert_allclose(coords[0], [0.5, 0.5, 0.5])
    np.testing.assert_allclose(coords[1], coords[0])
    np.testing.assert_allclose(coords[2], [0.5, 0.25, 0.5])
    np.testing.assert_allclose(coords[3], [0.5, 0.5, 0.0])  # mu1 / mu = 0.2: the low end of the fields' ratios


def test_quantum_centres_label_the_student_with_the_teachers_waveforms_at_their_quanta_centres():
    from mdr_drive_agents.student.data import labelled_episodes
    from mdr_drive_agents.protocol import ACTION_MAP

    points = [(0.1, 0.02), (0.4, 0.005)]
    teacher = StepTeacher()
    drives = teacher.best(points)[0]
    _, plain = labelled_episodes(teacher, points, None, DistillConfig(periods=2), 0)
    _, centred = labelled_episodes(teacher, points, None, DistillConfig(periods=2, quantum_centres=True), 0)
    assert np.array_equal(plain, np.tile(drives, (2, 1, 1)))
    assert np.array_equal(centred, ACTION_MAP.quantum_centre(plain)) and not np.array_equal(centred, plain)
    same = ACTION_MAP.to_params_batch(plain.reshape(-1, 5)) == ACTION_MAP.to_params_batch(centred.reshape(-1, 5))
    assert same.all()


def test_stall_points_lie_in_their_band_around_the_zero_crossing_of_each_k_lines_velocity():
    from mdr_drive_agents.student.data import stall_fractions, stall_points

    field = synthetic_field(nk=3, ns=4)  # fractions 0, 0.4, 0.8, 1.2; k lines 0, 0.3, 0.6
    field.trapezoid_critical[:] = [0.02, 0.04, 0.08]
    field.velocities[:] = [[3.0, 2.0, 1.0, -3.0],     # crosses zero a quarter of the way from 0.8 to 1.2
                           [-1.0, -2.0, -3.0, -4.0],  # moves nowhere
                           [3.0, 2.0, 2.0, 1.0]]      # moves everywhere: its heaviest fraction
    assert np.allclose(stall_fractions(field), [0.9, 0.0, 1.2])
    points = np.array(stall_points(field, 400, np.random.default_rng(1), (0.9, 1.0)))
    stall = np.interp(points[:, 0], field.ks, [0.9 * 0.02, 0.0, 1.2 * 0.08])
    assert np.all((points[:, 0] >= 0.0) & (points[:, 0] <= 0.6))
    assert np.all(points[:, 1] >= 0.9 * stall - 1e-15) and np.all(points[:, 1] <= stall + 1e-15)
    assert points[:, 1].max() > 0.95 * 1.2 * 0.08 * 0.95  # the band is filled, not one load

