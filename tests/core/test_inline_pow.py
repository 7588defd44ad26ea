"""The fast kernel's inline ``x ** y`` (core/inline_pow.py) against NumPy's, and the depth block
that uses it against the closed-form normal force."""

import numpy as np
import pytest
from numba import njit

from mdr_drive_env.core.fast_kernel import STEP_BLOCK, _depth_block, normal_force
from mdr_drive_env.core.inline_pow import exp_moderate, log_positive, pow_positive


@njit(cache=True)
def _pow_all(x, y, out):
    for i in range(x.size):
        out[i] = pow_positive(x[i], y[i])


def test_pow_positive_matches_numpy_to_a_few_ulp():
    rng = np.random.default_rng(0)
    x = 10.0 ** rng.uniform(-12.0, 3.0, 200_000)
    y = rng.uniform(0.0, 3.0, x.size)
    out = np.empty_like(x)
    _pow_all(x, y, out)
    assert np.max(np.abs(out / x**y - 1.0)) < 1e-13
    # the kernel's range: x = a^2 = (1+k) R d (m^2), y = (k+1)/2
    x = 10.0 ** rng.uniform(-11.0, -6.0, 200_000)
    y = rng.uniform(0.5, 1.0, x.size)
    _pow_all(x, y, out)
    assert np.max(np.abs(out / x**y - 1.0)) < 5e-15


@pytest.mark.parametrize("x", [1.0, 2.0, 0.5, np.sqrt(2.0), np.nextafter(np.sqrt(2.0), 0.0), 1e-300, 1e300])
def test_log_and_exp_at_range_reduction_edges(x):
    assert log_positive(x) == pytest.approx(np.log(x), rel=1e-15, abs=1e-16)


@pytest.mark.parametrize("y", [0.0, 0.5 * np.log(2.0), -0.5 * np.log(2.0), 1e-20, -30.0, 30.0, 700.0, -700.0])
def test_exp_at_range_reduction_edges(y):
    assert exp_moderate(y) == pytest.approx(np.exp(y), rel=2e-16 * 4)


def test_depth_block_gives_paper_eq8_normal_force():
    k, radius, c_n, c0k = 0.3, 2.5e-3, 1.1e11, 1.0
    s = (1.0 + k) * radius
    za, zb, n = -1e-6, 6e-6, 40  # a segment that starts out of contact
    d, a1, fz = np.empty(STEP_BLOCK), np.empty(STEP_BLOCK), np.empty(STEP_BLOCK)
    _depth_block(za, (zb - za) / n, zb, 0, n, n, s, 0.5 * (k + 1.0), c_n * 2.0 / c0k, 1.0 / (k + 1.0),
                 1.0 / (s * (k + 3.0)), d, a1, fz)
    expected_d = za + np.arange(1, n + 1) * ((zb - za) / n)
    expected_d[-1] = zb
    np.testing.assert_array_equal(d[:n], expected_d)
    expected = np.array([normal_force(v, c_n, k, s, c0k) for v in expected_d])
    np.testing.assert_allclose(fz[:n], expected, rtol=1e-13, atol=0.0)
    assert np.all(fz[:n][expected_d <= 0.0] == 0.0)
