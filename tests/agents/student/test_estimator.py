"""The estimator's score (mdr_drive_agents.student.estimator)."""

import numpy as np
import pytest

pytest.importorskip("torch")

from mdr_drive_agents.student.estimator import standardised_error  # noqa: E402


def test_the_standardised_error_is_zero_when_exact_one_for_the_mean_and_blind_to_units():
    truth = np.random.default_rng(1).normal(size=(500, 3)) * [1.0, 10.0, 0.1]
    assert np.allclose(standardised_error(truth, truth), 0.0)
    assert np.allclose(standardised_error(np.broadcast_to(truth.mean(axis=0), truth.shape), truth), 1.0)
    noisy = truth + np.random.default_rng(2).normal(size=truth.shape) * truth.std(axis=0) * 0.5
    assert np.allclose(standardised_error(noisy, truth), 0.5, atol=0.05)
    assert np.allclose(standardised_error(noisy * 1e3, truth * 1e3), standardised_error(noisy, truth))
