import os

import numpy as np
import pytest
from hypothesis import settings

from mdr_drive_env.core import Numerics

# Property tests draw the same examples on every run (a gate must not pass or fail by the draw);
# HYPOTHESIS_PROFILE=explore draws new ones, to look for failures worth pinning with @example.
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

#: Coarse numerics for tests (the `default` preset's resolution).
COARSE = Numerics(time_step=1e-6, spring_spacing=1e-7)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
