"""Hole-round variants of the shipped student without refitting round 0 (a decision tool: 2 minutes a
variant instead of 12).

    python results/blind/stall_probe_decision/from_round0.py round0 runs/round0_s0.pkl
    python results/blind/stall_probe_decision/from_round0.py holes runs/round0_s0.pkl RECIPE.yaml runs/OUT

Both take the teacher's field as an optional argument after those (default: the committed
results/recipe/teacher_field.npz); ``holes`` must be given the one its round 0 was fitted to.
``round0`` takes a recipe after the teacher (default the shipped one; e.g. another ``student_seed``).

``round0`` runs the recipe's round 0 (``distill.distill`` with no hole round, its student seed, on the
given teacher) and keeps it in the student's round-0 checkpoint (``agents/checkpoint.py``, the file
``make train --resume`` continues from). ``holes`` continues from that checkpoint with RECIPE.yaml's
distillation settings through its hole rounds and saves the policy in OUT/policy; it refuses a
checkpoint fitted with another teacher or other round-0 settings (``checkpoint.LATER_ROUND_KEYS`` are the
settings a variant may change). With the shipped recipe it gives the shipped policy (``tests/test_recipe.py``
checks the same continuation at CI size; at full size, ``make train``'s student stage resumed from its
checkpoint gave policy.pth md5 d2ab3dbb...: ``results/recipe/resume_check.md``).

Checkpoints written by this script before the round-0 checkpoint moved into ``distill`` (git 2ab38f6
and earlier) have no fingerprint and are refused: fit round 0 again.

Run one at a time on a 2-core machine: each fit uses the recipe's two torch threads, and two side by
side took 2,403 s for a round 0 that takes about 565 s alone (side_teacher_seeds_decision).
"""
import dataclasses
import sys
import time
from pathlib import Path

from mdr_drive_agents import checkpoint
from mdr_drive_agents.distill import distill
from mdr_drive_agents.student import save_student
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.recipe import load_recipe, student_record

SHIPPED, TEACHER = "agents/configs/recipe.yaml", "results/recipe/teacher_field.npz"


def round0(out: str, teacher: str = TEACHER, recipe_path: str = SHIPPED) -> None:
    recipe = load_recipe(recipe_path)
    config = dataclasses.replace(recipe["distill"], hole_rounds=0)
    assert config.rounds == 0
    student = distill(DriveField.load(teacher), config, seed=recipe["student_seed"], env_kwargs=recipe["env_kwargs"],
                      hyperparameters=recipe["ppo"], checkpoint=out)
    print(student.history[0], flush=True)


def holes(ckpt: str, recipe_path: str, out: str, teacher: str = TEACHER) -> None:
    recipe = load_recipe(recipe_path)
    config, seed = recipe["distill"], recipe["student_seed"]
    field_ = DriveField.load(teacher)
    state, why_not = checkpoint.load(ckpt, checkpoint.fingerprint(field_, config, seed, recipe["env_kwargs"],
                                                                  recipe["ppo"]))
    if state is None:
        sys.exit(f"{recipe_path} with {teacher}: {why_not or f'{ckpt} does not exist'}")
    t0 = time.perf_counter()
    student = distill(field_, config, seed=seed, env_kwargs=recipe["env_kwargs"], hyperparameters=recipe["ppo"],
                      checkpoint=ckpt)
    origin = {"teacher": teacher, "recipe": recipe_path, "round0_checkpoint": ckpt}
    save_student(student, Path(out) / "policy", student_record(seed, recipe["env_kwargs"], recipe["ppo"], config,
                                                             student, round(time.perf_counter() - t0, 1),
                                                             " ".join(sys.argv), origin))
    print(f"{out}/policy: hole rounds {time.perf_counter() - t0:.0f} s; {config.stall_probes} stall probes", flush=True)


if __name__ == "__main__":
    {"round0": round0, "holes": holes}[sys.argv[1]](*sys.argv[2:])
