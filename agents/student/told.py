"""The policy told k and the load, as one network that predicts each whole drive's worth.

The teacher's field (``teacher.DriveField``) holds the best drive found at every node of its grid of k
and load: a fixed action or a two-action cycle. Those drives, and the trapezoid, are the policy's
library (``field_library``, a ``teacher.DriveTable``). Every drive of the library is played at random
points of the training domain with the batched kernel (``teacher.drive_values``, the evaluation
protocol); each drive's worth at a point follows from the velocities there
(``student.DriveValueTargets``). One network (``student.DriveValueNetwork``) learns each drive's worth
from what the policy observes, and the policy plays the drive of the highest predicted worth, a
cycle's two actions in turn (``student.pick_rows``): the same method as the sensor policy's, on the
observation that is told the point.

Told k and the load, the worth at a point does not depend on how the slider got there: the network
reads only k and the load (the slider's motion, the previous action and the episode's elapsed
fraction are masked out), so no DAgger round is needed: the labelled points are the whole data.
The previous action only selects which of a cycle's two rows comes next.

``fit_told`` returns the network written as one SB3 PPO ``MlpPolicy`` over ``MDRDrive-v0(action_codebook=
rows)`` (``DriveValueNetwork.policy``), which ``PPO.load`` + ``VecNormalize.load`` play.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace

import gymnasium as gym
import numpy as np

from mdr_drive_env import ENV_ID  # importing the package registers the env
from mdr_drive_env.core.params import check_int, check_range
from mdr_drive_env.sweep import Executor, TaskStore

from ..protocol import BELOW_TOLERANCE, MOVING_THRESHOLD, trapezoid_action
from ..teacher import DriveField
from ..teacher.drive_table import DriveTable, drive_values
from .data import draw_points, stall_points
from .drive_values import DriveValueNetwork, DriveValueTargets, check_fit_settings


@dataclass(frozen=True)
class WorthConfig:
    """How the told-load policy is made from a field (module docstring).

    Attributes:
        points: (k, load) points drawn uniformly over the field's k range and loads up to
            ``load_factor`` times the trapezoid's critical load, every drive valued at each (-).
        stall_points: further points at 0.75-1.02 of the teacher's stall load, where the critical
            load is decided (-).
        load_factor: the uniform points' loads reach this times the trapezoid's critical load (-).
        no_load_share: share of the uniform points without load (-).
        arch: hidden layer sizes of the network (ReLU).
        steps: Adam steps of the fit (-).
        batch: minibatch size (-).
        learning_rate: Adam step size, decaying linearly to zero (-).
        top_weight: the squared error of the drives within 0.1 of a point's best worth weighs
            ``1 + top_weight`` (-): the pick needs the order of the best drives.
        continuation: ``student.pick_rows``' weight on the distance from the previous action to a row's
            partner (-): a cycle's rows alternate.
        knee, shortfall_weight, below_weight: ``student.DriveValueTargets``' worth (-).
        validation_points: further points, drawn as the uniform ones with another seed and never
            fitted, where the picks are judged against the library's best (-); 0: none.
        torch_threads: torch threads of the fit (-).
    """

    points: int = 2048
    stall_points: int = 1024
    load_factor: float = 1.7
    no_load_share: float = 0.1
    arch: tuple[int, ...] = (512, 512, 512)
    steps: int = 10000
    batch: int = 512
    learning_rate: float = 1e-3
    top_weight: float = 4.0
    continuation: float = 0.02
    knee: float = 0.85
    shortfall_weight: float = 1.0
    below_weight: float = 5.0
    validation_points: int = 0
    torch_threads: int = 2

    def __post_init__(self) -> None:
        check_int("points", self.points, 1)
        for name in ("stall_points", "validation_points"):
            check_int(name, getattr(self, name), 0)
        check_fit_settings(self)
        check_range("load_factor", self.load_factor, 0.0, 10.0, low_open=True)
        check_range("no_load_share", self.no_load_share, 0.0, 1.0)
        check_range("top_weight", self.top_weight, 0.0, 100.0)

    def targets(self, velocities: np.ndarray) -> DriveValueTargets:
        """Each drive's worth at the points of ``velocities`` (points, drives) m/s."""
        return DriveValueTargets.of(velocities, self)


def field_library(field_: DriveField) -> DriveTable:
    """The drives a told-load policy picks from: the trapezoid first, then every distinct drive of the
    field's grid and point drives, at the centres of their time quanta (``ActionMap.quantum_centre``),
    in the field's order."""
    centre = field_.drive.action_map().quantum_centre
    drives = np.concatenate([field_.drives.reshape(-1, 2, 5), field_.point_drives])
    drives = centre(drives.reshape(-1, 5)).reshape(-1, 2, 5)
    drives = np.concatenate([np.tile(trapezoid_action().astype(np.float64), (2, 1))[None], drives])
    _, first = np.unique(drives.reshape(len(drives), -1), axis=0, return_index=True)
    kept = drives[np.sort(first)]  # the trapezoid stays first
    return DriveTable(kept, {"source": "teacher field", "drives": len(kept)})


def told_points(field_: DriveField, config: WorthConfig, seed: int) -> list[tuple[float, float]]:
    """The (k, cargo mass kg) points the library is valued at (``WorthConfig.points`` and
    ``stall_points``), drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    draw = SimpleNamespace(load_factor=config.load_factor, no_load_share=config.no_load_share)
    return draw_points(field_, config.points, rng, draw) + (
        stall_points(field_, config.stall_points, rng, (0.75, 1.02)) if config.stall_points else [])


def told_observations(points, env_kwargs: dict) -> np.ndarray:
    """The observation (n, d) of ``MDRDrive-v0(**env_kwargs)`` at the start of an episode at each (k,
    cargo mass kg) point: what the network reads of it (k and the load) is the same in every period."""
    env = gym.make(ENV_ID, **{key: v for key, v in env_kwargs.items() if key != "action_codebook"})
    return np.array([env.reset(seed=0, options={"k": k, "cargo_mass": m})[0] for k, m in points], dtype=np.float32)


def pick_quality(velocities: np.ndarray, picks: np.ndarray) -> dict:
    """How the picked drives (n,) do at the labelled points (n, drives) m/s: their mean and lowest
    fraction of the library's best where it moves >= ``MOVING_THRESHOLD``, and the points below the
    trapezoid (drive 0) by more than ``BELOW_TOLERANCE``."""
    best = velocities.max(axis=1)
    got = velocities[np.arange(len(velocities)), picks]
    moving = best >= MOVING_THRESHOLD
    fraction = got[moving] / best[moving]
    return {"fraction_of_library_best_mean": float(fraction.mean()) if moving.any() else None,
            "fraction_of_library_best_min": float(fraction.min()) if moving.any() else None,
            "points_below_trapezoid": int(np.sum(got < velocities[:, 0] - BELOW_TOLERANCE))}


def fit_told(field_: DriveField, config: WorthConfig, seed: int, env_kwargs: dict, executor: Executor,
             store: TaskStore | None = None, progress: bool = True):
    """The told-load policy of ``field_`` (module docstring): the library valued at ``told_points``
    (kept in ``store`` as the tasks finish), the network fitted to their worth and written as an SB3
    policy in ``MDRDrive-v0(**env_kwargs)``. Returns the ``student.Student``, the library and a record
    (sizes, wall times, the fit's last loss and how its picks do at the labelled points)."""
    import torch

    torch.set_num_threads(config.torch_threads)
    t0 = time.perf_counter()
    library = field_library(field_)
    points = told_points(field_, config, seed)
    mu, mu1 = field_.friction
    quantum = float(env_kwargs.get("time_quantum", field_.drive.action_map().time_quantum))
    velocities = drive_values([(k, m, mu, mu1) for k, m in points], library.drives, executor, store,
                              "told: every drive at every point", time_quantum=quantum, drive=field_.drive)
    values_s = time.perf_counter() - t0
    x = told_observations(points, env_kwargs)
    structure = gym.make(ENV_ID).unwrapped.observation_structure
    ignored = (*range(structure["dynamics"].start, structure["previous_action"].stop),
               structure["episode_fraction"].start)
    network = DriveValueNetwork(x.shape[1], library.partners, structure["previous_action"], config.continuation,
                                (), config.arch, seed, ignored=ignored)
    none = np.zeros((len(x), 0))
    network.standardise_with(x, none)
    t1 = time.perf_counter()
    loss = network.fit(x, np.arange(len(x)), none, config.targets(velocities), config.steps, config.batch,
                       config.learning_rate, seed, 0.0, progress, top_weight=config.top_weight,
                       desc="told: worth network")
    fit_s = time.perf_counter() - t1
    picks = network.predicted_worth(x).argmax(axis=1)
    validation = None
    if config.validation_points:  # points the fit never saw, judged against the library's best
        held = draw_points(field_, config.validation_points, np.random.default_rng([seed, 1]),
                           SimpleNamespace(load_factor=config.load_factor, no_load_share=config.no_load_share))
        held_v = drive_values([(k, m, mu, mu1) for k, m in held], library.drives, executor,
                              None if store is None else TaskStore(store.folder.with_name(store.folder.name + "_validation")),
                              "told: validation points", time_quantum=quantum, drive=field_.drive)
        validation = pick_quality(held_v, network.predicted_worth(told_observations(held, env_kwargs)).argmax(axis=1))
    student = network.policy(env_kwargs, library.rows, seed, env_id=ENV_ID)
    record = {"drives": len(library.drives), "rows": len(library.rows), "points": len(points), "loss": loss,
              "labelled_points": pick_quality(velocities, picks), "validation_points": validation,
              "wall_time_s": {"values": round(values_s, 1), "fit": round(fit_s, 1),
                              "total": round(time.perf_counter() - t0, 1)}}
    return student, library, record


__all__ = ["WorthConfig", "field_library", "fit_told", "pick_quality", "told_observations", "told_points"]
