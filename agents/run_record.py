"""What every training command records about its run, and how it starts one.

A run's ``run.json`` (``mdr_drive_agents.policy``) says how the policy was made: the command line
(``command_line``), the package versions (``versions``), and the program's own settings; a command
refuses an output folder that holds something unless told to continue or overwrite it
(``start_run``).
"""

from __future__ import annotations

import dataclasses
import platform
import sys
from pathlib import Path


def versions() -> dict[str, str]:
    """The versions of Python and of the packages a policy depends on."""
    import gymnasium
    import numba
    import numpy as np
    import stable_baselines3
    import torch

    import mdr_drive_env

    return {"python": platform.python_version(), "mdr_drive": mdr_drive_env.__version__, "torch": torch.__version__,
            "stable_baselines3": stable_baselines3.__version__, "gymnasium": gymnasium.__version__,
            "numba": numba.__version__, "numpy": np.__version__}


def command_line() -> str:
    """The command line that runs this process, ``mdr-drive ...`` when it is the ``mdr-drive`` command."""
    if Path(sys.argv[0]).name == "mdr-drive":
        return " ".join(["mdr-drive", *sys.argv[1:]])
    return " ".join(sys.argv)


def start_run(out: str | Path, resume: bool, force: bool, executor=None, progress: bool = True):
    """A training command's output folder (``ValueError`` if it is not empty, unless ``resume`` or
    ``force``) and its executor (default: local processes; no progress bars unless ``progress``)."""
    from mdr_drive_env.sweep import Executor

    out = Path(out)
    if out.exists() and any(out.iterdir()) and not (resume or force):
        raise ValueError(f"{out} is not empty: continue with --resume, or overwrite with --force")
    executor = executor or Executor()
    return out, executor if progress else dataclasses.replace(executor, progress=False)


__all__ = ["command_line", "start_run", "versions"]
