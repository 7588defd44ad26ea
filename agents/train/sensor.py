"""The sensor policy's recipe: a plain SB3 PPO MlpPolicy that drives without being told k, the load or
friction, by picking whole drives from a table.

    mdr-drive train-sensor agents/configs/sensor.yaml --out runs/sensor        # make train-sensor

1. **The drive table** (``teacher.DriveTable``): fixed actions and two-action cycles that CMA-ES finds
   at draws of the hidden parameters, a few hundred picked to cover the hidden range; or a table built
   before (``drive_table``, ``--reuse``).
2. **Their values**: every drive of the table played at the hidden points of the training episodes
   (``episodes`` draws of ``MDRDriveSensor-v0``, a share with a load step), kept as
   ``OUT/episode_values.npz``; each row's worth at a point follows from them
   (``student.DriveValueTargets``).
3. **Rounds of DAgger** (Ross et al. 2011): round 0 is driven by the table's best drive told the hidden
   point, rounds 1 ... R by the network itself, a share ``explore`` of the periods playing a random row;
   after each round the network (``student.DriveValueNetwork``) is fitted on every episode so far: the
   worth of every drive at each period's hidden point from the sensor observation, and the hidden entries
   the motion can tell (k, the load over mu F_ref, the load, mu1 / mu) beside it. It plays the drive of
   the highest predicted worth (``student.pick_rows``: a cycle's actions in turn): the best decision under
   what the sensor cannot tell.
4. **One network**: written as one SB3 ``MlpPolicy`` over ``Discrete(rows)`` (``OUT/policy/``, the table's
   rows as ``action_codebook.npy``), its estimates as ``estimator.npz``.

The network of the last round is written, or with ``keep_best_round`` that of the round whose
validation ranks best. Each round is validated on ``validation_seed``'s draws (``validation_points`` of them, and
``validation_load_steps`` load-step episodes): the steady velocity's fraction of the table's best drive
there, points below the trapezoid, load steps recovered, the estimates' errors. A Ctrl-C once
round 0's fit has finished saves the policy of the last finished round (``"interrupted": true``) and exits
with 130; the table's and the values' sweeps are kept as they finish (``--resume`` continues them).
"""

from __future__ import annotations

import hashlib
import json
import shutil
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_bool, check_int, check_range
from mdr_drive_env.files import atomic_path, write_text
from mdr_drive_env.gym_envs.sensor import DEFAULT_ENCODER_NOISE, DEFAULT_TRACE_SAMPLES, SensorTier
from mdr_drive_env.gym_envs.spaces import PrivilegedLayout
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from ..drive import PAPER_DRIVE, DriveDescription
from ..policy import ESTIMATOR_FILE, package_path, read_run
from ..protocol import SENSOR_ID, draw_hidden, hidden_point, steady_velocity_of
from ..run_record import RunLock, command_line, policy_record
from ..student.drive_values import DriveValueNetwork, DriveValueTargets, check_fit_settings, pick_rows
from ..student.estimator import FINE_TUNE_PPO, hidden_entries, standardised_error
from ..student.network import save_student
from ..teacher.drive_table import DriveTable, DriveTableConfig, build, drive_values
from ..yaml_config import from_yaml
from ..sensor_episodes import collect_rows, episode_points, sensor_env_kwargs, sensor_envs

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "sensor.yaml"
TABLE_FILE = "drive_table.npz"
VALUES_FILE = "episode_values.npz"
#: The privileged observation's entries the network estimates beside the worth of its rows.
ESTIMATED = tuple(PrivilegedLayout.NAMES[i] for i in hidden_entries(PrivilegedLayout))
#: Validation: hidden draws without a load step (30 periods), and load-step episodes (40 periods, the
#: step before period 20), as the report (``benchmarks.adaptation``) plays them.
VALIDATION_POINTS = 64
VALIDATION_STEPS = 32


@dataclass(frozen=True)
class SensorConfig:
    """Training of the sensor policy (module docstring).

    Attributes:
        history: periods of the sensor observation (-).
        episodes: training episodes, each a draw of the hidden parameters, driven again in every round (-).
        periods: periods per episode (-).
        load_step_share: share of the episodes with a load step (-).
        load_step_periods: (first, last) period index at which a load step may fall (-).
        explore: share of the periods in which a random row is played instead (-), so that the episodes
            show the network the slider's answer to other drives than its own.
        arch: hidden layer sizes of the network (-).
        rounds: rounds driven by the network, after round 0 (-).
        steps: Adam steps of the fit after each round (-).
        batch: minibatch size (-).
        learning_rate: Adam step size, decaying linearly to zero over each fit (-).
        estimate_weight: weight of the estimates' squared error beside the worth's in the fit (-).
        continuation: ``student.pick_rows``' weight: a row costs this times the squared distance between the
            previous action and its partner, so that a cycle's actions alternate and another drive is started
            only where it is worth more by that margin (-).
        play_switch_cost: ``student.pick_rows``' switch cost in the policy as written (the rounds drive
            without it): a row that does not continue the drive just played costs this besides (-). The
            continuation term prices a switch by how far the actions are apart, so between two good drives
            whose actions lie close it costs almost nothing; yet each switch breaks a cycle, and a pick that
            hops between such drives every period can drive far below either.
        knee: ``DriveValueTargets.knee`` (-).
        shortfall_weight: ``DriveValueTargets.shortfall_weight`` (-).
        below_weight: ``DriveValueTargets.below_weight`` (-).
        torch_threads: torch threads of the fits (-).
        keep_best_round: keep the network of the round whose validation ranks best (fewest draws below the
            trapezoid, then the largest sum of the mean and the lowest fraction of the table's best), not the
            last round's; needs the recipe's ``validation_seed``. The rounds' validation swings from round to
            round, and a later round can lose what an earlier one had.
        sensor_tier: what the drive measures, ``MDRDriveSensor-v0(sensor_tier=...)``: ``"encoder"``
            (per-period summaries), ``"trace"`` (also positions through each period) or
            ``"self-sensing"`` (also the piezo-sensed peak forces).
        trace_samples: position samples per period of the ``trace`` and ``self-sensing`` tiers (-).
        encoder_noise: standard deviation of each position sample (m).
    """

    history: int = 4
    episodes: int = 6000
    periods: int = 40
    load_step_share: float = 0.5
    load_step_periods: tuple[int, int] = (5, 30)
    explore: float = 0.05
    arch: tuple[int, ...] = (512, 512)
    rounds: int = 6
    steps: int = 15000
    batch: int = 512
    learning_rate: float = 1e-3
    estimate_weight: float = 0.2
    continuation: float = 0.02
    play_switch_cost: float = 0.0
    knee: float = 0.85
    shortfall_weight: float = 1.0
    below_weight: float = 5.0
    torch_threads: int = 1
    keep_best_round: bool = False
    sensor_tier: str = "encoder"
    trace_samples: int = DEFAULT_TRACE_SAMPLES
    encoder_noise: float = DEFAULT_ENCODER_NOISE

    def __post_init__(self) -> None:
        for name in ("history", "episodes", "periods"):
            check_int(name, getattr(self, name), 1)
        check_int("rounds", self.rounds, 0)
        check_fit_settings(self)
        check_bool("keep_best_round", self.keep_best_round)
        lo, hi = self.load_step_periods
        if not (isinstance(lo, int) and isinstance(hi, int) and 1 <= lo <= hi <= self.periods - 1):
            raise ValueError(f"load_step_periods={self.load_step_periods!r} is outside the allowed range "
                             f"1 <= first <= last <= periods - 1 = {self.periods - 1}")
        for name in ("load_step_share", "explore", "play_switch_cost"):
            check_range(name, getattr(self, name), 0.0, 1.0)
        check_range("estimate_weight", self.estimate_weight, 0.0, 100.0)
        SensorTier(self.sensor_tier, self.trace_samples, self.encoder_noise)  # its own checks

    def targets(self, velocities: np.ndarray) -> DriveValueTargets:
        """Each drive's worth at the hidden points of ``velocities`` (points, drives) m/s."""
        return DriveValueTargets.of(velocities, self)


@dataclass(frozen=True)
class SensorRecipeConfig:
    """The sensor recipe's YAML (``agents/configs/sensor.yaml``).

    Attributes:
        seed: seed of the training episodes and the network (-).
        sensor: the training (``SensorConfig``).
        table: how the drive table is made (``teacher.DriveTableConfig``), unless ``drive_table`` is given.
        drive_table: a drive table saved before (``DriveTable.save``), used instead of building one.
        validation_seed: seed of the hidden draws each round is validated on (-); None: no validation.
        validation_points: draws without a load step each round is validated on (>= 1).
        validation_load_steps: load-step episodes each round is validated on (>= 1).
    """

    seed: int
    sensor: SensorConfig
    table: DriveTableConfig = DriveTableConfig()
    drive_table: str | None = None
    validation_seed: int | None = None
    validation_points: int = VALIDATION_POINTS
    validation_load_steps: int = VALIDATION_STEPS

    def __post_init__(self) -> None:
        check_int("seed", self.seed, 0)
        check_int("validation_points", self.validation_points, 1)
        check_int("validation_load_steps", self.validation_load_steps, 1)
        if self.sensor.keep_best_round and self.validation_seed is None:
            raise ValueError("keep_best_round=True needs a validation_seed: the rounds are ranked on its draws")
        if self.drive_table is not None and not package_path(self.drive_table).is_file():
            raise ValueError(f"drive_table={self.drive_table!r} is not a file")
        polish = self.table.polish_from
        if self.drive_table is None and polish is not None:
            if not (package_path(polish) / "model.zip").is_file():
                raise ValueError(f"polish_from={polish!r} is not a policy folder (no model.zip)")
            if read_run(package_path(polish)).get("env_kwargs", {}).get("observation") == "sensor":
                raise ValueError(f"polish_from={polish!r} is not a full-observation policy (its run.json: "
                                 "observation='sensor'): the searches start from its drive told the hidden values")


class Validation:
    """How the network does on ``seed``'s hidden draws (``points`` without a load step, ``load_steps``
    with one before period 20 of 40, as the report plays them): its steady
    velocity's fraction of the table's best drive there (where that moves >= 2 mm/s), points below the
    trapezoid, load steps recovered (``benchmarks.adaptation.recovery``), and its estimates'
    standardised errors over the periods after the first ``history``. The draws are of ``drive``'s
    sensor env (``DriveDescription.sensor_env_kwargs``)."""

    def __init__(self, config: SensorConfig, table: DriveTable, seed: int, points: int, load_steps: int,
                 drive: DriveDescription = PAPER_DRIVE):
        from ..benchmarks.load_steps import STEP_EPISODE_PERIODS, STEP_PERIOD

        self.config, self.table, self.seed, self.drive = config, table, seed, drive
        self.points = draw_hidden(points, seed, drive=drive)
        self.steps = draw_hidden(load_steps, seed + 1, step_period=STEP_PERIOD, drive=drive)
        self.step_period, self.step_periods = STEP_PERIOD, STEP_EPISODE_PERIODS
        self.velocities = drive_values([hidden_point(d) for d in self.points], table.drives,
                                       Executor(workers=1, progress=False), drive=drive)

    def play(self, network: DriveValueNetwork, draws: list[dict], periods: int):
        """``collect_rows`` of the network at ``draws`` (one episode each)."""
        import gymnasium as gym

        kwargs = {**sensor_env_kwargs(self.config, self.drive), "max_periods": periods, "action_codebook": self.table.rows}
        envs = [gym.make(SENSOR_ID, **kwargs) for _ in draws]
        obs = []
        for env, d in zip(envs, draws):
            options = {key: d[key] for key in ("k", "cargo_mass", "friction_coefficient", "base_friction_coefficient")}
            if "step_cargo_mass" in d:
                options["load_step"] = (self.step_period, d["step_cargo_mass"])
            obs.append(env.reset(seed=0, options=options)[0])
        return collect_rows(envs, np.array(obs), lambda o, point: network.act(o),
                            hidden=hidden_entries(PrivilegedLayout))

    def __call__(self, network: DriveValueNetwork) -> dict:
        from ..benchmarks.load_steps import recovery
        from ..benchmarks.targets import velocity_statistics

        sensed, _, privileged, disp = self.play(network, self.points, 30)
        stats = velocity_statistics(self.velocities[:, 0], self.velocities.max(axis=1),
                                    steady_velocity_of(disp, period=self.drive.period))
        step_disp = self.play(network, self.steps, self.step_periods)[3]
        scored = [r[2] for r in (recovery(d / self.drive.period) for d in step_disp.T) if r[2] is not None]
        settled = slice(self.config.history * len(self.points), None)  # rows are period-major
        err = standardised_error(network.estimates(sensed[settled]), privileged[settled])
        return {"val_mean_fraction_of_table": stats["fraction_of_best_mean"],
                "val_min_fraction_of_table": stats["fraction_of_best_min"], "val_points_scored": stats["points_scored"],
                "val_points_below_trapezoid": stats["points_below_trapezoid"],
                "val_load_steps_recovered": int(sum(scored)), "val_load_steps_scored": len(scored),
                **{f"val_error_{name}": float(e) for name, e in zip(ESTIMATED, err)}}


def _log(record: dict) -> None:
    print(" ".join(f"{key}={value:.4g}" if isinstance(value, float) else f"{key}={value}"
                   for key, value in record.items()), flush=True)


def values_fingerprint(table: DriveTable, config: SensorConfig, seed: int, drive: DriveDescription = PAPER_DRIVE) -> str:
    """What the training episodes' values depend on: the table's drives, the episodes' draws and seed, the
    drive's sensor env."""
    draws = {key: getattr(config, key) for key in ("episodes", "load_step_share", "load_step_periods")}
    payload = (np.asarray(table.drives, dtype=np.float64).tobytes()
               + json.dumps([draws, seed, drive.sensor_env_kwargs()], sort_keys=True).encode())
    return hashlib.sha256(payload).hexdigest()


def episode_values(table: DriveTable, config: SensorConfig, seed: int, out: Path, executor: Executor, tasks: Path,
                   reuse: Path | None = None, drive: DriveDescription = PAPER_DRIVE
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The training episodes' hidden points on ``drive`` (``episode_points``' index and step) and every
    drive's steady velocity at them (points, drives) m/s: from ``reuse``'s ``VALUES_FILE`` if it holds
    them for the same table, episodes and drive, else computed (a sweep) and written to ``out``."""
    key = values_fingerprint(table, config, seed, drive)
    for folder in (out, reuse):
        path = None if folder is None else Path(folder) / VALUES_FILE
        if path is not None and path.is_file():
            with np.load(path, allow_pickle=False) as f:
                if str(f["fingerprint"]) == key:
                    if folder != out:
                        shutil.copyfile(path, out / VALUES_FILE)
                    return f["index"], f["step"], f["velocities"]
    envs, _ = sensor_envs(config, config.episodes, seed, drive=drive)
    points, index, step = episode_points(envs)
    velocities = drive_values(points, table.drives, executor, TaskStore(tasks / "episode_values"),
                              "sensor: drive values at the episodes' hidden points", drive=drive)
    with atomic_path(out / VALUES_FILE) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, fingerprint=np.array(key), index=index, step=step, velocities=velocities)
    return index, step, velocities


def train(config: SensorConfig, table: DriveTable, index: np.ndarray, step: np.ndarray, velocities: np.ndarray,
          seed: int = 0, validate: Validation | None = None, progress: bool = True, drive: DriveDescription = PAPER_DRIVE):
    """Round 0, driven by the table's best drive told the hidden point, then ``config.rounds`` rounds
    driven by the network, each followed by a fit on every episode so far (module docstring), in the
    sensor env of ``drive`` (the one ``episode_values`` valued the episodes of). Returns
    the network, the per-round records (the kept round's marked ``"kept": true``) and whether a Ctrl-C cut
    it short. The network kept is the last finished round's, or with ``config.keep_best_round`` and a
    ``validate``, the round whose validation ranks best (``round_rank``); before round 0's fit had
    finished, the Ctrl-C is raised."""
    import copy

    import torch

    torch.set_num_threads(config.torch_threads)
    targets = config.targets(velocities)
    hidden = hidden_entries(PrivilegedLayout)
    partners = table.partners
    rng = np.random.default_rng(seed)
    data, history = [], []
    network = kept = None
    kept_round = 0
    try:
        for r in range(config.rounds + 1):
            t0 = time.perf_counter()
            envs, first = sensor_envs(config, config.episodes, seed, codebook=table.rows, drive=drive)
            structure = envs[0].unwrapped.observation_structure
            newest = slice(structure["actions"].start, structure["actions"].start + 5)  # the previous action
            if r == 0:  # the table's best drive, told the hidden point
                driver = lambda obs, point: pick_rows(targets.worth[point], obs[:, newest], partners,  # noqa: E731
                                                      config.continuation)
            else:
                driver = lambda obs, point: network.act(obs)  # noqa: E731
            data.append(collect_rows(envs, first, driver, index, step, config.explore, rng, hidden)[:3])
            x, point, estimates = (np.concatenate(d) for d in zip(*data))
            if network is None:
                network = DriveValueNetwork(x.shape[1], partners, newest, config.continuation, ESTIMATED, config.arch,
                                            seed, ignored=(structure["episode_fraction"].start,))
                network.standardise_with(x, estimates)
            loss = network.fit(x, point, estimates, targets, config.steps, config.batch, config.learning_rate,
                               seed + r, config.estimate_weight, progress)
            record = {"round": r, "samples": len(x), "loss": loss}
            if validate is not None:
                record.update(validate(network))
            record["wall_time_s"] = round(time.perf_counter() - t0, 1)
            history.append(record)
            if kept is None or not (config.keep_best_round and validate is not None) or (
                    round_rank(record) > round_rank(history[kept_round])):
                kept, kept_round = copy.deepcopy(network.state()), r
            _log(record)
    except KeyboardInterrupt:
        if kept is None:
            raise
        network.load_state(kept)
        print(f"sensor: interrupted; the network of round {kept_round} is kept ({len(history)} finished)", flush=True)
        history[kept_round]["kept"] = True
        return network, history, True
    network.load_state(kept)
    history[kept_round]["kept"] = True
    return network, history, False


def round_rank(record: dict) -> tuple[int, float]:
    """How a round's validation ranks (larger is better): fewer points below the trapezoid, then a larger
    sum of the mean and the lowest fraction of the table's best drive."""
    return (-record["val_points_below_trapezoid"],
            record["val_mean_fraction_of_table"] + record["val_min_fraction_of_table"])


def merge_check(student, network: DriveValueNetwork, config: SensorConfig, table: DriveTable, seed: int,
                drive: DriveDescription = PAPER_DRIVE) -> dict:
    """How many of the actions the SB3 policy plays differ from the network's, over the sensor
    observations of 16 episodes the network drives on ``drive`` (none should)."""
    envs, first = sensor_envs(config, 16, seed + 7, codebook=table.rows, drive=drive)
    sensed = collect_rows(envs, first, lambda obs, point: network.act(obs))[0]
    differ = np.any(student.act(sensed) != table.rows[network.act(sensed)], axis=1)  # a fixed drive's rows are equal
    return {"merge_rows_differ": int(differ.sum()), "merge_rows_checked": len(sensed)}


def load_config(path: str | Path) -> SensorRecipeConfig:
    """The sensor recipe of the YAML at ``path`` (``SensorRecipeConfig``)."""
    return from_yaml(SensorRecipeConfig, path)


def run(config_path: str | Path, out: str | Path, force: bool = False, progress: bool = True,
        sensor_tier: str | None = None, reuse: str | Path | None = None, resume: bool = False,
        executor: Executor | None = None) -> dict:
    """Train the sensor policy of ``config_path`` (its ``sensor_tier`` replaced by ``sensor_tier`` if
    given) into ``out``; returns what ``adapt.json`` holds. ``reuse``: an earlier run's folder whose drive
    table (and training episodes' values, where they match) are used instead of building them.
    ``resume``: continue the table's and the values' sweeps of an interrupted run in ``out``."""
    recipe = load_config(config_path)
    config = recipe.sensor if sensor_tier is None else replace(recipe.sensor, sensor_tier=sensor_tier)
    out = Path(out)
    if reuse is not None and not (Path(reuse) / TABLE_FILE).is_file():
        raise ValueError(f"--reuse {reuse}: no {TABLE_FILE} in it")
    if out.exists() and any(p.name != ".tasks" for p in out.iterdir()) and not (force or resume):
        raise ValueError(f"{out} is not empty: overwrite with --force")
    with RunLock(out):
        return _run(config_path, out, recipe, config, progress, reuse, resume, executor or Executor())


def _run(config_path, out: Path, recipe: SensorRecipeConfig, config: SensorConfig, progress: bool, reuse, resume: bool,
         executor: Executor) -> dict:
    command = command_line()
    t0 = time.perf_counter()
    tasks = task_folder(out, resume)
    if reuse is not None:
        table = DriveTable.load(Path(reuse) / TABLE_FILE)
    elif recipe.drive_table is not None:
        table = DriveTable.load(package_path(recipe.drive_table))
    else:
        table = build(recipe.table, executor, tasks / "table")
    table.save(out / TABLE_FILE)
    table_s = round(time.perf_counter() - t0, 1)
    summary = policy_from_table(table, recipe, config, out, out / "policy", tasks, executor, progress, command,
                                str(config_path), reuse)
    summary["stage_times_s"] = {"table_s": table_s, **summary["stage_times_s"]}
    summary["wall_time_s"] = round(time.perf_counter() - t0, 1)
    write_text(out / "adapt.json", json.dumps(summary, indent=2))
    shutil.rmtree(tasks, ignore_errors=True)
    print(f"sensor: {summary['wall_time_s']:.0f} s; policy in {out / 'policy'}", flush=True)
    return summary


def policy_from_table(table: DriveTable, recipe: SensorRecipeConfig, config: SensorConfig, values_folder: Path,
                      policy_folder: Path, tasks: Path, executor: Executor, progress: bool, command: str,
                      config_name: str, reuse: Path | None = None, drive: DriveDescription = PAPER_DRIVE) -> dict:
    """The sensor policy of ``drive`` that picks from ``table``: the training episodes' values (kept in
    ``values_folder``, or taken from ``reuse``'s), the rounds, the policy written to ``policy_folder``
    with its ``estimator.npz``; returns the run's summary (its stage times, rounds and merge check)."""
    t0 = time.perf_counter()
    times = {}
    index, step, velocities = episode_values(table, config, recipe.seed, values_folder, executor, tasks, reuse, drive)
    times["values_s"] = round(time.perf_counter() - t0, 1)
    validate = None if recipe.validation_seed is None else Validation(
        config, table, recipe.validation_seed, recipe.validation_points, recipe.validation_load_steps, drive)
    network, history, interrupted = train(config, table, index, step, velocities, recipe.seed, validate, progress,
                                          drive)
    times["rounds_s"] = round(time.perf_counter() - t0 - times["values_s"], 1)
    env_kwargs = sensor_env_kwargs(config, drive)
    network.switch_cost = config.play_switch_cost
    student = network.policy(env_kwargs, table.rows, recipe.seed)
    check = merge_check(student, network, config, table, recipe.seed, drive)
    _log(check)
    wall = round(time.perf_counter() - t0, 1)
    record = policy_record(
        algo="ppo", seed=recipe.seed, env_id=SENSOR_ID, env_kwargs=env_kwargs,
        hyperparameters={**FINE_TUNE_PPO, "normalize": True, "warm_start": "none",
                         "policy_kwargs": {"net_arch": {"pi": list(config.arch), "vf": [64, 64]}, "activation_fn": "relu"}},
        picks_from={"config": config_name, "sensor": asdict(config), "drive_table": table.record,
                    "drives": len(table.drives), "rows": len(table.rows), "validation_seed": recipe.validation_seed,
                    "validation_points": recipe.validation_points,
                    "validation_load_steps": recipe.validation_load_steps, "history": history, "merged": check},
        command=command, torch_threads=config.torch_threads, wall_time_s=wall, interrupted=interrupted,
        drive=None if drive.is_paper else drive.to_record())
    save_student(student, policy_folder, record)
    network.estimator().save(policy_folder / ESTIMATOR_FILE)  # what the report plots the estimates with
    return {"config": config_name, "command": command, "seed": recipe.seed, "wall_time_s": wall,
            "stage_times_s": times, "drives": len(table.drives), "rows": len(table.rows),
            "table_coverage": table.record.get("coverage"), "rounds": history, "merged": check,
            "interrupted": interrupted}


__all__ = ["DEFAULT_CONFIG", "ESTIMATED", "SensorConfig", "SensorRecipeConfig", "TABLE_FILE", "VALUES_FILE",
           "Validation", "episode_values", "load_config", "merge_check", "policy_from_table", "round_rank", "run", "train", "values_fingerprint"]
