"""Hole-round variants of the shipped student without refitting round 0 (a decision tool: 2 minutes a
variant instead of 12).

    python results/blind/stall_probe_decision/from_round0.py round0 runs/round0_s0.pkl
    python results/blind/stall_probe_decision/from_round0.py holes runs/round0_s0.pkl RECIPE.yaml runs/OUT

Both take the teacher's field as an optional argument after those (default: the committed
results/recipe/teacher_field.npz); ``holes`` must be given the one its round 0 was fitted to.
``round0`` takes a recipe after the teacher (default the shipped one; e.g. another ``student_seed``), and
``holes`` checks RECIPE.yaml's round 0 against the recipe the checkpoint was fitted with.

``round0`` runs the recipe's round 0 (agents/configs/recipe.yaml, its student seed, on the given teacher)
exactly as ``distill.distill`` does and pickles the student's weights, its observation statistics,
the gathered episodes and the random state after it. ``holes``
continues from there with RECIPE.yaml's distillation settings (round 0's must be the checkpoint's:
checked) through its hole rounds (``distill.hole_round``) and saves the policy in OUT/policy. With
the shipped recipe it gives the shipped policy (checked, value for value, before any variant).

Run one at a time on a 2-core machine: each fit uses the recipe's two torch threads, and two side by
side took 2,403 s for a round 0 that takes about 565 s alone (side_teacher_seeds_decision).
"""
import dataclasses
import pickle
import sys
import time
from pathlib import Path

import numpy as np
import torch

from mdr_drive_agents.distill import fit, hole_round, make_student, save_student
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.recipe import load_recipe, student_record
from mdr_drive_agents.teacher_data import draw_points, jump_points, labelled_episodes, teacher_drives

SHIPPED, TEACHER = "agents/configs/recipe.yaml", "results/recipe/teacher_field.npz"
ROUND0_KEYS = ("net_arch", "activation", "points", "periods", "no_load_share", "load_factor", "steps", "rounds", "batch",
               "learning_rate", "perturbed_share", "log_std", "torch_threads", "teacher_radius", "huber_delta",
               "jump_levels", "jump_neighbours", "jump_threshold", "quantum_centres")


def round0(out: str, teacher: str = TEACHER, recipe_path: str = SHIPPED) -> None:
    recipe = load_recipe(recipe_path)
    config, seed = recipe["distill"], recipe["student_seed"]
    assert config.rounds == 0
    torch.set_num_threads(config.torch_threads)
    field_ = DriveField.load(teacher)
    rng = np.random.default_rng(seed)
    student = make_student(config, seed, recipe["env_kwargs"], recipe["ppo"])
    t0 = time.perf_counter()
    points = draw_points(field_, config.points, rng, config, None)
    drives, _ = teacher_drives(field_, points, config)
    extra, extra_drives = jump_points(field_, points, drives, config)
    points, drives = points + extra, np.concatenate([drives, extra_drives]) if extra else drives
    obs, sample_drives = labelled_episodes(field_, points, None, config, seed, student.z_phase_origin, drives=drives)
    obs64 = obs.astype(np.float64)
    student.venv.obs_rms.mean, student.venv.obs_rms.var = obs64.mean(axis=0), obs64.var(axis=0)
    student.venv.obs_rms.count = float(len(obs))
    loss = fit(student, obs, sample_drives, config.steps, config, seed, False)
    record = {"round": 0, "jump_points": len(extra), "samples": int(len(obs)), "loss": loss,
              "wall_time_s": round(time.perf_counter() - t0, 1)}
    print(record, flush=True)
    with open(out, "wb") as f:
        pickle.dump({"policy": student.model.policy.state_dict(), "obs_rms": student.venv.obs_rms,
                     "obs_all": [obs], "drive_all": [sample_drives], "rng": rng.bit_generator.state,
                     "record": record, "teacher": teacher, "recipe": recipe_path}, f)


def holes(ckpt: str, recipe_path: str, out: str, teacher: str = TEACHER) -> None:
    with open(ckpt, "rb") as f:
        state = pickle.load(f)
    fitted_with = state.get("recipe", SHIPPED)  # checkpoints written before the argument: the shipped recipe
    recipe, shipped = load_recipe(recipe_path), load_recipe(fitted_with)
    config, seed = recipe["distill"], recipe["student_seed"]
    differ = [key for key in ROUND0_KEYS if getattr(config, key) != getattr(shipped["distill"], key)]
    if differ or seed != shipped["student_seed"] or recipe["env_kwargs"] != shipped["env_kwargs"]:
        sys.exit(f"{recipe_path}: round 0 differs from {fitted_with}'s ({differ or 'seed/env_kwargs'})")
    torch.set_num_threads(config.torch_threads)
    fitted_to = state.get("teacher", TEACHER)  # checkpoints written before the argument: the default
    if fitted_to != teacher:
        sys.exit(f"{ckpt}: round 0 was fitted to {fitted_to}, not {teacher}")
    field_ = DriveField.load(teacher)
    student = make_student(config, seed, recipe["env_kwargs"], recipe["ppo"])
    student.model.policy.load_state_dict(state["policy"])
    student.venv.obs_rms = state["obs_rms"]
    rng = np.random.default_rng()
    rng.bit_generator.state = state["rng"]
    student.history.append(state["record"])
    obs_all, drive_all = state["obs_all"], state["drive_all"]
    t0 = time.perf_counter()
    for h in range(1, config.hole_rounds + 1):
        record = hole_round(student, field_, config, h, rng, seed, obs_all, drive_all, None, False)
        student.history.append(record)
        print(record, flush=True)
    teacher = {"teacher": teacher, "recipe": recipe_path, "round0_checkpoint": ckpt}
    save_student(student, Path(out) / "policy", student_record(seed, recipe["env_kwargs"], recipe["ppo"], config,
                                                             student, round(time.perf_counter() - t0, 1),
                                                             " ".join(sys.argv), teacher))
    print(f"{out}/policy: hole rounds {time.perf_counter() - t0:.0f} s; "
          f"{dataclasses.asdict(config)['stall_probes']} stall probes", flush=True)


if __name__ == "__main__":
    {"round0": round0, "holes": holes}[sys.argv[1]](*sys.argv[2:])
