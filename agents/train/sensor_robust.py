"""Posterior-robust targets for a sensor policy's estimator (``AdaptConfig.robust_neighbours``).

An estimator fitted to the hidden entries by squared error guesses their mean over the hidden values
the sensor cannot tell apart. The teacher is a fit to searched drive fields: where neighbouring hidden
values ask for different drives, the teacher told that mean can drive far worse than told the truth,
though every entry is read closely. This stage tells the teacher instead, for each sensor
observation, a value it drives well with under every hidden value the sensor confuses with it:

1. **library**: ``robust_episodes`` episodes without a load step (hidden values drawn as in training),
   driven by the estimator-informed teacher; per episode, the mean estimate over its last 10 periods
   and the true entries;
2. **robust target** of library episode j: its ``robust_neighbours`` nearest episodes by estimate
   (entries over their standard deviation, j among them) stand for what the sensor cannot tell from
   j. Every neighbour's true entries are a candidate; the teacher told a candidate, unchanged for
   30 periods, drives at each neighbour's parameters, and the candidate's score is the mean over the
   neighbours of its steady velocity (last 10 periods) as a fraction of the teacher's told that
   neighbour's truth (that velocity at least 2 mm/s; fractions clipped to [-2, 1.5]). The best
   candidate is j's target;
3. **refit**: every sensor observation of the training episodes is labelled with the target of the
   library episode nearest to its estimate, and a copy of the estimator is refitted to those labels
   (warm, ``estimator_steps`` Adam steps). The sensor policy is the teacher on the refitted copy.
"""

from __future__ import annotations

import copy
from dataclasses import replace
from typing import TYPE_CHECKING

import gymnasium as gym
import numpy as np

from ..protocol import AVERAGE_PERIODS, steady_velocity_of
from ..student.estimator import SENSOR_ID, SensorTeacher
from .sensor_episodes import collect, sensor_env_kwargs, sensor_envs

if TYPE_CHECKING:
    from .sensor import AdaptConfig

#: Periods of the library's and of the candidates' episodes (the validation's: steady over the last 10).
ROBUST_PERIODS = 30
#: Candidate episodes played at once (envs in memory).
CHUNK = 1024
#: Teacher velocities below this count as this (m/s) in the fractions that score candidates.
FRACTION_FLOOR = 2e-3
FRACTION_CLIP = (-2.0, 1.5)


def drive_parameters(envs: list) -> np.ndarray:
    """(n, 4) of each env's drive: k, cargo mass (kg), mu, mu1."""
    return np.array([(e.unwrapped.params.indenter.grading_exponent, e.unwrapped.params.drive.cargo_mass,
                      e.unwrapped.params.contact.friction_coefficient,
                      e.unwrapped.params.contact.base_friction_coefficient) for e in envs])


def told_velocities(sensor_teacher: SensorTeacher, config: AdaptConfig, parameters: np.ndarray,
                    hidden: np.ndarray, friction: bool, progress: bool = True) -> np.ndarray:
    """Steady velocity (m/s) of the teacher told ``hidden[i]`` (its hidden entries, unchanged through
    the episode) in a ``ROBUST_PERIODS``-period episode at the drive ``parameters[i]``
    (``drive_parameters``); the sensor noise seeded by the row."""
    from tqdm import tqdm

    kwargs = {key: v for key, v in sensor_env_kwargs(config).items() if key != "load_ratio"}
    kwargs["max_periods"] = ROBUST_PERIODS
    teacher = sensor_teacher.teacher
    out = []
    for start in tqdm(range(0, len(parameters), CHUNK), desc="adapt: robust targets", unit="chunk",
                      disable=not progress):
        rows, told = parameters[start:start + CHUNK], hidden[start:start + CHUNK].astype(np.float32)
        envs = [gym.make(SENSOR_ID, **{**kwargs, "k": float(k), "cargo_mass": float(m), "friction_coefficient": float(mu),
                                       "base_friction_coefficient": float(mu1)}) for k, m, mu, mu1 in rows]
        first = np.array([env.reset(seed=start + i)[0] for i, env in enumerate(envs)])
        _, _, disp = collect(envs, first, lambda s, p: teacher.act(sensor_teacher.full_observation(s, hidden=told)),
                             friction=friction)
        out.append(steady_velocity_of(disp))
    return np.concatenate(out)


def neighbours(estimates: np.ndarray, scale: np.ndarray, n: int) -> np.ndarray:
    """(len(estimates), n) indices of each row's ``n`` nearest rows (itself first), by the entries
    over ``scale``."""
    from scipy.spatial import cKDTree

    z = estimates / scale
    return cKDTree(z).query(z, k=n)[1].reshape(len(z), n)


def choose_targets(neighbour_sets: np.ndarray, velocity: dict, teacher_velocity: np.ndarray) -> np.ndarray:
    """For each library episode, the index of the neighbour whose truth is its robust target:
    ``velocity[(a, b)]`` is the teacher's told a's truth at b's drive, ``teacher_velocity[b]`` told
    b's own (module docstring, step 2)."""
    chosen = np.empty(len(neighbour_sets), dtype=np.int64)
    for j, group in enumerate(neighbour_sets):
        ref = np.maximum(teacher_velocity[group], FRACTION_FLOOR)
        score = [np.mean(np.clip([velocity[a, b] for b in group] / ref, *FRACTION_CLIP)) for a in group]
        chosen[j] = group[int(np.argmax(score))]
    return chosen


def robust_refit(sensor_teacher: SensorTeacher, config: AdaptConfig, sensed: np.ndarray, friction: bool, seed: int,
                 progress: bool = True) -> tuple[SensorTeacher, dict]:
    """The teacher on a copy of ``sensor_teacher``'s estimator refitted to robust targets (module
    docstring) on the training episodes' sensor observations ``sensed``; and the stage's record."""
    library = replace(config, periods=ROBUST_PERIODS, load_step_share=0.0, load_step_periods=(1, 1))
    envs, first = sensor_envs(library, config.robust_episodes, seed)
    parameters = drive_parameters(envs)
    s, p, _ = collect(envs, first, sensor_teacher, friction=friction)
    n = config.robust_episodes
    rows = s.reshape(ROBUST_PERIODS, n, -1)[-AVERAGE_PERIODS:]
    estimates = np.mean([sensor_teacher.estimator(r) for r in rows], axis=0)
    truths = p.reshape(ROBUST_PERIODS, n, -1)[0][:, sensor_teacher.hidden]
    scale = truths.std(axis=0) + 1e-12
    groups = neighbours(estimates, scale, config.robust_neighbours)
    pairs = np.unique(np.array([(a, b) for g in groups for a in g for b in g]), axis=0)
    v = told_velocities(sensor_teacher, config, parameters[pairs[:, 1]], truths[pairs[:, 0]], friction, progress)
    velocity = {(int(a), int(b)): float(x) for (a, b), x in zip(pairs, v)}
    teacher_velocity = np.array([velocity.get((b, b), np.nan) for b in range(n)])
    chosen = choose_targets(groups, velocity, teacher_velocity)
    from scipy.spatial import cKDTree

    guesses = np.concatenate([sensor_teacher.estimator(sensed[i:i + 65536]) for i in range(0, len(sensed), 65536)])
    nearest = cKDTree(estimates / scale).query(guesses / scale)[1]
    refitted = copy.deepcopy(sensor_teacher.estimator)
    loss = refitted.fit(sensed, truths[chosen][nearest], config.estimator_steps, config.batch, config.learning_rate,
                        seed, progress)
    robust = SensorTeacher(sensor_teacher.teacher, refitted, sensor_teacher.sensor_structure)
    record = {"robust_library": n, "robust_candidate_episodes": len(pairs), "samples": len(sensed),
              "robust_targets_not_own_truth": float(np.mean(chosen != np.arange(n))), "loss": loss}
    return robust, record


__all__ = ["CHUNK", "ROBUST_PERIODS", "choose_targets", "drive_parameters", "neighbours", "robust_refit",
           "told_velocities"]
