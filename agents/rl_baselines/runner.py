"""The runs of ``mdr-drive rl-baselines``: the hyperparameter search of each algorithm, then its
final runs, each run one task of the sweep executor (local processes or a Ray cluster sharing the
runs folder), each finished task kept in ``OUT/.tasks`` so that ``--resume`` after Ctrl-C runs only
what is missing."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mdr_drive_env.sweep import Executor, TaskStore

from ..benchmarks.reference import Reference, common_time_quantum
from ..train.hyperparameters import load_config
from .config import Agent, BaselinesConfig
from .curve import curve_steps
from .tuning import fixed_hyperparameters, make_study, sample_hyperparameters


def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """Train one run from scratch (``train.sb3.train`` into ``task["folder"]``) and play it at
    ``task["points"]`` when it reaches each of ``task["curve_at"]`` steps; returns its learning curve
    (steps, seconds of training, velocities in m/s with runaways as None) and its speed."""
    from ..train.sb3 import train
    from .curve import learning_curve_callback

    env_overrides = {**task["env_kwargs"], "time_quantum": task["time_quantum"]}
    hyper, env_kwargs = load_config(task["algo"], task["config"])
    env_kwargs.update(env_overrides)
    callback = learning_curve_callback(task["algo"], env_kwargs, task["points"], task["curve_at"],
                                       hyperparameters={**hyper, **task["hyperparameters"]})
    record = train(task["algo"], task["steps"], task["seed"], task["folder"], config=task["config"],
                   hyperparams=task["hyperparameters"], warm_start=task["warm_start"], progress_bar=False, force=True,
                   eval_freq=task["steps"], checkpoint_freq=task["steps"], torch_threads=task["torch_threads"],
                   callbacks=[callback], env_overrides=env_overrides)
    return {
        "steps": [s for s, _, _ in callback.curve],
        "train_seconds": [t for _, t, _ in callback.curve],
        "velocities": [[None if np.isnan(x) else float(x) for x in v] for _, _, v in callback.curve],
        "total_timesteps": record["total_timesteps"],
        "wall_time_s": record["wall_time_s"],
        "interrupted": record["interrupted"],
    }


@dataclass(frozen=True)
class Plan:
    """What a run of the baselines plays where: the validation and report references, all their points
    (validation first) and the time quantum every drive acts at."""

    validation: Reference
    reports: tuple[Reference, ...]

    @classmethod
    def of(cls, config: BaselinesConfig) -> "Plan":
        validation = Reference.load(config.validation_record)
        reports = tuple(Reference.load(path) for path in config.report_records)
        common_time_quantum([validation, *reports])
        return cls(validation, reports)

    @property
    def points(self) -> list[tuple[float, float]]:
        return [p for ref in (self.validation, *self.reports) for p in ref.points]

    @property
    def time_quantum(self) -> float:
        return self.validation.time_quantum

    def split(self, velocities) -> tuple[np.ndarray, list[np.ndarray]]:
        """Velocities at ``points`` (None a runaway) as (validation's, [each report's])."""
        v = np.array([np.nan if x is None else x for x in velocities], dtype=float)
        n = len(self.validation.points)
        parts, start = [], n
        for ref in self.reports:
            parts.append(v[start:start + len(ref.points)])
            start += len(ref.points)
        return v[:n], parts


def _task(agent: Agent, seed: int, steps: int, hyper: dict, folder: Path, points, curve_at, plan: Plan,
          threads: int) -> dict[str, Any]:
    return {"algo": agent.algo, "seed": seed, "steps": steps, "config": agent.config,
            "hyperparameters": {**hyper, **(agent.hyperparameters or {})}, "warm_start": agent.warm_start,
            "env_kwargs": dict(agent.env_kwargs or {}), "folder": str(folder), "points": points, "curve_at": curve_at,
            "time_quantum": plan.time_quantum, "torch_threads": threads}


def tune(agent: Agent, config: BaselinesConfig, plan: Plan, executor: Executor, tasks: Path,
         runs: Path) -> dict[str, Any]:
    """The hyperparameter search of one algorithm (``tuning``): ``agent.tune_trials`` trials of
    ``agent.tune_steps`` steps, ``config.tune_batch`` at a time; returns the trials (hyperparameters, objective)
    and the best trial's hyperparameters."""
    study = make_study(config.tune_seed, startup_trials=max(2, agent.tune_trials // 3))
    points = list(plan.validation.points)
    trials, batch = [], config.tune_batch
    for start in range(0, agent.tune_trials, batch):
        asked = [study.ask() for _ in range(min(batch, agent.tune_trials - start))]
        hypers = [sample_hyperparameters(t, agent.algo) for t in asked]
        batch_tasks = [_task(agent, config.tune_seed, agent.tune_steps, h, runs / "tuning" / slug(agent) /
                             f"trial{t.number}", points, [agent.tune_steps], plan, config.torch_threads)
                       for t, h in zip(asked, hypers)]
        results = executor.map(run_task, batch_tasks,
                               f"{agent.label}: trials {start + 1}-{start + len(asked)} of {agent.tune_trials}",
                               store=TaskStore(tasks / f"tune_{slug(agent)}" / f"batch{start // batch}"))
        for trial, hyper, result in zip(asked, hypers, results):
            scores = plan.validation.scores(plan.split(result["velocities"][-1])[0])
            value = float(np.nanmean(scores)) if np.isfinite(scores).any() else -1.0
            study.tell(trial, value)
            trials.append({"number": trial.number, "params": trial.params, "hyperparameters": hyper,
                           "validation_mean_score": value, "wall_time_s": result["wall_time_s"]})
    best = study.best_trial
    return {"trials": trials, "best_trial": best.number, "best_validation_mean_score": best.value,
            "hyperparameters": fixed_hyperparameters(best.params, agent.algo)}


def run_baselines(config: BaselinesConfig, runs: str | Path, executor: Executor, tasks: str | Path) -> dict:
    """Search each algorithm's hyperparameters, then train its final runs (every seed of ``config``)
    into ``runs/<agent>/s<seed>`` (``slug``); returns the search and every run's learning curve at the plan's
    points (``report`` turns them into tables and figures)."""
    plan = Plan.of(config)
    runs, tasks = Path(runs), Path(tasks)
    searches = {}
    for agent in config.agents:
        if agent.tune_trials:
            searches[agent.label] = tune(agent, config, plan, executor, tasks, runs)
        else:
            searches[agent.label] = {"trials": [], "hyperparameters": {}}
    final = [(agent, seed) for agent in config.agents for seed in config.seeds]
    final_tasks = [_task(agent, seed, agent.steps, searches[agent.label]["hyperparameters"],
                         runs / slug(agent) / f"s{seed}", plan.points, curve_steps(agent.steps, config.curve_points),
                         plan, config.torch_threads) for agent, seed in final]
    results = executor.map(run_task, final_tasks, f"final runs ({len(config.seeds)} seeds each)",
                           store=TaskStore(tasks / "final"))
    per_agent: dict[str, list] = {agent.label: [] for agent in config.agents}
    for (agent, seed), result, task in zip(final, results, final_tasks):
        per_agent[agent.label].append({"seed": seed, "algo": agent.algo, "folder": task["folder"], **result})
    return {"plan": plan, "searches": searches, "runs": per_agent}


def slug(agent: Agent) -> str:
    """The file and folder name of an agent: its algorithm (``recurrent_ppo``), or, if it has a name, that
    name in lower case with runs of other characters as ``_``."""
    import re

    return agent.algo if agent.name is None else re.sub(r"[^a-z0-9]+", "_", agent.name.lower()).strip("_")


__all__ = ["Plan", "run_baselines", "run_task", "slug", "tune"]
