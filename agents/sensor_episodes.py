"""The sensor policy's training episodes: envs with hidden parameters drawn per episode, the hidden
points of each episode, the deliberate probe, and episodes driven by a driver of the sensor and
privileged observations (Box actions, ``collect``) or of the sensor observation and the hidden point
(the rows of an action table, ``collect_rows``).

Shared by the sensor recipe (``train.sensor``, which re-exports them) and the identifiability study
(``benchmarks.identifiability``), which sit beside each other and import neither.
"""

from __future__ import annotations

from typing import Protocol

import gymnasium as gym
import numpy as np

from .drive import PAPER_DRIVE, DriveDescription
from .protocol import SENSOR_ID


class EpisodeSettings(Protocol):
    """What the sensor episodes read of a recipe's settings (``train.sensor.SensorConfig`` has it):
    the observation's periods, the episode's length, the load steps' share and period range, the
    sensor tier with its position samples per period and their noise (m)."""

    history: int
    periods: int
    load_step_share: float
    load_step_periods: tuple[int, int]
    sensor_tier: str
    trace_samples: int
    encoder_noise: float


def sensor_envs(config: EpisodeSettings, n: int, seed: int, codebook: np.ndarray | None = None,
                drive: DriveDescription = PAPER_DRIVE) -> tuple[list, np.ndarray]:
    """``n`` sensor envs on ``drive`` (hidden parameters drawn per episode), the first ``load_step_share``
    of them with a load step, reset with seeds ``seed, seed + 1, ...``; and their first observations.
    ``codebook``: the (m, 5) action table they play rows of (``Discrete(m)`` actions), or None (Box)."""
    n_step = int(round(config.load_step_share * n))
    kwargs = sensor_env_kwargs(config, drive)
    if codebook is not None:
        kwargs["action_codebook"] = np.asarray(codebook)
    envs = [gym.make(SENSOR_ID, **kwargs, load_step_period=config.load_step_periods if i < n_step else None)
            for i in range(n)]
    return envs, np.array([env.reset(seed=seed + i)[0] for i, env in enumerate(envs)])


def episode_points(envs: list) -> tuple[list, np.ndarray, np.ndarray]:
    """The hidden points of freshly reset ``envs``: every distinct (k, cargo mass kg, mu, mu1) point in
    order, each episode's (point before its load step, point after it) indices (n, 2) (the same
    twice without a step) and its load step's period (n,) (-1: none)."""
    points, index, step = [], [], []
    for env in envs:
        u = env.unwrapped
        contact = u.params.contact
        first = (float(u.k), float(u.cargo_mass), float(contact.friction_coefficient),
                 float(contact.base_friction_coefficient))
        points.append(first)
        if u.load_step is None:
            index.append((len(points) - 1, len(points) - 1))
            step.append(-1)
        else:
            points.append((first[0], float(u.load_step[1]), first[2], first[3]))
            index.append((len(points) - 2, len(points) - 1))
            step.append(int(u.load_step[0]))
    return points, np.array(index, dtype=np.int64), np.array(step, dtype=np.int64)


def collect_rows(envs: list, obs: np.ndarray, driver, index: np.ndarray | None = None, step: np.ndarray | None = None,
                 explore: float = 0.0, rng: np.random.Generator | None = None, hidden: list[int] | None = None):
    """One episode in every env (reset, first observations ``obs``) that plays rows of an action
    table: each period's rows ``driver(sensor_obs, point)``, where ``point`` is the index of each
    episode's hidden point in that period (``episode_points``' ``index`` and ``step``; None without
    them); with probability ``explore`` a period plays a row drawn uniformly from ``rng`` instead.
    Returns the sensor observations (periods * n, d), the hidden points' indices (periods * n,; None
    without ``index``), the privileged observations' entries ``hidden`` (periods * n, len(hidden); None
    without) and the displacements (periods, n) m."""
    n = len(envs)
    n_rows = envs[0].action_space.n
    sensed, points, privileged, disp = [], [], [], []
    for t in range(envs[0].unwrapped.max_periods):
        point = None if index is None else np.where((step >= 0) & (t >= step), index[:, 1], index[:, 0])
        rows = np.asarray(driver(obs, point), dtype=np.int64).reshape(n)
        if explore > 0.0:
            rows = np.where(rng.random(n) < explore, rng.integers(0, n_rows, n), rows)
        if hidden is not None:
            privileged.append(np.array([env.unwrapped.privileged_observation(friction=True)[hidden] for env in envs]))
        sensed.append(obs)
        points.append(point)
        steps = [env.step(int(row)) for env, row in zip(envs, rows)]
        obs = np.array([s[0] for s in steps])
        disp.append([s[4]["displacement"] for s in steps])
    return (np.concatenate(sensed), None if index is None else np.concatenate(points),
            np.concatenate(privileged) if hidden is not None else None, np.array(disp))


def probe_actions(env) -> np.ndarray:
    """The deliberate probe of ``env``'s drive, (6, 5) actions: the trapezoid; reversed (its z phase
    half a period on); out of contact (no z stroke: the slider coasts under the load alone); at half
    the trapezoid's z stroke; symmetric (both rise fractions 1/2); a clamp (no x stroke)."""
    amap = env.unwrapped.action_map
    trapezoid = env.unwrapped.trapezoid_action().astype(np.float64)
    rows = np.tile(trapezoid, (6, 1))
    rows[1, 4] = 2.0 * (((trapezoid[4] + 1.0) / 2.0 + 0.5) % 1.0) - 1.0
    rows[2, 2] = -1.0
    rows[3, 2] = (trapezoid[2] + 1.0) / 2.0 - 1.0
    rows[4, [1, 3]] = 2.0 * (0.5 - amap.min_rise_fraction) / (amap.max_rise_fraction - amap.min_rise_fraction) - 1.0
    rows[5, 0] = -1.0
    return rows.astype(np.float32)


class ProbeFirst:
    """A driver (``collect``'s ``driver(sensor_obs, privileged_obs)``) that plays ``actions`` in turn
    in the first ``periods`` periods of every episode (read from the sensor observation's elapsed
    fraction of ``max_periods``), then ``driver``."""

    def __init__(self, driver, actions: np.ndarray, periods: int, max_periods: int):
        self.driver, self.actions, self.periods, self.max_periods = driver, actions, periods, max_periods

    def __call__(self, sensed: np.ndarray, privileged: np.ndarray | None = None) -> np.ndarray:
        action = np.array(self.driver(sensed, privileged), dtype=np.float32).reshape(len(sensed), -1)
        index = np.rint(sensed[:, -1] * self.max_periods).astype(int)
        probing = index < self.periods
        action[probing] = self.actions[index[probing] % len(self.actions)]
        return action


def collect(envs: list, obs: np.ndarray, driver, noise: float = 0.0, rng: np.random.Generator | None = None,
            friction: bool = False):
    """One episode in every env (reset, first observations ``obs``), each period's actions
    ``driver(sensor_obs, privileged_obs)`` plus Gaussian noise of std ``noise`` (from ``rng``).
    Returns the sensor observations (periods * n, d), the privileged observations (periods * n, 14;
    with ``friction`` 15, mu1 / mu appended) and the displacements (periods, n) m."""
    sensed, privileged, disp = [], [], []
    for _ in range(envs[0].unwrapped.max_periods):
        full = np.array([env.unwrapped.privileged_observation(friction=friction) for env in envs])
        action = np.clip(np.asarray(driver(obs, full), dtype=np.float32).reshape(len(envs), 5), -1.0, 1.0)
        if noise > 0.0:
            action = np.clip(action + rng.normal(0.0, noise, action.shape), -1.0, 1.0).astype(np.float32)
        sensed.append(obs)
        privileged.append(full)
        steps = [env.step(a) for env, a in zip(envs, action)]
        obs = np.array([s[0] for s in steps])
        disp.append([s[4]["displacement"] for s in steps])
    return np.concatenate(sensed), np.concatenate(privileged), np.array(disp)


def sensor_env_kwargs(config: EpisodeSettings, drive: DriveDescription = PAPER_DRIVE) -> dict:
    """The env the sensor policy of ``drive`` is trained and acts in, as ``MDRDriveSensor-v0`` keywords:
    the drive, its hidden ranges (``DriveDescription.sensor_env_kwargs``; run.json: what ``evaluate``
    warns outside) and its observation."""
    tier = {} if config.sensor_tier == "encoder" else {
        "sensor_tier": config.sensor_tier, "trace_samples": config.trace_samples, "encoder_noise": config.encoder_noise}
    return {**drive.sensor_env_kwargs(), "history": config.history, "max_periods": config.periods, **tier}


def sensor_structure_of(config: EpisodeSettings) -> dict[str, slice]:
    """Where each group of entries sits in the sensor observation ``config`` trains on."""
    return gym.make(SENSOR_ID, **sensor_env_kwargs(config)).unwrapped.observation_structure
