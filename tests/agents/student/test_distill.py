"""The distillation's epoch (mdr_drive_agents.student.distill, ``epoch_samples``): what the student is fitted on."""

from __future__ import annotations

import numpy as np

from mdr_drive_agents.cycles import cycle_action
from mdr_drive_agents.student.distill import epoch_samples
from mdr_drive_env.gym_envs.spaces import ObservationLayout


def _episodes(n: int = 400, seed: int = 3):
    rng = np.random.default_rng(seed)
    obs = rng.normal(size=(n, 14)).astype(np.float32)
    drives = rng.uniform(-1.0, 1.0, (n, 2, 5))
    obs[:, ObservationLayout.structure["previous_action"]] = drives[:, 0]  # every sample just played its first action
    return obs, drives


def test_an_epoch_labels_each_sample_with_its_drives_next_action_and_keeps_the_point():
    obs, drives = _episodes()
    s = ObservationLayout.structure
    x, y = epoch_samples(obs, drives, np.random.default_rng(0), 0.5)
    assert np.array_equal(y, cycle_action(drives, x[:, s["previous_action"]]))
    for name in ("k", "load_over_friction", "load_over_10N"):
        assert np.array_equal(x[:, s[name]], obs[:, s[name]])  # the point is the sample's own
    perturbed = np.any(x[:, s["previous_action"]] != obs[:, s["previous_action"]], axis=1)
    assert 0.4 < perturbed.mean() < 0.6  # about the share asked for
    assert np.array_equal(y[~perturbed], drives[~perturbed, 1])  # unperturbed: the second action follows the first


def test_an_epoch_shuffles_the_slider_entries_across_samples_and_leaves_the_input_alone():
    obs, drives = _episodes()
    before = obs.copy()
    s = ObservationLayout.structure
    x, _ = epoch_samples(obs, drives, np.random.default_rng(0), 0.0)
    assert np.array_equal(obs, before)
    for column in range(*s["dynamics"].indices(14)):
        assert not np.array_equal(x[:, column], obs[:, column])
        assert np.array_equal(np.sort(x[:, column]), np.sort(obs[:, column]))  # a permutation of the column
    assert np.array_equal(x[:, s["previous_action"]], obs[:, s["previous_action"]])  # share 0: none perturbed
    for column in range(*s["episode_fraction"].indices(14)):
        assert np.array_equal(np.sort(x[:, column]), np.sort(obs[:, column]))
    # the same generator state gives the same epoch (the recipe's fit is reproducible)
    x2, y2 = epoch_samples(obs, drives, np.random.default_rng(0), 0.0)
    assert np.array_equal(x, x2)
