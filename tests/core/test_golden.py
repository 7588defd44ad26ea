"""Golden regression: a whole short run compared with the stored trace."""

import numpy as np
from tests.core.golden_run import GOLDEN, golden_run


def test_run_matches_golden_file():
    stored = np.load(GOLDEN)
    trace, periods = golden_run()
    assert trace.shape == stored["trace"].shape
    scale = np.abs(stored["trace"]).max(axis=0)  # per-column scale: t, x, z, X, V, F_x, F_z
    np.testing.assert_allclose(trace, stored["trace"], rtol=1e-7, atol=0)
    assert np.all(np.abs(trace - stored["trace"]) <= 1e-7 * scale)
    np.testing.assert_allclose(periods, stored["periods"], rtol=1e-7, atol=1e-12)
