"""mdr_drive_agents.blas: numpy's BLAS kernels pinned before numpy loads (same CMA-ES drives on every x86-64 CPU)."""

import os
import subprocess
import sys

import pytest

from mdr_drive_agents.blas import PINNED_CORE, _cpu_has_avx2_and_fma, pin_blas_kernels, pin_command

SHOW = "import os; from mdr_drive_agents.blas import blas_core; print(os.environ.get('OPENBLAS_CORETYPE'), blas_core())"
PINNABLE = sys.platform.startswith("linux") and _cpu_has_avx2_and_fma()


def _run(code: str, env: dict) -> list[str]:
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout.split()


@pytest.mark.skipif(not PINNABLE, reason="x86-64 Linux with AVX2/FMA")
def test_importing_the_agents_first_pins_the_kernels_and_the_physics_package_does_not():
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    assert _run("import mdr_drive_agents; " + SHOW, env) == [PINNED_CORE, PINNED_CORE]
    assert _run("import mdr_drive_env; " + SHOW, env)[0] == "None"  # the physics package leaves numpy alone
    assert _run("import numpy, mdr_drive_agents; " + SHOW, env)[0] == "None"  # numpy first: its kernels stay
    # a user's own choice is left alone
    assert _run("import mdr_drive_agents; " + SHOW, {**env, "OPENBLAS_CORETYPE": "Sandybridge"}) == ["Sandybridge",
                                                                                                    "Sandybridge"]


def test_the_pin_never_changes_a_loaded_numpy():
    assert "numpy" in sys.modules
    assert pin_blas_kernels() is False


@pytest.mark.skipif(not PINNABLE, reason="x86-64 Linux with AVX2/FMA")
def test_a_search_command_runs_with_the_pinned_kernels_though_the_cli_loads_numpy_first(tmp_path):
    """``mdr-drive recipe`` (and every CMA-ES command) starts again with the kernels pinned: its
    recipe.json records the kernels its teacher was searched with."""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    from tests import DATA

    mdr = os.path.join(os.path.dirname(sys.executable), "mdr-drive")
    subprocess.run([mdr, "recipe", str(DATA / "recipe_tiny.yaml"), "--out", str(tmp_path / "r"), "--no-progress",
                    "--workers", "1"], env=env, capture_output=True, text=True, check=True)
    import json

    assert json.loads((tmp_path / "r" / "recipe.json").read_text())["blas_core"] == PINNED_CORE


def test_a_process_that_is_not_the_command_is_never_started_again():
    pin_command()  # pytest is not mdr-drive: it returns, whatever the kernels
