"""The friction-aware teacher's recipe: drive fields at several ratios mu1 / mu, distilled into one network.

    mdr-drive friction-teacher agents/configs/friction_teacher.yaml --out runs/friction_teacher

A full-observation policy trained at the paper's friction (mu = 0.3, mu1 = 0.1) plays, at other
friction, drives often far from the best ones. This recipe makes a teacher that is told friction:

1. **fields**: one ``DriveField`` per value of ``rho = mu1 / mu`` in ``rhos``, each searched at
   mu = 0.3, mu1 = 0.3 rho over a grid of k and load fractions (``FieldConfig`` with ``friction``);
   a field given in ``fields`` (with the same k grid) is loaded instead of searched;
2. **the teacher at any (k, load, mu, mu1)**: ``mdr_drive_agents.teacher.FrictionField``;
3. **student**: a plain SB3 PPO ``MlpPolicy`` on ``MDRDrive-v0``'s privileged observation (the full
   observation and mu, mu1) with friction drawn per episode, fitted to that teacher by
   ``mdr_drive_agents.student.distill`` (the same fit and hole rounds as the shipped generalist).

The result can teach a sensor policy (``mdr_drive_agents.train.sensor``) whose estimator learns mu
and mu1 as well as k and the load. Writes ``OUT/fields/rho*.npz``, ``OUT/policy/`` and
``OUT/friction_teacher.json`` (stage times); an existing ``OUT`` is refused unless ``--resume``
or ``--force``. ``--resume`` reuses the finished fields and the student's first round (round 0, most
of the student stage) as far as it got, its labelled episodes or its fit, kept in
``OUT/.tasks/student_round0.npz`` for the same fields and settings
(``mdr_drive_agents.student.checkpoint``); the hole rounds run again.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import time
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_range
from mdr_drive_env.files import write_text
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from ..run_record import RunLock, command_line, start_run
from ..student.distill import DistillConfig, check_drawn_friction, distill
from ..student.network import save_student
from ..teacher import DriveField, FieldConfig, FrictionField
from ..teacher.friction import FIELD_MU
from ..yaml_config import from_yaml
from .recipe import student_record

DEFAULT_CONFIG = Path(__file__).parents[1] / "configs" / "friction_teacher.yaml"


@dataclasses.dataclass(frozen=True)
class FrictionTeacherConfig:
    """The fields of the friction-aware teacher.

    Attributes:
        rhos: ratios mu1 / mu searched (-), each at mu = 0.3.
        fields: saved fields (.npz) used as they are instead of searching their rho (e.g. the
            recipe's ``teacher_field.npz`` at the paper's 1/3).
        friction_coefficient: (low, high) of mu drawn per training episode (-).
        base_friction_coefficient: (low, high) of mu1 drawn per training episode (-).
    """

    rhos: tuple[float, ...] = (0.175, 0.46, 0.65)
    fields: tuple[str, ...] = ()
    friction_coefficient: tuple[float, float] = (0.2, 0.4)
    base_friction_coefficient: tuple[float, float] = (0.07, 0.13)

    def __post_init__(self) -> None:
        for rho in self.rhos:
            check_range("rhos", rho, 0.0, 2.0, low_open=True)
        for name in ("friction_coefficient", "base_friction_coefficient"):
            lo, hi = getattr(self, name)
            check_range(name, lo, 0.0, 2.0)
            check_range(name, hi, lo, 2.0)


def search_fields(config: FrictionTeacherConfig, field_config: FieldConfig, out: Path, seed: int,
                  executor: Executor, resume: bool) -> list[DriveField]:
    """Every field of ``config``: loaded from ``config.fields`` or ``out/fields/rho*.npz`` (a finished
    one, with ``resume``), else searched at mu = 0.3, mu1 = 0.3 rho and saved there."""
    fields = [DriveField.load(p) for p in config.fields]
    for rho in config.rhos:
        path = out / "fields" / f"rho{rho:.3f}.npz"
        if resume and path.is_file():
            fields.append(DriveField.load(path))
            continue
        t0 = time.perf_counter()
        cfg = dataclasses.replace(field_config, friction=(FIELD_MU, round(FIELD_MU * rho, 9)))
        field = DriveField.search(cfg, seed=seed, executor=executor,
                                  store=TaskStore(task_folder(out, resume) / f"rho{rho:.3f}"))
        field.save(path)
        fields.append(field)
        print(f"friction_teacher: field rho = {rho:g}: {time.perf_counter() - t0:.0f} s", flush=True)
    return fields


@dataclasses.dataclass(frozen=True)
class FrictionRecipeConfig:
    """The friction-aware teacher's YAML (``agents/configs/friction_teacher.yaml``).

    Attributes:
        seed: seed of the fields' searches and of the student (-).
        friction: the ratios searched and the friction drawn per training episode.
        teacher: each field's grid, budgets and stages (its ``friction`` is set per field).
        distill: the student's distillation.
        ppo: the saved model's SB3 PPO settings.
        env_kwargs: the training domain, as ``MDRDrive-v0`` keywords (the friction ranges and the
            privileged observation are added).
    """

    seed: int
    friction: FrictionTeacherConfig
    teacher: FieldConfig
    distill: DistillConfig
    ppo: dict = dataclasses.field(default_factory=dict)
    env_kwargs: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        check_drawn_friction(self.distill, friction_drawn=True)  # the student's friction is always drawn here
        missing = [f for f in self.friction.fields if not Path(f).is_file()]
        if missing:
            raise ValueError(f"friction.fields {missing} are not files (saved drive fields, .npz)")


def load_config(path: str | Path) -> FrictionRecipeConfig:
    """The YAML at ``path``; unknown keys and bad values are a ``ValueError`` naming them."""
    return from_yaml(FrictionRecipeConfig, path)


def run(config_path: str | Path, out: str | Path, executor: Executor | None = None, resume: bool = False,
        force: bool = False, progress: bool = True) -> dict:
    """Fields, then the student (module docstring), into ``out``; returns what ``friction_teacher.json`` holds."""
    cfg = load_config(config_path)
    out, executor = start_run(out, resume, force, executor, progress)
    with RunLock(out):
        stages = {}
        t0 = time.perf_counter()
        field = FrictionField(search_fields(cfg.friction, cfg.teacher, out, cfg.seed, executor, resume))
        stages["fields_s"] = round(time.perf_counter() - t0, 1)
        t1 = time.perf_counter()
        f = cfg.friction
        env_kwargs = {**cfg.env_kwargs, "observation": "privileged", "friction_coefficient": list(f.friction_coefficient),
                      "base_friction_coefficient": list(f.base_friction_coefficient)}
        tasks = task_folder(out, resume=True)  # the fields' searches are done: keep a resumed run's checkpoint
        student = distill(field, cfg.distill, seed=cfg.seed, env_kwargs=env_kwargs, hyperparameters=cfg.ppo,
                          progress=progress, friction=(f.friction_coefficient, f.base_friction_coefficient),
                          checkpoint=tasks / "student_round0.npz")
        stages["student_s"] = round(time.perf_counter() - t1, 1)
        command = command_line()
        record = student_record(cfg.seed, env_kwargs, cfg.ppo, cfg.distill, student, stages["student_s"], command,
                                {"fields": [str(p) for p in cfg.friction.fields] + [
                                    str(out / "fields" / f"rho{rho:.3f}.npz") for rho in cfg.friction.rhos],
                                 "recipe": str(config_path)})
        save_student(student, out / "policy", record)
        stages["total_s"] = round(time.perf_counter() - t0, 1)
        summary = {"config": str(config_path), "command": command, "seed": cfg.seed, "stage_wall_time_s": stages,
                   "rhos": field.rhos.tolist(),
                   "field_mean_velocity_m_s": [float(np.mean(fl.velocities)) for fl in field.fields]}
        write_text(out / "friction_teacher.json", json.dumps(summary, indent=2))
        shutil.rmtree(tasks, ignore_errors=True)  # the fields and the student are written: their task files are spent
        print(f"friction_teacher: fields {stages['fields_s']:.0f} s, student {stages['student_s']:.0f} s; policy in "
              f"{out / 'policy'}", flush=True)
        return summary


__all__ = ["DEFAULT_CONFIG", "FrictionRecipeConfig", "FrictionTeacherConfig", "load_config", "run", "search_fields"]
