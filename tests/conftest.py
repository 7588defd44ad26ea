import numpy as np
import pytest

from mdr_drive_env.core import Numerics

#: Coarse numerics for tests (the `default` preset's resolution).
COARSE = Numerics(time_step=1e-6, spring_spacing=1e-7)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
