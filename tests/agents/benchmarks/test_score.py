"""The normalised score and its rliable-style aggregates."""

import numpy as np
import pytest
from scipy import stats

from mdr_drive_agents.benchmarks.score import SCORE_MIN_GAP, aggregate, format_aggregate, iqm, normalized_scores


def test_the_trapezoid_scores_0_the_best_drive_1_and_a_runaway_as_a_stalled_drive():
    trap = np.array([10e-3, 10e-3, 10e-3, 10e-3, np.nan, 5e-3])
    best = np.array([20e-3, 20e-3, 30e-3, 10e-3 + SCORE_MIN_GAP / 2, 8e-3, 20e-3])
    learned = np.array([10e-3, 20e-3, 40e-3, 15e-3, 4e-3, np.nan])
    scores = normalized_scores(trap, best, learned)
    np.testing.assert_allclose(scores[[0, 1, 2, 4, 5]], [0.0, 1.0, 1.5, 0.5, -5 / 15])
    assert np.isnan(scores[3])  # the best drive barely beats the trapezoid: not scored
    with pytest.raises(ValueError, match="differ in shape"):
        normalized_scores(trap, best, learned[:3])


def test_the_iqm_is_the_25_percent_trimmed_mean():
    x = np.random.default_rng(0).normal(size=(101,)) ** 3
    assert iqm(x) == pytest.approx(stats.trim_mean(x, 0.25), rel=1e-12)
    assert iqm([1.0, 2.0, 3.0, 100.0]) == 2.5


def test_the_intervals_are_reproducible_cover_the_estimate_and_shrink_with_more_points():
    rng = np.random.default_rng(1)
    small, large = rng.normal(1.0, 0.2, 50), rng.normal(1.0, 0.2, 5000)
    a = aggregate([small])
    assert a == aggregate([small]) and a["scores"] == 50
    for name in ("iqm", "mean"):
        value, low, high = a[name]
        assert low <= value <= high
    width = lambda agg: agg["mean"][2] - agg["mean"][1]  # noqa: E731
    assert width(aggregate([large])) < width(a) / 5
    # the mean's interval is the normal one for a large sample: +-1.96 sigma / sqrt(n)
    assert width(aggregate([large])) == pytest.approx(2 * 1.96 * 0.2 / np.sqrt(5000), rel=0.1)


def test_each_stratum_is_resampled_on_its_own():
    low, high = np.zeros(30), np.ones(30)
    agg = aggregate([low, high])  # every resample holds 30 zeros and 30 ones
    assert agg["mean"] == [0.5, 0.5, 0.5]
    pooled = aggregate([np.concatenate([low, high])])  # one stratum: the mix varies
    assert pooled["mean"][1] < 0.5 < pooled["mean"][2]


def test_nothing_scored_is_said_not_averaged():
    agg = aggregate([np.array([np.nan, np.nan])])
    assert agg == {"iqm": None, "mean": None, "scores": 0} and format_aggregate(agg) == "-"
    assert "IQM 1.000 [1.000, 1.000]" in format_aggregate(aggregate([np.ones(4)]))
