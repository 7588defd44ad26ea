"""The settings of ``mdr-drive rl-baselines`` (a YAML file, ``agents/configs/rl_baselines.yaml``).

    config = from_yaml(BaselinesConfig, "agents/configs/rl_baselines.yaml")
"""

from __future__ import annotations

from dataclasses import dataclass

from ..policy import ALGORITHMS
from ..train.hyperparameters import WARM_STARTS


def _at_least(name: str, value, low: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name}={value!r} is outside the allowed range [{low}, inf)")


#: How tables name an algorithm.
ALGORITHM_NAMES = {"ppo": "PPO", "sac": "SAC", "td3": "TD3", "recurrent_ppo": "RecurrentPPO"}


@dataclass(frozen=True)
class Agent:
    """One agent of the table: an algorithm, its budget and what it starts from.

    Attributes:
        algo: one of ``ALGORITHMS`` (ppo, sac, td3, recurrent_ppo).
        steps: environment steps (drive periods) of each training run (-).
        tune_trials: Optuna trials of its hyperparameter search; 0 keeps its config's hyperparameters (-).
        tune_steps: environment steps of each trial (-).
        config: its RL-Zoo-style YAML of default hyperparameters and training domain (default
            ``agents/configs/<algo>.yaml``; a ``hyperparameters/<algo>.yaml`` this command wrote
            replays a search); the search replaces the hyperparameters it samples.
        name: how tables name it, unique (default: the algorithm's name).
        warm_start: "none" (from scratch: the baselines) or "trapezoid" (the policy's mean action
            starts at the paper's waveform).
        env_kwargs: ``MDRDrive-v0`` keywords that replace its config's (e.g. ``{max_periods: 100}``).
        hyperparameters: SB3 hyperparameters that replace the config's and the search's.
    """

    algo: str
    steps: int
    tune_trials: int = 0
    tune_steps: int = 0
    config: str | None = None
    name: str | None = None
    warm_start: str = "none"
    env_kwargs: dict | None = None
    hyperparameters: dict | None = None

    def __post_init__(self) -> None:
        if self.algo not in ALGORITHMS:
            raise ValueError(f"algo={self.algo!r} is not one of {list(ALGORITHMS)}")
        _at_least("steps", self.steps, 1)
        _at_least("tune_trials", self.tune_trials, 0)
        _at_least("tune_steps", self.tune_steps, 1 if self.tune_trials else 0)
        if self.warm_start not in WARM_STARTS:
            raise ValueError(f"warm_start={self.warm_start!r} is not one of {list(WARM_STARTS)}")
        for field in ("env_kwargs", "hyperparameters"):
            if getattr(self, field) is not None and not isinstance(getattr(self, field), dict):
                raise ValueError(f"{field}={getattr(self, field)!r} must be a mapping")

    @property
    def label(self) -> str:
        """The name tables give it."""
        return self.name or ALGORITHM_NAMES[self.algo]


@dataclass(frozen=True)
class BaselinesConfig:
    """What ``mdr-drive rl-baselines`` trains and where it judges it.

    Attributes:
        agents: the agents (``Agent``), in the table's order.
        seeds: training seeds of every algorithm's final runs (-), at least one.
        validation_record: a blind benchmark's ``blind.json`` (``mdr-drive benchmark --blind``) whose
            points decide: the search's objective and which run ships. Never reported.
        report_records: the blind benchmarks reported (their points and references), none of them the
            validation record.
        curve_points: evaluations on each run's learning curve, evenly spaced in steps (-), >= 1.
        tune_seed: seed of the search's sampler and of its trials' training (-).
        tune_batch: trials asked of the sampler at once, then trained in parallel (-): the search
            depends on it, not on the number of workers.
        torch_threads: torch threads of each run (-); 1 is fastest for these small networks.
    """

    agents: tuple[Agent, ...]
    seeds: tuple[int, ...]
    validation_record: str
    report_records: tuple[str, ...]
    curve_points: int = 10
    tune_seed: int = 0
    tune_batch: int = 2
    torch_threads: int = 1

    def __post_init__(self) -> None:
        if not self.agents:
            raise ValueError("agents: at least one")
        names = [a.label for a in self.agents]
        if len(set(names)) != len(names):
            raise ValueError(f"agents={names}: each name once (give two agents of one algorithm a name each)")
        if not self.seeds or len(set(self.seeds)) != len(self.seeds):
            raise ValueError(f"seeds={list(self.seeds)}: at least one, each once")
        for seed in self.seeds:
            _at_least("seeds", seed, 0)
        if not self.report_records:
            raise ValueError("report_records: at least one blind benchmark to report on")
        if self.validation_record in self.report_records:
            raise ValueError(f"report_records: {self.validation_record} is the validation record; a record that "
                             "decides is not reported")
        _at_least("curve_points", self.curve_points, 1)
        _at_least("tune_seed", self.tune_seed, 0)
        _at_least("tune_batch", self.tune_batch, 1)
        _at_least("torch_threads", self.torch_threads, 1)


__all__ = ["ALGORITHM_NAMES", "Agent", "BaselinesConfig"]
