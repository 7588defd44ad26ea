"""``mdr-drive rl-baselines`` from its config to its outputs (``run``)."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import numpy as np

from mdr_drive_env.files import write_text
from mdr_drive_env.sweep import Executor, task_folder

from ..run_record import RunLock, command_line, start_run, versions
from ..yaml_config import from_yaml
from .config import BaselinesConfig
from .report import write_report
from .runner import Plan, run_baselines

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "rl_baselines.yaml"


def best_run(summaries: dict, found: dict) -> dict:
    """The run with the highest mean score on the validation record's points (the run to ship): its
    agent, algorithm, seed, folder and that score."""
    candidates = [(score, name, run) for name, runs in found["runs"].items()
                  for score, run in zip(summaries[name]["validation_mean_score"], runs) if np.isfinite(score)]
    if not candidates:
        raise ValueError("no run scored on the validation points")
    score, name, run = max(candidates, key=lambda c: c[0])
    return {"agent": name, "algo": run["algo"], "seed": run["seed"], "folder": run["folder"],
            "validation_mean_score": score}


def run(config_path: str | Path, out: str | Path, runs: str | Path, executor: Executor | None = None,
        resume: bool = False, force: bool = False, progress: bool = True, ship: str | Path | None = None) -> dict:
    """Search, train and report (``runner``, ``report``): the outputs go to ``out``, the trained runs
    to ``runs/<agent>/s<seed>``; with ``ship``, the best run on the validation points goes to
    ``ship/<algo>_plain`` with its model card (``card``), replacing every plain policy ``ship`` held
    (``ship/*_plain``: refused without ``force``, before any work). Returns the run record also written to
    ``out/run.json``."""
    config = from_yaml(BaselinesConfig, config_path)
    shipped = shipped_before(ship, force)
    out, executor = start_run(out, resume, force, executor, progress)
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        t0 = time.perf_counter()
        tasks = task_folder(out, resume)
        found = run_baselines(config, runs, executor, tasks)
        summaries = write_report(out, config, found)
        best = ship_best(summaries, found, out, ship, shipped) if ship is not None else best_run(summaries, found)
        record = {"command": command_line(), "versions": versions(), "config": str(config_path),
                  "runs": str(runs), "best_run": best, "wall_time_s": round(time.perf_counter() - t0, 1)}
        write_text(out / "run.json", json.dumps(record, indent=2))
        shutil.rmtree(tasks, ignore_errors=True)
    print(f"rl-baselines: {out}/benchmark.md; best run on the validation points: {best['agent']} seed "
          f"{best['seed']} ({best['folder']}, mean score {best['validation_mean_score']:.3f})")
    return record


def report_only(config_path: str | Path, out: str | Path, ship: str | Path | None = None, force: bool = False,
                records=()) -> dict:
    """Write ``out``'s tables, figures and hyperparameter files again from its ``results.json`` (no
    training): after a change of the report, or to redraw; with ``ship``, ship its best run again (as
    ``run`` does; its runs folder must still hold it), its card quoting the blind benchmarks
    ``records`` of the shipped folder. ``config_path`` must name the same agents."""
    config = from_yaml(BaselinesConfig, config_path)
    out = Path(out)
    try:
        results = json.loads((out / "results.json").read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{out}/results.json: no results of mdr-drive rl-baselines to report ({type(e).__name__})") \
            from None
    names = [a.label for a in config.agents]
    if sorted(names) != sorted(results.get("runs", {})):
        raise ValueError(f"{config_path} names the agents {names}, {out}/results.json {sorted(results.get('runs', {}))}")
    found = {"plan": Plan.of(config), "searches": results["searches"], "runs": results["runs"]}
    shipped = shipped_before(ship, force)
    with RunLock(out):
        summaries = write_report(out, config, found)
        if ship is not None:
            ship_best(summaries, found, out, ship, shipped, records)
        return summaries


def shipped_before(ship: str | Path | None, force: bool) -> list[Path]:
    """The plain policies in ``ship`` a new one replaces; ``ValueError`` if there are any and not ``force``."""
    shipped = sorted(Path(ship).glob("*_plain")) if ship is not None else []
    if shipped and not force:
        raise ValueError(f"--ship {ship}: {shipped[0]} holds a plain policy, which the new one replaces: add --force")
    return shipped


def ship_best(summaries: dict, found: dict, out: Path, ship: str | Path, shipped: list[Path], records=()) -> dict:
    """Ship the best run on the validation points to ``ship/<algo>_plain`` (``card.ship_plain``, its
    card quoting ``records``), replacing ``shipped``; returns ``best_run``'s record of it."""
    from .card import ship_plain

    best = best_run(summaries, found)
    card = ship_plain(best, found, summaries, out, ship, records)  # into its folder, replacing its files
    for folder in shipped:  # the plain policies of other algorithms
        if folder.resolve() != card.parent.resolve():
            shutil.rmtree(folder)
    best["shipped_to"] = str(card.parent)
    return best


__all__ = ["DEFAULT_CONFIG", "best_run", "report_only", "run"]
