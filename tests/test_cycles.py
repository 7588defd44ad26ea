"""Two-action cycles (agents/cycles.py): the phase a drive is written in, and the action that follows."""

from __future__ import annotations

import numpy as np

import pytest

from mdr_drive_agents.cycles import align_phase, cycle_action, grid_phases, swap_is_closer
from mdr_drive_agents.drive_field import DriveField, FieldConfig

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


# Three cycles: on a k line, A then D; a new drive N between them is written in the phase closest
# to A, and D, aligned to N, lands in the other phase than D aligned to A.
CYCLE_A = [[-0.5, -1.0, 0.3, 0.4, 0.7], [-0.4, -0.6, 0.3, 0.6, 0.9]]
CYCLE_N = [[-0.7, 0.0, 0.8, -0.2, 0.2], [-1.0, 0.3, 0.8, 0.7, 0.8]]
CYCLE_D = [[0.3, -0.5, 0.5, -0.6, 0.7], [-0.9, 0.7, -0.7, -0.2, -0.4]]


def _grid_with_a_new_drive() -> DriveField:
    """Three k lines of six loads, A at the two lightest and D at the heavier nodes; the middle line
    holds the new drive N at load node 2."""
    drives = np.array([[CYCLE_A] * 2 + [CYCLE_D] * 4] * 3)
    drives[1, 2] = CYCLE_N
    return DriveField(np.linspace(0.0, 0.1, 3), np.linspace(0.0, 1.0, 6), np.full(3, 0.1), drives,
                      np.ones((3, 6)))


def test_one_new_drive_flips_its_k_lines_heavier_nodes_along_the_load_but_not_over_the_grid():
    along_load, grid = _grid_with_a_new_drive(), _grid_with_a_new_drive()
    along_load.align()  # each line from its lighter node: the middle line's D follow N's phase
    assert np.array_equal(along_load.drives[0, 3:], along_load.drives[2, 3:])
    assert np.array_equal(along_load.drives[1, 3:], along_load.drives[0, 3:, ::-1])
    grid.align_grid()  # over the grid: the k neighbours holding the same cycle decide
    assert np.array_equal(grid.drives[1, 3:], grid.drives[0, 3:])
    assert np.array_equal(grid.drives[1, 3:], grid.drives[2, 3:])


def _one_cycle_grid(nk: int, ns: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A grid holding one cycle at every node (each with a little noise) in one phase. Returns
    (drives, the cycle)."""
    rng = np.random.default_rng(seed)
    cycle = rng.uniform(-1.0, 1.0, (2, 5))
    return cycle + 0.02 * rng.standard_normal((nk, ns, 2, 5)), cycle


def test_align_grid_only_swaps_cycles_and_is_stable():
    drives, cycle = _one_cycle_grid(nk=4, ns=5, seed=3)
    drives[2] = drives[2][:, ::-1]  # a whole k line written in the other phase
    drives[1, 3] = drives[1, 3, ::-1]  # and one node
    velocities = np.arange(20.0).reshape(4, 5)
    field = DriveField(np.linspace(0.0, 0.3, 4), np.linspace(0.0, 1.0, 5), np.full(4, 0.1), drives.copy(),
                       velocities.copy())
    assert field.align_grid() == 6  # the k line and the new drive
    same = np.all(field.drives == drives, axis=(2, 3))
    swapped = np.all(field.drives == drives[:, :, ::-1], axis=(2, 3))
    assert (same | swapped).all() and np.array_equal(field.velocities, velocities)
    assert np.abs(field.drives - cycle).max() < 0.1  # every node now in the cycle's phase (noise 0.02)
    assert field.align_grid() == 0 and field.meta["phases_swapped"] == 0


def test_a_fixed_drive_has_no_phase_to_follow():
    fixed = np.array([[0.3, -0.2, 0.5, 0.1, 0.9]] * 2)
    drives = np.broadcast_to(fixed, (2, 3, 2, 5)).copy()
    assert not grid_phases(drives).any()


def test_an_unknown_phase_rule_is_refused_by_name():
    with pytest.raises(ValueError, match="phases='lighter'"):
        FieldConfig(phases="lighter")
