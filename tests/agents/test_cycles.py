"""Two-action cycles (agents/cycles.py): the phase a drive is written in, and the action that follows."""

from __future__ import annotations

import numpy as np

from mdr_drive_agents.cycles import align_phase, cycle_action, swap_is_closer

PUSH, CLAMP = [1.0, 0, 0, 0, 0], [-1.0, 0, 0, 0, 0]


def test_cycle_labels_follow_the_previous_action():
    drives = np.array([[PUSH, CLAMP]] * 3)
    prev = np.array([[0.0] * 5, [0.9, 0, 0, 0, 0], [-0.9, 0, 0, 0, 0]])
    labels = cycle_action(drives, prev)
    assert labels[:, 0].tolist() == [1.0, -1.0, 1.0]  # start: first; after the first: second; after it: first


def test_a_fixed_drive_plays_its_action_after_anything():
    fixed = np.array([[[0.3, -0.2, 0.5, 0.1, 0.9]] * 2] * 3)
    prev = np.array([[0.0] * 5, [0.3, -0.2, 0.5, 0.1, 0.9], [-1.0] * 5])
    assert np.array_equal(cycle_action(fixed, prev), fixed[:, 0])


def test_a_drive_is_aligned_to_the_phase_closest_to_its_reference():
    drive = np.array([PUSH, CLAMP])
    assert np.array_equal(align_phase(drive[::-1], drive), drive)
    assert np.array_equal(align_phase(drive, drive), drive)
    # pair by pair: only the pairs written in the other phase are swapped
    drives, references = np.stack([drive, drive[::-1]]), np.stack([drive, drive])
    assert swap_is_closer(drives, references).tolist() == [False, True]
    assert np.array_equal(align_phase(drives, references), references)
