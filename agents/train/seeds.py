"""Several training seeds as one sweep (``mdr-drive train --seeds 0 1 2``), on local processes or Ray.

Each seed is one task: it trains in a temporary folder of whichever machine runs it and returns the
folder as a compressed tar archive, which is unpacked into ``OUT/s<seed>`` here (into a temporary
folder first, then renamed: a half-unpacked run never appears). A seed whose folder already holds a
finished run (``run.json`` not marked interrupted) is not trained again, so a sweep stopped by
Ctrl-C or a lost node continues by running the same command; ``--force`` retrains every seed.
"""

from __future__ import annotations

import io
import json
import shutil
import sys
import tarfile
import tempfile
from pathlib import Path
from typing import Any

from mdr_drive_env.files import write_text


def train_seed_task(kwargs: dict[str, Any]) -> bytes:
    """Train one run with ``mdr_drive_agents.train.sb3.train(**kwargs)`` in a temporary folder; returns
    the folder as a .tar.gz archive (bytes)."""
    from .sb3 import train

    with tempfile.TemporaryDirectory(prefix="mdr-drive-seed-") as tmp:
        run = Path(tmp) / "run"
        train(**{**kwargs, "out": run, "progress_bar": False, "force": True})
        buffer = io.BytesIO()
        with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
            tar.add(run, arcname=".")
        return buffer.getvalue()


def finished(folder: Path) -> bool:
    """Whether ``folder`` holds a run that was not interrupted."""
    try:
        return not json.loads((folder / "run.json").read_text()).get("interrupted", False)
    except (OSError, ValueError):
        return False


def unpack(archive: bytes, folder: Path) -> None:
    """Unpack a run archive into ``folder`` (replacing it), through a temporary sibling folder."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=folder.parent))
    try:
        with tarfile.open(fileobj=io.BytesIO(archive), mode="r:gz") as tar:
            tar.extractall(tmp, filter="data")
        if folder.exists():
            shutil.rmtree(folder)
        tmp.rename(folder)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def train_seeds(seeds: list[int], out: str | Path, executor, force: bool = False, **train_kwargs) -> dict[int, Path]:
    """Train one run per seed into ``out/s<seed>`` on ``executor`` (``mdr_drive_env.sweep``); seeds
    with a finished run there are kept unless ``force``. Returns {seed: folder}."""
    out = Path(out)
    folders = {s: out / f"s{s}" for s in seeds}
    todo = [s for s in seeds if force or not finished(folders[s])]
    for s in sorted(set(seeds) - set(todo)):
        print(f"train: seed {s} is already trained in {folders[s]} (--force trains it again)")
    tasks = [{**train_kwargs, "seed": s} for s in todo]

    command = " ".join(sys.argv)

    def keep(i: int, archive: bytes) -> None:
        folder = folders[todo[i]]
        unpack(archive, folder)
        run = json.loads((folder / "run.json").read_text())  # the worker's argv is not the command
        write_text(folder / "run.json", json.dumps({**run, "command": command}, indent=2))

    executor.map(train_seed_task, tasks, f"training seeds {todo}", on_result=keep)
    return folders


__all__ = ["finished", "train_seed_task", "train_seeds", "unpack"]
