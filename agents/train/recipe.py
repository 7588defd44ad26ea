"""The recipe of a policy told k and the load, teacher to student, as one function driven by one YAML file.

    mdr-drive recipe agents/configs/recipe.yaml --out runs/recipe                  # make train
    mdr-drive recipe agents/configs/recipe.yaml --out runs/recipe --ray-address auto

Stages (each one's wall time is printed and kept in ``recipe.json``):

1. **teacher**: the best open-loop drives on a grid of k and load (``mdr_drive_agents.teacher``),
   one task per k slice on the sweep executor (local processes or Ray), kept in ``OUT/.tasks`` as
   they finish (``--resume`` continues an interrupted search); written to ``OUT/teacher_field.npz``.
2. **student**: a plain SB3 PPO ``MlpPolicy`` written to ``OUT/policy/`` as ``model.zip``,
   ``vecnormalize.pkl`` and ``run.json``, which ``PPO.load`` + ``VecNormalize.load`` play,
   ``mdr-drive evaluate`` and ``benchmark`` judge, and ``mdr-drive train --resume OUT/policy``
   fine-tunes with PPO. The YAML names one of two:

   - ``worth`` (``mdr_drive_agents.student.told``): every distinct drive of the teacher's field is
     played at random points of the domain, and a network that predicts each drive's worth from k
     and the load picks the best (the sensor policies' method, told the point); the labelled
     points are kept in ``OUT/.tasks`` as they finish;
   - ``distill`` (``mdr_drive_agents.student.distill``): a classifier fitted to the teacher's picks
     on its episodes, with optional DAgger and hole rounds.

An existing ``OUT`` is refused unless ``--resume`` or ``--force``. ``--resume`` continues an
interrupted run: the teacher's finished k slices are reused, and so are the worth student's
labelled points, or the distilled student's first round (round 0, most of its stage) as far as it
got, its labelled episodes or its fit, kept in ``OUT/.tasks/student_round0.npz`` for the same
teacher and settings (``mdr_drive_agents.student.checkpoint``); its hole rounds run again.
``--teacher FIELD.npz`` skips stage 1 and builds the student of that field (a recipe's
``teacher_field.npz``), for trying student settings without searching the teacher again.
``--snapshots`` also saves the distilled student after each hole round into
``OUT/snapshots/hole_round<H>/`` (the same files as ``OUT/policy/``), so one run shows what each
further hole round changes.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import sys
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mdr_drive_env.files import write_text
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from ..blas import PINNED_CORE, blas_core
from ..drive import PAPER_DRIVE, DriveDescription
from ..run_record import RunLock, command_line, policy_record, start_run
from ..student.distill import DistillConfig, distill
from ..student.network import save_student
from ..student.told import WorthConfig, field_library, fit_told
from ..teacher import DriveField, FieldConfig
from ..teacher.drive_table import build as build_table
from ..yaml_config import build, from_yaml
from .sb3 import ENV_ID, HELD_OUT_POINTS
from .sensor import TABLE_FILE, SensorRecipeConfig, policy_from_table

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "recipe.yaml"
#: The students a recipe can build (``RecipeConfig.student``).
STUDENTS = ("distill", "worth")
#: What ``--only`` builds alone.
ONLY = ("told",)


@dataclass(frozen=True)
class RecipeConfig:
    """The recipe YAML (``agents/configs/recipe.yaml``).

    Attributes:
        seed: seed of the teacher's search (-).
        teacher: the teacher's grid, budgets and stages.
        student: which section builds the student: ``"distill"`` or ``"worth"``.
        distill: the student's distillation (a codebook classifier fitted by DAgger).
        worth: the student as a network that predicts the worth of each of the field's whole drives and
            plays the best (``student.told``).
        ppo: the saved model's SB3 PPO settings (what ``mdr-drive train --resume`` fine-tunes it with).
        env_kwargs: the training domain and the env the student acts in, as ``MDRDrive-v0`` keywords.
        student_seed: seed of the student's network, episodes and minibatches (-); default ``seed``.
        sensor_policy: the sensor policy's table (``teacher.DriveTableConfig``: searched at draws of the
            hidden parameters from the teacher's drives, which join it) and training
            (``train.sensor.SensorRecipeConfig``); None: the recipe builds the told policy alone.
    """

    seed: int
    teacher: FieldConfig
    student: str = "distill"
    distill: DistillConfig | None = None
    worth: WorthConfig | None = None
    ppo: dict = field(default_factory=dict)
    env_kwargs: dict = field(default_factory=dict)
    student_seed: int | None = None
    sensor_policy: SensorRecipeConfig | None = None

    def __post_init__(self) -> None:
        for name in ("seed", "student_seed"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
                raise ValueError(f"{name}={value!r} must be an integer")
        if self.student not in STUDENTS:
            raise ValueError(f"student={self.student!r} is not one of {list(STUDENTS)}")
        if getattr(self, self.student) is None:
            raise ValueError(f"student={self.student!r} needs a '{self.student}' section in the recipe")

    @property
    def seeds(self) -> tuple[int, int]:
        """(the teacher's seed, the student's seed)."""
        return self.seed, self.seed if self.student_seed is None else self.student_seed


def load_recipe(path: str | Path) -> RecipeConfig:
    """The recipe YAML at ``path``; unknown keys and bad values are a ``ValueError`` naming them."""
    return from_yaml(RecipeConfig, path)


def student_record(seed: int, env_kwargs: dict, ppo: dict, config: DistillConfig, student, wall_time_s: float,
                   command: str, teacher: dict, drive: DriveDescription | None = None) -> dict:
    """The distilled student's ``run.json``: what ``mdr-drive train --resume`` and ``evaluate`` read
    (env keywords, the drive's among them, PPO settings, network), and where it came from (``teacher``:
    {"teacher" or "fields", "recipe"}, with the distillation settings and fit history added; ``drive``:
    the description it was built for, named)."""
    return policy_record(
        algo="ppo", seed=seed, env_id=ENV_ID, env_kwargs=env_kwargs,
        hyperparameters={**dict(ppo), "normalize": True, "warm_start": "none",
                         "policy_kwargs": {"net_arch": {"pi": list(config.net_arch), "vf": [64, 64]},
                                           "activation_fn": config.activation, "log_std_init": config.log_std}},
        distilled_from={**teacher, "distill": {key: getattr(config, key) for key in config.__dataclass_fields__},
                        "history": student.history},
        held_out_points=HELD_OUT_POINTS, command=command, torch_threads=config.torch_threads, wall_time_s=wall_time_s,
        drive=None if drive is None else drive.to_record())


def worth_record(seed: int, env_kwargs: dict, ppo: dict, config: WorthConfig, student, picks: dict,
                 wall_time_s: float, command: str, teacher: dict, drive: DriveDescription | None = None) -> dict:
    """The told-load worth policy's ``run.json`` (``student.told``): as :func:`student_record`, its
    provenance under ``picks_from`` (the teacher, the settings, the library's size and how its picks
    do at the labelled points) and its network's actual layer sizes."""
    import torch

    layers = [m.out_features for m in student.model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    return policy_record(
        algo="ppo", seed=seed, env_id=ENV_ID, env_kwargs=env_kwargs,
        hyperparameters={**dict(ppo), "normalize": True, "warm_start": "none",
                         "policy_kwargs": {"net_arch": {"pi": layers, "vf": [64, 64]}, "activation_fn": "relu"}},
        picks_from={**teacher, "observation": "told", "worth": dataclasses.asdict(config), **picks},
        held_out_points=HELD_OUT_POINTS, command=command, torch_threads=config.torch_threads, wall_time_s=wall_time_s,
        drive=None if drive is None else drive.to_record())


def searched_with_another_config(field: DriveField, config: FieldConfig) -> bool:
    """Whether ``field`` was searched with settings other than ``config`` (keys its saved config
    lacks, top-level or in a stage's mapping, added to ``FieldConfig`` and its stages since, count at
    their defaults; a saved key ``FieldConfig`` no longer has makes it another)."""
    def as_json(c) -> dict:
        return json.loads(json.dumps(dataclasses.asdict(c)))

    try:
        saved = build(FieldConfig, field.meta.get("config", {}), "the field's saved config")
    except ValueError:
        return True
    return as_json(saved) != as_json(config)


def on_drive(recipe: RecipeConfig, drive: DriveDescription) -> RecipeConfig:
    """``recipe`` for ``drive``: the teacher searches the drive's k range at its friction, and the
    student's env (its run.json's ``env_kwargs``) is the drive's, over its k and load ranges."""
    teacher = dataclasses.replace(recipe.teacher, k_range=drive.k_range, friction=drive.nominal_friction)
    env_kwargs = {**recipe.env_kwargs, **drive.env_kwargs, "k": list(drive.k_range),
                  "load_ratio": list(drive.load_ratio_range)}
    return dataclasses.replace(recipe, teacher=teacher, env_kwargs=env_kwargs)


def run(config_path: str | Path, out: str | Path, executor: Executor | None = None, resume: bool = False,
        force: bool = False, progress: bool = True, teacher: str | Path | None = None, snapshots: bool = False,
        drive: DriveDescription | None = None, student_kind: str | None = None, only: str | None = None,
        sensor_tier: str | None = None) -> dict:
    """Run the recipe into ``out`` (with ``teacher``: that saved field instead of stage 1; with
    ``snapshots``: the student after each hole round in ``out/snapshots/hole_round<H>/`` too; with
    ``drive``: for that drive, :func:`on_drive`; with ``student_kind``: that student (``STUDENTS``)
    instead of the YAML's; with ``only="told"``: no sensor policy; with ``sensor_tier``: the sensor
    policy's tier instead of the YAML's); returns what ``recipe.json`` holds."""
    recipe = load_recipe(config_path)
    if only is not None and only not in ONLY:
        raise ValueError(f"only={only!r} is not one of {list(ONLY)}")
    if student_kind is not None:
        recipe = dataclasses.replace(recipe, student=student_kind)
    sensor = None if only == "told" else recipe.sensor_policy
    if sensor is not None and sensor_tier is not None:
        sensor = dataclasses.replace(sensor, sensor=dataclasses.replace(sensor.sensor, sensor_tier=sensor_tier))
    elif sensor is None and sensor_tier is not None:
        raise ValueError(f"--sensor-tier {sensor_tier}: no sensor policy is built ({config_path} has no "
                         "'sensor_policy' section, or --only told)")
    if sensor is not None and drive is not None:
        drive.sensor_env_kwargs()  # its hidden ranges: a one-line error before any search
    if snapshots and recipe.student == "worth":
        raise ValueError(f"--snapshots saves a 'distill' student after each hole round; {config_path}'s student is "
                         "'worth', which has none")
    if drive is not None:
        recipe = on_drive(recipe, drive)
    out, executor = start_run(out, resume, force, executor, progress)
    with RunLock(out):
        (seed, student_seed), stages = recipe.seeds, {}
        command = command_line()

        tasks = task_folder(out, resume)
        core = blas_core()
        if teacher is None and core not in (None, PINNED_CORE):
            print(f"recipe: warning: numpy's OpenBLAS runs its {core!r} kernels, not {PINNED_CORE!r} (numpy was loaded "
                  f"before mdr_drive_agents, or OPENBLAS_CORETYPE is set): the teacher's CMA-ES searches round differently "
                  f"in the last bits, and its drives will differ from the shipped teacher's", file=sys.stderr)
        t0 = time.perf_counter()
        if teacher is None:
            field = DriveField.search(recipe.teacher, seed=seed, executor=executor, store=TaskStore(tasks / "teacher"),
                                      drive=drive or PAPER_DRIVE)
        else:
            try:
                field = DriveField.load(teacher)
            except (OSError, ValueError, KeyError, zipfile.BadZipFile) as e:
                raise ValueError(f"--teacher {teacher} is not a saved teacher field ({type(e).__name__}: {e})") from None
            if drive is not None and field.drive.settings != drive.settings:
                raise ValueError(f"--teacher {teacher} was searched on another drive than {drive.name}")
            if searched_with_another_config(field, recipe.teacher):
                print(f"recipe: warning: {teacher} was searched with another teacher config than {config_path}'s",
                      file=sys.stderr)
        field.save(out / "teacher_field.npz")
        stages["teacher_s"] = round(time.perf_counter() - t0, 1)
        print(f"recipe: teacher {stages['teacher_s']:.0f} s{' (loaded)' if teacher else ''}: {field.velocities.size} "
              f"grid points, {field.meta.get('exchanged', 0)} drives taken from a neighbour", flush=True)
        if not teacher and field.meta.get("stage_wall_time_s"):
            print("recipe: teacher stages: " + ", ".join(f"{name} {s:.0f} s" for name, s in
                                                      field.meta["stage_wall_time_s"].items()), flush=True)

        t1 = time.perf_counter()
        teacher_record = {"teacher": str(out / "teacher_field.npz"), "recipe": str(config_path)}

        def save_snapshot(student, round_record: dict) -> None:
            if snapshots and "hole_round" in round_record:
                record = student_record(student_seed, recipe.env_kwargs, recipe.ppo, recipe.distill, student,
                                        round(time.perf_counter() - t1, 1), command, teacher_record, drive)
                save_student(student, out / "snapshots" / f"hole_round{round_record['hole_round']}", record)

        if recipe.student == "worth":
            student, _, picks = fit_told(field, recipe.worth, student_seed, recipe.env_kwargs, executor,
                                         TaskStore(tasks / "told_values"), progress)
            print("recipe: told: " + ", ".join(f"{key} {value:.3g}" for key, value in
                                               picks["labelled_points"].items() if value is not None), flush=True)
            stages["student_s"] = round(time.perf_counter() - t1, 1)
            record = worth_record(student_seed, recipe.env_kwargs, recipe.ppo, recipe.worth, student, picks,
                                  stages["student_s"], command, teacher_record, drive)
        else:
            student = distill(field, recipe.distill, seed=student_seed, env_kwargs=recipe.env_kwargs,
                              hyperparameters=recipe.ppo, progress=progress, on_round=save_snapshot,
                              checkpoint=tasks / "student_round0.npz")
            stages["student_s"] = round(time.perf_counter() - t1, 1)
            record = student_record(student_seed, recipe.env_kwargs, recipe.ppo, recipe.distill, student,
                                    stages["student_s"], command, teacher_record, drive)
        save_student(student, out / "policy", record)
        print(f"recipe: student {stages['student_s']:.0f} s; policy in {out / 'policy'}", flush=True)
        sensor_summary = None
        if sensor is not None:
            t2 = time.perf_counter()
            table = build_table(sensor.table, executor, tasks / "sensor_table", field_library(field), field.drive)
            table.save(out / TABLE_FILE)
            stages["sensor_table_s"] = round(time.perf_counter() - t2, 1)
            print(f"recipe: sensor table {stages['sensor_table_s']:.0f} s: {len(table.drives)} drives, coverage "
                  f"{table.record['coverage']}", flush=True)
            sensor_summary = policy_from_table(table, sensor, sensor.sensor, out, out / "sensor_policy", tasks,
                                               executor, progress, command, str(config_path), drive=field.drive)
            stages["sensor_policy_s"] = sensor_summary["wall_time_s"]
            print(f"recipe: sensor policy {stages['sensor_policy_s']:.0f} s; policy in {out / 'sensor_policy'}",
                  flush=True)
        stages["total_s"] = round(time.perf_counter() - t0, 1)
        print(f"recipe: total {stages['total_s']:.0f} s", flush=True)
        summary = {"config": str(config_path), "command": command, "seed": seed, "student_seed": student_seed,
                   "student": recipe.student,
                   "drive": None if drive is None else drive.to_record(),
                   "stage_wall_time_s": stages,
                   "teacher_stage_wall_time_s": field.meta.get("stage_wall_time_s"),
                   "teacher_loaded_from": None if teacher is None else str(teacher), "blas_core": core,
                   "executor": f"ray ({executor.ray_address})" if executor.is_ray else f"local ({executor.workers or 'all'} workers)",
                   "teacher_grid": {"k": field.ks.tolist(), "load_fractions": field.fractions.tolist()},
                   "teacher_mean_velocity_m_s": float(np.mean(field.velocities)),
                   "sensor_policy": sensor_summary}
        write_text(out / "recipe.json", json.dumps(summary, indent=2))
        shutil.rmtree(tasks, ignore_errors=True)  # the teacher and the student are written: their task files are spent
        return summary


__all__ = ["DEFAULT_CONFIG", "ONLY", "STUDENTS", "RecipeConfig", "load_recipe", "run", "searched_with_another_config", "student_record",
           "worth_record"]
