"""The sensor policy's recipe: a plain SB3 PPO MlpPolicy that drives without being told k, the load or
friction.

    mdr-drive train-sensor agents/configs/sensor.yaml --out runs/sensor        # make train-sensor

Teacher-student training, as controllers that must act without privileged information are trained
(Lee et al. 2020; Kumar et al. 2021), with DAgger (Ross et al. 2011):

* the **teacher** is a full-observation policy (default: ``agents/pretrained/ppo_sensor/teacher``,
  ``mdr-drive friction-teacher``), told k, the load and the friction ratio mu1 / mu through the env's
  ``privileged_observation(friction=True)``; a teacher that picks from an action table (a codebook
  student, ``distill.action_codebook``) gives a merged network that picks from the same table;
* the **student** sees only ``MDRDriveSensor-v0``'s observation in its sensor tier: the last
  ``history`` periods of slider motion (displacement, mean and end velocity; with ``trace``, positions
  through each period; with ``self-sensing``, also the piezo-sensed forces) and the actions that
  produced them. With
  that history as its input, a plain MLP is the recurrent memory's frame-stacked equivalent, and it
  loads with plain ``PPO.load`` + ``VecNormalize.load``;
* round 0: the teacher drives random episodes (hidden k, load, mu, mu1 drawn per episode; a share
  with a load step; in every round the actions played are perturbed by ``action_noise``); an
  **estimator** (``mdr_drive_agents.student.estimator``) is fitted from every sensor observation to the hidden entries
  of the teacher's observation, what the slider's motion can tell (k, the load over mu F_ref, the
  load and, for a teacher told friction, mu1 / mu; squared error). Rounds 1 ... R: the teacher acting on
  the estimator's guesses
  (``SensorTeacher``) drives, so the estimator meets the states its own errors lead to, and it is
  refitted on every episode so far (DAgger);
* optionally (``action_steps``, ``action_rounds``), the estimator is fitted through the frozen
  teacher to the teacher's actions told the truth instead of to the hidden values, once after the
  rounds or in the last rounds: an entry the slider's motion hardly shows (friction, for a teacher
  on the privileged observation, ``mdr_drive_agents.train.friction_teacher``) then costs what it changes in the
  drive (tried; docs/adaptation.md);
* the estimator and the teacher are then written as one ``MlpPolicy`` (``merged_policy``: RMA's
  adaptation module and base policy in one network), checked against the pair they replace
  (``merge_check``).

Writes ``OUT/policy/`` (``model.zip``, ``vecnormalize.pkl``, ``run.json``) and ``OUT/adapt.json``
(per-round validation, stage times). An existing ``OUT`` is refused unless ``--force``. A Ctrl-C once
the first round's fit has finished writes the policy of the last finished stage, marked
``"interrupted": true``; the command then exits with 130.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_int, check_range
from mdr_drive_env.files import write_text
from mdr_drive_env.gym_envs.sensor import DEFAULT_ENCODER_NOISE, DEFAULT_TRACE_SAMPLES, SensorTier
from mdr_drive_env.gym_envs.spaces import PrivilegedLayout

from ..policy import CODEBOOK_FILE, ESTIMATOR_FILE, Policy, package_path
from ..protocol import steady_velocity_of
from ..run_record import RunLock, command_line, versions
from ..student.estimator import (FINE_TUNE_PPO, SENSOR_ID, Estimator, SensorTeacher, hidden_entries, merged_policy,
                                 sensor_teacher_policy, standardised_error, teacher_layout)
from ..student.network import Student, save_student
from ..yaml_config import from_yaml
from .sensor_episodes import (ProbeFirst, collect, probe_actions, sensor_env_kwargs, sensor_envs, sensor_structure_of,
                              with_probe)

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "sensor.yaml"


@dataclass(frozen=True)
class AdaptConfig:
    """Training of the sensor policy (module docstring).

    Attributes:
        teacher: folder of the full-observation teacher policy (``model.zip``, ``vecnormalize.pkl``).
        history: periods of the sensor observation (-).
        episodes: episodes driven per round (-).
        periods: periods per episode (-).
        load_step_share: share of the episodes with a load step (-).
        load_step_periods: (first, last) period index at which a load step may fall (-).
        action_noise: std of the Gaussian noise added to every action played (-), so the episodes
            show the estimator how the slider answers other actions than the teacher's.
        estimator_arch: hidden layer sizes of the estimator of the hidden entries (-).
        rounds: rounds after round 0, each driven by the estimator-informed teacher (-).
        estimator_steps: gradient steps of the estimator's fit after each round (-).
        batch: minibatch size (-).
        learning_rate: Adam step size, decaying linearly to zero over each fit (-).
        log_std: the shipped policy's log standard deviation (for PPO fine-tuning) (-).
        torch_threads: torch threads of the fits (-).
        action_steps: after the rounds, Adam steps that fit the estimator through the frozen teacher
            to the teacher's actions told the truth, on every episode (``SensorTeacher.fit_actions``;
            0: none) (-).
        action_learning_rate: Adam step size of that fit, decaying linearly to zero (-).
        action_rounds: 0: that fit once after the rounds; N: instead, the last N rounds fit the
            estimator on the actions only (warm), so the rounds after the first of them drive with an
            estimator fitted on actions (DAgger for that fit) (-).
        probe_periods: periods at the start of every episode in which the drive plays the deliberate
            probe (``probe_actions``, in turn) instead of the teacher, so the estimator reads the drive
            from answers to varied waveforms (0: no probe). A measurement: the merged network does not
            play the probe (``ProbeFirst`` does, in Python) (-).
        sensor_tier: what the drive measures, ``MDRDriveSensor-v0(sensor_tier=...)``: ``"encoder"``
            (per-period summaries), ``"trace"`` (also positions through each period) or
            ``"self-sensing"`` (also the piezo-sensed peak forces).
        trace_samples: position samples per period of the ``trace`` and ``self-sensing`` tiers (-).
        encoder_noise: standard deviation of each position sample (m).
    """

    teacher: str = "agents/pretrained/ppo_sensor/teacher"
    history: int = 6
    episodes: int = 512
    periods: int = 40
    load_step_share: float = 0.5
    load_step_periods: tuple[int, int] = (5, 30)
    action_noise: float = 0.15
    estimator_arch: tuple[int, ...] = (256, 256)
    rounds: int = 4
    estimator_steps: int = 4000
    batch: int = 256
    learning_rate: float = 1e-3
    log_std: float = -3.0
    torch_threads: int = 1
    action_steps: int = 0
    action_learning_rate: float = 3e-4
    action_rounds: int = 0
    probe_periods: int = 0
    sensor_tier: str = "encoder"
    trace_samples: int = DEFAULT_TRACE_SAMPLES
    encoder_noise: float = DEFAULT_ENCODER_NOISE

    def __post_init__(self) -> None:
        for name in ("history", "episodes", "periods", "estimator_steps", "batch", "torch_threads"):
            check_int(name, getattr(self, name), 1)
        check_int("rounds", self.rounds, 0)
        check_int("action_steps", self.action_steps, 0)
        check_int("action_rounds", self.action_rounds, 0)
        check_int("probe_periods", self.probe_periods, 0)
        if self.action_rounds > self.rounds:
            raise ValueError(f"action_rounds={self.action_rounds!r} is outside the allowed range [0, rounds = {self.rounds}]")
        check_range("action_learning_rate", self.action_learning_rate, 0.0, 1.0, low_open=True)
        if not self.estimator_arch or not all(isinstance(n, int) and n >= 1 for n in self.estimator_arch):
            raise ValueError(f"estimator_arch={self.estimator_arch!r} must be positive layer sizes")
        lo, hi = self.load_step_periods
        if not (isinstance(lo, int) and isinstance(hi, int) and 1 <= lo <= hi <= self.periods - 1):
            raise ValueError(f"load_step_periods={self.load_step_periods!r} is outside the allowed range "
                             f"1 <= first <= last <= periods - 1 = {self.periods - 1}")
        check_range("load_step_share", self.load_step_share, 0.0, 1.0)
        check_range("action_noise", self.action_noise, 0.0, 1.0)
        check_range("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        SensorTier(self.sensor_tier, self.trace_samples, self.encoder_noise)  # its own checks


class Validation:
    """A driver's steady velocity (mean of the last 10 of 30 periods, no load step) as a fraction of
    the teacher's on the same ``n`` hidden draws of ``seed``, where the teacher moves >= 2 mm/s (the
    teacher's velocities are computed once); for a ``SensorTeacher``, also its estimator's error on
    each hidden entry over the periods after the first ``history`` (root mean square over the
    entry's standard deviation on the draws: 0 exact, 1 no better than the mean)."""

    def __init__(self, teacher: Policy, config: AdaptConfig, seed: int, n: int = 64):
        self.config = AdaptConfig(**{**asdict(config), "periods": 30, "load_step_share": 0.0,
                                     "load_step_periods": (1, 1)})
        self.seed, self.n = seed, n
        self.friction = teacher_layout(teacher) is PrivilegedLayout
        self.v_teacher = self.steady(lambda s, p: teacher.act(p))[0]

    def steady(self, driver) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``driver``'s steady velocities (m/s) on the draws, and its episodes' sensor and privileged
        observations from period ``history`` on."""
        envs, first = sensor_envs(self.config, self.n, self.seed)
        sensed, privileged, disp = collect(envs, first, with_probe(driver, self.config, envs), friction=self.friction)
        settled = slice(self.config.history * self.n, None)  # rows are period-major
        return steady_velocity_of(disp), sensed[settled], privileged[settled]

    def __call__(self, driver) -> dict:
        v, sensed, privileged = self.steady(driver)
        keep = self.v_teacher >= 2e-3
        frac = v[keep] / self.v_teacher[keep]
        record = {"val_mean_fraction_of_teacher": float(frac.mean()), "val_min_fraction_of_teacher": float(frac.min()),
                  "val_points_scored": int(keep.sum())}
        if isinstance(driver, SensorTeacher):
            record.update(estimate_errors(driver, sensed, privileged))
        return record


def estimate_errors(sensor_teacher: SensorTeacher, sensed: np.ndarray, privileged: np.ndarray) -> dict:
    """The estimator's standardised error on each hidden entry (``val_error_<name>``: root mean
    square error over the entry's standard deviation in ``privileged``)."""
    names = teacher_layout(sensor_teacher.teacher).NAMES
    err = standardised_error(sensor_teacher.estimator(sensed), privileged[:, sensor_teacher.hidden])
    return {f"val_error_{names[i]}": float(e) for i, e in zip(sensor_teacher.hidden, err)}


def _log(record: dict) -> None:
    print(" ".join(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
                   for key, value in record.items()), flush=True)


def train(config: AdaptConfig, seed: int = 0, validate: Validation | None = None,
          progress: bool = True, teacher: Policy | None = None) -> tuple[SensorTeacher, list[dict], bool]:
    """Round 0: the privileged teacher drives; rounds 1 ... R: the estimator-informed teacher
    (``SensorTeacher``) drives, on its own state distribution. After every round the estimator is
    refitted on every episode so far. ``teacher``: ``config.teacher`` already loaded
    (``sensor_teacher_policy``), or None to load it here. Returns the final ``SensorTeacher``, the
    per-round records and whether it was interrupted: a Ctrl-C once a stage has finished keeps the
    estimator of the last finished stage (before that, the Ctrl-C is raised)."""
    import torch

    torch.set_num_threads(config.torch_threads)
    if teacher is None:
        teacher = sensor_teacher_policy(config.teacher)
    rng = np.random.default_rng(seed)
    layout = teacher_layout(teacher)
    hidden = hidden_entries(layout)
    sensor_structure = sensor_structure_of(config)
    sensed, privileged, history = [], [], []
    estimator = sensor_teacher = kept = None  # kept: the estimator's weights after the last finished stage

    def finish(record: dict, t0: float) -> None:  # validate, time, keep and print a stage's record
        nonlocal kept
        if validate is not None:
            record.update(validate(sensor_teacher))
        record["wall_time_s"] = round(time.perf_counter() - t0, 1)
        history.append(record)
        kept = copy.deepcopy(estimator.net.state_dict())
        _log(record)

    try:
        for r in range(config.rounds + 1):
            t0 = time.perf_counter()
            envs, first = sensor_envs(config, config.episodes, seed + 1_000_003 * (r + 1))
            driver = with_probe((lambda s, p: teacher.act(p)) if r == 0 else sensor_teacher, config, envs)
            s, p, _ = collect(envs, first, driver, config.action_noise, rng, friction=layout is PrivilegedLayout)
            sensed.append(s)
            privileged.append(p)
            x, full = np.concatenate(sensed), np.concatenate(privileged)
            if estimator is None:
                estimator = Estimator(x.shape[1], config.estimator_arch, seed, n_out=len(hidden),
                                      names=tuple(layout.NAMES[i] for i in hidden))
                sensor_teacher = SensorTeacher(teacher, estimator, sensor_structure)
            if config.action_steps and config.action_rounds and r > config.rounds - config.action_rounds:
                record = {"round": r, "samples": len(x), "action_fit": config.action_steps,  # on the actions only
                          "loss": fit_on_actions(sensor_teacher, x, full, config, seed + r, progress)}
            else:
                record = {"round": r, "samples": len(x),
                          "loss": estimator.fit(x, full[:, hidden], config.estimator_steps, config.batch,
                                                config.learning_rate, seed + r, progress)}
            finish(record, t0)
        if config.action_steps and not config.action_rounds:  # x, full: every episode, from the last round
            t0 = time.perf_counter()
            finish({"action_fit": config.action_steps, "samples": len(x),
                    "loss": fit_on_actions(sensor_teacher, x, full, config, seed + 99, progress)}, t0)
    except KeyboardInterrupt:
        if kept is None:
            raise
        estimator.net.load_state_dict(kept)
        print(f"adapt: interrupted; the estimator of the last finished stage ({len(history)} finished) is kept",
              flush=True)
        return sensor_teacher, history, True
    return sensor_teacher, history, False


def fit_on_actions(sensor_teacher: SensorTeacher, sensed: np.ndarray, privileged: np.ndarray, config: AdaptConfig,
                   seed: int, progress: bool) -> float:
    """``config.action_steps`` steps of the estimator's fit through the teacher to the teacher's
    actions told the truth of ``privileged`` (``SensorTeacher.fit_actions``); its last epoch's loss."""
    return sensor_teacher.fit_actions(sensed, sensor_teacher.told_truth(sensed, privileged), config.action_steps,
                                      config.batch, config.action_learning_rate, seed, progress=progress)


def merge_check(student: Student, sensor_teacher: SensorTeacher, config: AdaptConfig, seed: int) -> dict:
    """The largest difference between the merged policy's actions and the ``SensorTeacher``'s over
    the sensor observations of 64 episodes it drives itself."""
    sensed, _, _ = collect(*sensor_envs(config, 64, seed + 7), lambda s, p: student.act(s))
    merged = np.clip(student.act(sensed), -1.0, 1.0)
    composed = np.clip(sensor_teacher(sensed), -1.0, 1.0)
    return {"merge_max_action_difference": float(np.abs(merged - composed).max())}


@dataclass(frozen=True)
class SensorRecipeConfig:
    """The sensor recipe's YAML (``agents/configs/sensor.yaml``).

    Attributes:
        seed: seed of the episodes, the estimator and the merged network (-).
        adapt: the training (``AdaptConfig``).
        validation_seed: seed of the hidden draws each round is validated on (-); None: no validation.
    """

    seed: int
    adapt: AdaptConfig
    validation_seed: int | None = None

    def __post_init__(self) -> None:
        teacher = package_path(self.adapt.teacher)
        if not (teacher / "model.zip").is_file():
            raise ValueError(f"teacher={self.adapt.teacher!r} is not a policy folder (no model.zip)")
        if (teacher / CODEBOOK_FILE).is_file() and self.adapt.action_steps:
            raise ValueError(f"teacher={self.adapt.teacher!r} picks from an action table (Discrete actions): its "
                             f"estimator cannot be fitted through its actions (action_steps={self.adapt.action_steps}"
                             "; allowed with it: 0)")


def load_config(path: str | Path) -> tuple[int, int | None, AdaptConfig]:
    """(seed, validation seed, AdaptConfig) of the YAML at ``path`` (``SensorRecipeConfig``)."""
    config = from_yaml(SensorRecipeConfig, path)
    return config.seed, config.validation_seed, config.adapt


def run(config_path: str | Path, out: str | Path, force: bool = False, progress: bool = True,
        sensor_tier: str | None = None) -> dict:
    """Train the sensor student from ``config_path`` (its ``sensor_tier`` replaced by
    ``sensor_tier`` if given) into ``out``; returns what ``adapt.json`` holds. A Ctrl-C once a stage
    has finished saves the policy of the last finished stage (``"interrupted": true`` in ``adapt.json``
    and ``run.json``)."""
    seed, validation_seed, config = load_config(config_path)
    if sensor_tier is not None:
        config = replace(config, sensor_tier=sensor_tier)
    out = Path(out)
    if out.exists() and any(out.iterdir()) and not force:
        raise ValueError(f"{out} is not empty: overwrite with --force")
    with RunLock(out):
        return _run(config_path, out, seed, validation_seed, config, progress)


def _run(config_path, out: Path, seed: int, validation_seed, config: AdaptConfig, progress: bool) -> dict:
    command = command_line()
    t0 = time.perf_counter()
    teacher = sensor_teacher_policy(config.teacher)  # checked before anything is built
    validate = None if validation_seed is None else Validation(teacher, config, validation_seed)
    sensor_teacher, history, interrupted = train(config, seed, validate, progress, teacher)
    student = merged_policy(sensor_teacher, sensor_env_kwargs(config), config.log_std, seed)
    check = merge_check(student, sensor_teacher, config, seed)
    if validate is not None and not interrupted:
        check.update(validate(lambda s, p: student.act(s)))
    _log(check)
    wall = round(time.perf_counter() - t0, 1)
    env_kwargs = sensor_env_kwargs(config)
    record = {
        "algo": "ppo", "seed": seed, "env_id": SENSOR_ID, "env_kwargs": env_kwargs,
        "hyperparameters": {**FINE_TUNE_PPO, "normalize": True, "warm_start": "none",
                            "policy_kwargs": {"net_arch": {"pi": student.model.policy.net_arch["pi"], "vf": [64, 64]},
                                              "activation_fn": "relu", "log_std_init": config.log_std}},
        "adapted_from": {"teacher": config.teacher, "config": str(config_path), "adapt": asdict(config),
                         "validation_seed": validation_seed, "history": history, "merged": check},
        "command": command, "versions": versions(), "torch_threads": config.torch_threads,
        "total_timesteps": 0, "steps_this_run": 0, "wall_time_s": wall, "steps_per_s_this_run": 0.0, "resumes": 0,
        "interrupted": interrupted,
    }
    save_student(student, out / "policy", record)
    sensor_teacher.estimator.save(out / "policy" / ESTIMATOR_FILE)  # what the report plots the estimates with
    summary = {"config": str(config_path), "command": command, "seed": seed, "wall_time_s": wall,
               "rounds": history, "merged": check, "interrupted": interrupted}
    write_text(out / "adapt.json", json.dumps(summary, indent=2))
    print(f"adapt: {wall:.0f} s; policy in {out / 'policy'}", flush=True)
    return summary


__all__ = ["AdaptConfig", "DEFAULT_CONFIG", "SensorRecipeConfig", "Validation", "collect", "estimate_errors", "load_config", "merge_check", "probe_actions", "ProbeFirst", "run", "sensor_env_kwargs", "with_probe", "sensor_envs", "sensor_structure_of", "train"]
