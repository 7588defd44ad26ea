"""What every training command records about its run, and how it starts one.

A run's ``run.json`` (``mdr_drive_agents.policy``) says how the policy was made: the command line
(``command_line``), the package versions (``versions``), and the program's own settings, in one
layout (``policy_record``); a command
refuses an output folder that holds something unless told to continue or overwrite it
(``start_run``), and one that another command is writing into (``RunLock``).
"""

from __future__ import annotations

import dataclasses
import os
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


def policy_record(*, algo: str, seed: int, env_id: str, env_kwargs: dict, hyperparameters: dict, torch_threads: int,
                  wall_time_s: float, interrupted: bool = False, total_timesteps: int = 0, steps_this_run: int = 0,
                  steps_per_s_this_run: float = 0.0, resumes: int = 0, command: str | None = None,
                  drive: dict | None = None, **extra) -> dict:
    """A policy's ``run.json``, as every command that writes a policy records it: what ``load_policy``,
    ``evaluate`` and ``train --resume`` read (the algorithm, the env and its keywords, the SB3
    settings), how long it trained (``total_timesteps`` env steps, 0 for a policy fitted without RL;
    ``wall_time_s`` s), the command line and the package versions; ``drive``: the drive description
    it was built for (``DriveDescription.to_record``); ``extra``: the command's own keys (where the
    policy came from, its fit history, ...)."""
    return {**({} if drive is None else {"drive": drive}),
            "algo": algo, "seed": seed, "env_id": env_id, "env_kwargs": env_kwargs, "hyperparameters": hyperparameters,
            **extra, "command": command_line() if command is None else command, "versions": versions(),
            "torch_threads": torch_threads, "total_timesteps": int(total_timesteps), "steps_this_run": int(steps_this_run),
            "wall_time_s": wall_time_s, "steps_per_s_this_run": steps_per_s_this_run, "resumes": resumes,
            "interrupted": interrupted}


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


class RunLock:
    """One writer per output folder: ``with RunLock(out):`` holds an exclusive lock on ``out/.lock``
    for as long as the block runs (the kernel releases it when the process ends, however it ends);
    a second command on the same folder gets a ``ValueError`` at once."""

    def __init__(self, out: str | Path):
        self.path = Path(out) / ".lock"
        self.file = None

    def __enter__(self) -> "RunLock":
        import fcntl

        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.file = open(self.path, "a+")
        try:
            fcntl.flock(self.file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.file.seek(0)
            holder = self.file.read().strip() or "another process"
            self.file.close()
            raise ValueError(f"{self.path.parent} is being written by {holder}: wait for it to end, or write into "
                             "another folder") from None
        self.file.seek(0)
        self.file.truncate()
        self.file.write(f"process {os.getpid()} ({command_line()})")
        self.file.flush()
        return self

    def __exit__(self, *exc) -> bool:
        self.file.close()  # releases the lock; the file stays (harmless, and no race on removing it)
        return False


__all__ = ["RunLock", "command_line", "policy_record", "start_run", "versions"]
