"""A teacher that knows friction: drive fields at several ratios mu1 / mu, distilled into one network.

    python -m mdr_drive_agents.friction_teacher agents/configs/friction_teacher.yaml --out runs/friction_teacher

The shipped generalist was trained at the paper's friction (mu = 0.3, mu1 = 0.1). At other friction
its drive for the true load is often far from the best one (``agents/told_load.py``): the steady
velocity of a drive depends little on mu itself at a given load over mu F_ref, but much on the ratio
``rho = mu1 / mu`` (the base friction against the contact's). Played at (k, load, 0.2, 0.1) and at
(k, 1.5 load, 0.3, 0.15), one drive gives nearly the same velocity; at mu1 1.3 times larger, often
half of it. So the teacher is searched along rho only:

1. **fields**: one ``DriveField`` (``agents.drive_field``) per value of ``rho`` in ``rhos``, each
   searched at mu = 0.3, mu1 = 0.3 rho over a grid of k and load fractions (``FieldConfig`` with
   ``friction``); a field given in ``fields`` (e.g. the recipe's, at the paper's rho = 1/3) is
   loaded instead of searched;
2. **the teacher at any (k, load, mu, mu1)** (``FrictionField.best``): the drives of the two fields
   whose rho brackets the point's, each read at the same load over mu F_ref, and their mixture,
   played at the point itself; the best is kept (the mixture unless another is 2 % better);
3. **student**: a plain SB3 PPO ``MlpPolicy`` on ``MDRDrive-v0``'s privileged observation (the full
   observation and mu, mu1) with friction drawn per episode, fitted to that teacher by
   ``agents.distill`` (the same fit and hole rounds as the shipped generalist).

The result is the privileged teacher of the sensor policy (``agents/adapt.py``): the estimator
learns mu and mu1 as well as k and the load. Writes ``OUT/fields/rho*.npz``, ``OUT/policy/`` and
``OUT/friction_teacher.json`` (stage times); an existing ``OUT`` is refused unless ``--resume``
(finished fields reused) or ``--force``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_int, check_range
from mdr_drive_env.files import write_text
from mdr_drive_env.sweep import Executor, TaskStore, add_executor_arguments, executor_from, task_folder

from .cycles import align_phase
from .drive_field import PAPER_FRICTION, DriveField, FieldConfig, pick_best, with_friction

DEFAULT_CONFIG = Path(__file__).parent / "configs" / "friction_teacher.yaml"
#: mu of every field: the fields differ in mu1 only (the load scales with mu).
FIELD_MU = PAPER_FRICTION[0]


class FrictionField:
    """Drive fields at increasing ``rho = mu1 / mu`` (each searched at mu = ``FIELD_MU``), queried at
    (k, load kg, mu, mu1) points."""

    def __init__(self, fields: list[DriveField]):
        if not fields:
            raise ValueError("a FrictionField needs at least one drive field")
        fields = sorted(fields, key=lambda f: f.friction[1] / f.friction[0])
        self.fields = fields
        self.rhos = np.array([f.friction[1] / f.friction[0] for f in fields])
        if len(set(np.round(self.rhos, 9))) != len(self.rhos):
            raise ValueError(f"two fields share a ratio mu1 / mu: {self.rhos.tolist()}")
        ks = fields[0].ks
        self.ks = ks
        self.trapezoid_critical = fields[0].trapezoid_critical  # at the paper's friction: loads' scale
        for f in fields[1:]:
            if f.ks.shape != ks.shape or not np.allclose(f.ks, ks):
                raise ValueError("the fields must share their k grid")

    def _bracket(self, rho: float) -> tuple[int, int, float]:
        """Indices of the fields below and above ``rho`` and the weight of the upper one (clipped to
        the fields' range)."""
        if len(self.rhos) == 1:
            return 0, 0, 0.0
        r = float(np.clip(rho, self.rhos[0], self.rhos[-1]))
        i = int(min(np.searchsorted(self.rhos, r, side="right") - 1, len(self.rhos) - 2))
        return i, i + 1, (r - self.rhos[i]) / (self.rhos[i + 1] - self.rhos[i])

    def candidates(self, point, radius: int = 1) -> np.ndarray:
        """(c, 2, 5) drives for (k, load kg, mu, mu1): the mixture of the two bracketing fields'
        interpolations (weighted by rho), then each field's :meth:`DriveField.candidates` at the same
        load over mu F_ref, all aligned to the lower field's interpolation."""
        k, _, mu, mu1 = point
        lo, hi, w = self._bracket(mu1 / mu)
        below = self.fields[lo].candidates(k, self.fields[lo].field_load(point), radius)
        if hi == lo:
            return below
        above = [align_phase(c, below[0]) for c in
                 self.fields[hi].candidates(k, self.fields[hi].field_load(point), radius)]
        mixed = (1.0 - w) * below[0] + w * above[0]
        return np.array([mixed, *below, *above])

    def best(self, points, prefer_interpolation: float = 0.02, radius: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """The teacher's drive (n, 2, 5) and its velocity (n,) m/s at each (k, load kg, mu, mu1)
        point ((k, load) points: the paper's friction): the best of :meth:`candidates` played there."""
        check_int("radius", radius, 1)
        points = with_friction(points, PAPER_FRICTION)
        return pick_best(points, [self.candidates(p, radius) for p in points], prefer_interpolation)

    @classmethod
    def load(cls, paths) -> "FrictionField":
        return cls([DriveField.load(p) for p in paths])


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


def load_config(path: str | Path) -> dict:
    """The YAML as {"seed", "friction": FrictionTeacherConfig, "teacher": FieldConfig, "distill":
    DistillConfig, "ppo", "env_kwargs"}; unknown sections or keys are a ``ValueError``."""
    from .distill import DistillConfig, check_drawn_friction
    from .recipe import config_of, read_sections

    data = read_sections(path, {"seed", "friction", "teacher", "distill", "ppo", "env_kwargs"})
    config = {"seed": int(data["seed"]), "friction": config_of(FrictionTeacherConfig, data["friction"], path),
              "teacher": config_of(FieldConfig, data["teacher"], path),
              "distill": config_of(DistillConfig, data["distill"], path), "ppo": dict(data["ppo"]),
              "env_kwargs": dict(data["env_kwargs"])}
    check_drawn_friction(config["distill"], friction_drawn=True)  # the student's friction is always drawn here
    missing = [f for f in config["friction"].fields if not Path(f).is_file()]
    if missing:
        raise ValueError(f"{path}: friction.fields {missing} are not files (saved drive fields, .npz)")
    return config


def run(config_path: str | Path, out: str | Path, executor: Executor | None = None, resume: bool = False,
        force: bool = False, progress: bool = True) -> dict:
    """Fields, then the student (module docstring), into ``out``; returns what ``friction_teacher.json`` holds."""
    from .distill import distill
    from .student import save_student
    from .recipe import command_line, start_run, student_record

    cfg = load_config(config_path)
    out, executor = start_run(out, resume, force, executor, progress)
    stages = {}
    t0 = time.perf_counter()
    field = FrictionField(search_fields(cfg["friction"], cfg["teacher"], out, cfg["seed"], executor, resume))
    stages["fields_s"] = round(time.perf_counter() - t0, 1)
    t1 = time.perf_counter()
    f = cfg["friction"]
    env_kwargs = {**cfg["env_kwargs"], "observation": "privileged", "friction_coefficient": list(f.friction_coefficient),
                  "base_friction_coefficient": list(f.base_friction_coefficient)}
    student = distill(field, cfg["distill"], seed=cfg["seed"], env_kwargs=env_kwargs, hyperparameters=cfg["ppo"],
                      progress=progress, friction=(f.friction_coefficient, f.base_friction_coefficient))
    stages["student_s"] = round(time.perf_counter() - t1, 1)
    command = command_line("friction_teacher")
    record = student_record(cfg["seed"], env_kwargs, cfg["ppo"], cfg["distill"], student, stages["student_s"], command,
                            {"fields": [str(p) for p in cfg["friction"].fields] + [
                                str(out / "fields" / f"rho{rho:.3f}.npz") for rho in cfg["friction"].rhos],
                             "recipe": str(config_path)})
    save_student(student, out / "policy", record)
    stages["total_s"] = round(time.perf_counter() - t0, 1)
    summary = {"config": str(config_path), "command": command, "seed": cfg["seed"], "stage_wall_time_s": stages,
               "rhos": field.rhos.tolist(),
               "field_mean_velocity_m_s": [float(np.mean(fl.velocities)) for fl in field.fields]}
    write_text(out / "friction_teacher.json", json.dumps(summary, indent=2))
    print(f"friction_teacher: fields {stages['fields_s']:.0f} s, student {stages['student_s']:.0f} s; policy in "
          f"{out / 'policy'}", flush=True)
    return summary


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, input_file, output_dir, run_command

    ap = Parser(prog="python -m mdr_drive_agents.friction_teacher", description=__doc__,
                formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", nargs="?", default=str(DEFAULT_CONFIG), type=input_file,
                    help="YAML with seed, friction, teacher, distill, ppo and env_kwargs "
                         "(default: agents/configs/friction_teacher.yaml)")
    ap.add_argument("--out", default="runs/friction_teacher", type=output_dir,
                    help="output folder (default: runs/friction_teacher)")
    ap.add_argument("--force", action="store_true", help="overwrite a non-empty --out")
    ap.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_executor_arguments(ap)
    a = ap.parse_args(argv)
    return run_command(ap.prog, lambda: run(a.config, a.out, executor_from(a), resume=a.resume, force=a.force,
                                            progress=not a.no_progress),
                       f"finished fields are kept, continue with --resume --out {a.out}")


if __name__ == "__main__":
    raise SystemExit(main())
