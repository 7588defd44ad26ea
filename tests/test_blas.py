"""mdr_drive_env.blas: numpy's BLAS kernels pinned before numpy loads (same CMA-ES drives on every x86-64 CPU)."""

import os
import subprocess
import sys

import pytest

from mdr_drive_env.blas import PINNED_CORE, _cpu_has_avx2_and_fma, pin_blas_kernels

SHOW = "import os; from mdr_drive_env.blas import blas_core; print(os.environ.get('OPENBLAS_CORETYPE'), blas_core())"


def _run(code: str, env: dict) -> list[str]:
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout.split()


@pytest.mark.skipif(not (sys.platform.startswith("linux") and _cpu_has_avx2_and_fma()), reason="x86-64 Linux with AVX2/FMA")
def test_importing_the_package_first_pins_the_kernels_and_numpy_first_does_not():
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    assert _run("import mdr_drive_env; " + SHOW, env) == [PINNED_CORE, PINNED_CORE]
    assert _run("import mdr_drive_agents; " + SHOW, env) == [PINNED_CORE, PINNED_CORE]
    assert _run("import numpy, mdr_drive_env; " + SHOW, env)[0] == "None"  # numpy first: its kernels stay its own
    # a user's own choice is left alone
    assert _run("import mdr_drive_env; " + SHOW, {**env, "OPENBLAS_CORETYPE": "Sandybridge"}) == ["Sandybridge", "Sandybridge"]


def test_the_pin_never_changes_a_loaded_numpy():
    assert "numpy" in sys.modules
    assert pin_blas_kernels() is False
