#!/usr/bin/env python
"""An ablation (not shipped): repair a distilled student where it fails, with labels from a local search
started at its own drive.

    python scripts/repair_student.py agents/pretrained/ppo_generalist --out runs/repair/c \
        --rounds 6 --probes 16384 --steps 1500 --learning-rate 5e-5

Why: where the teacher's drive jumps between two optima, the student plays a blend of them, and the
blend may stall. A label near what the student already plays, and that moves, would let the student
cross the jump through drives that work. Each round:

1. the student drives closed loop at ``--probes`` random points of the training domain
   (``distill.draw_points`` with the recipe's settings, seed ``--seed``); it fails where it is below
   the trapezoid (``blind.below_trapezoid``) or, where it is slow (under 3 mm/s, or under the
   trapezoid's velocity + 0.5 mm/s), short of the teacher (``DriveField.best``) by the hole round's
   margin;
2. at each failure, CMA-ES over two-action cycles starts from the student's last two actions
   (``--budget`` evaluations, step 0.1 action units) and the drive found becomes the label there if it
   beats both the student and the trapezoid;
3. the teacher's episodes at 4,096 random points (drawn once, before round 1) and ``--copies`` copies
   of the repaired points' episodes are fitted for ``--steps`` Adam steps at ``--learning-rate``
   (``distill.fit``).

The repaired policy is written to ``--out`` (a copy of the input folder with a new model.zip and
vecnormalize.pkl); judge it with ``scripts/dense_check.py`` and the blind benchmark.
"""

from __future__ import annotations

import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def local_search(task):
    """CMA-ES over two-action cycles from one cycle (2, 5) at one (k, load kg) point: (drive, m/s)."""
    from mdr_drive_agents.baselines import best_cma_run

    point, cycle, budget, seed = task
    run = best_cma_run(point[0], point[1], [cycle], budget, popsize=16, sigma0=0.1, cycle=2, seed=seed)
    return np.asarray(run.action), run.velocity


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policy", type=folder_with("model.zip"), help="the student's folder (model.zip, vecnormalize.pkl)")
    p.add_argument("--out", required=True, help="folder of the repaired policy (must not exist)")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--rounds", type=int_range(1), default=6, help="repair rounds (-)")
    p.add_argument("--probes", type=int_range(1), default=16384, help="random points per round (-)")
    p.add_argument("--steps", type=int_range(1), default=1500, help="Adam steps per round (-)")
    p.add_argument("--learning-rate", type=float, default=5e-5, help="Adam step size, decaying to 0 each round (-)")
    p.add_argument("--copies", type=int_range(1), default=4, help="copies of the repaired points' episodes (-)")
    p.add_argument("--budget", type=int_range(16), default=160, help="CMA-ES evaluations per failure (-)")
    p.add_argument("--seed", type=int, default=515151, help="seed of the points and the fit (-)")
    args = p.parse_args(argv)
    if Path(args.out).exists():
        p.error(f"--out {args.out!r} exists; choose a new folder")
    if not 0.0 < args.learning_rate < 1.0:
        p.error(f"--learning-rate {args.learning_rate!r} is outside the allowed range (0, 1)")

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from mdr_drive_agents.blind import below_trapezoid
    from mdr_drive_agents.distill import Student, draw_points, fit, labelled_episodes, rollout
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import open_loop_velocity, steady_velocity_of, trapezoid_action
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.vec_env import BatchedVecEnv

    torch.set_num_threads(2)
    recipe = load_recipe(DEFAULT_CONFIG)
    config = recipe["distill"]
    field = DriveField.load(args.field)
    model = PPO.load(Path(args.policy) / "model.zip", device="cpu")
    venv = VecNormalize.load(str(Path(args.policy) / "vecnormalize.pkl"),
                             VecMonitor(BatchedVecEnv(16, seed=0, **recipe["env_kwargs"])))
    venv.training = False
    model.set_env(venv)
    student = Student(model, venv)
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    replay_obs, replay_drives = labelled_episodes(field, draw_points(field, config.points, rng, config), None, config,
                                                  args.seed)
    repair_obs, repair_drives = [], []
    for r in range(args.rounds):
        t1 = time.perf_counter()
        points = draw_points(field, args.probes, rng, config)
        actions = []

        def act(obs):
            action = student.act(obs)
            actions.append(np.asarray(action).reshape(len(points), 5))
            return action

        _, _, disp = rollout(points, np.zeros((len(points), 2, 5)), act, 30)
        cycles = np.stack([actions[-2], actions[-1]], axis=1).astype(np.float64)
        v_student = steady_velocity_of(disp)
        v_trap = open_loop_velocity(points, trapezoid_action())
        slow = np.flatnonzero((v_student < 3e-3) | (v_student < v_trap + 0.5e-3))
        v_teacher = np.full(len(points), -np.inf)
        v_teacher[slow] = field.best([points[i] for i in slow], radius=config.teacher_radius)[1]
        below, _, _ = below_trapezoid(v_trap, v_student)
        short = v_student < v_teacher - np.maximum(config.hole_shortfall * np.abs(v_teacher), 1e-3)
        fail = np.flatnonzero(below | short)
        with ProcessPoolExecutor(2) as pool:
            found = list(pool.map(local_search, [(points[i], cycles[i], args.budget, int(i)) for i in fail]))
        drives = np.array([f[0] for f in found]).reshape(-1, 2, 5)
        v_found = np.array([f[1] for f in found])
        keep = v_found > np.maximum(v_student[fail], v_trap[fail])
        moving = v_teacher[fail] > 2e-3
        print(f"round {r}: {args.probes} probes, {below.sum()} below the trapezoid, {short.sum()} short of the teacher "
              f"({len(slow)} slow probes checked); the local search beats the student and the trapezoid at "
              f"{keep.sum()} of {len(fail)}, median {np.median(v_found[moving] / v_teacher[fail][moving]):.2f} of the "
              f"teacher; {time.perf_counter() - t1:.0f} s", flush=True)
        obs, sample_drives, _ = rollout([points[i] for i in fail[keep]], drives[keep], None, config.periods, seed=r)
        repair_obs += [obs] * args.copies
        repair_drives += [sample_drives] * args.copies
        loss = fit(student, np.concatenate([replay_obs, *repair_obs]), np.concatenate([replay_drives, *repair_drives]),
                   args.steps, config, 777000 + r, True, learning_rate=args.learning_rate)
        print(f"  fit loss {loss:.3g}; {time.perf_counter() - t0:.0f} s in all", flush=True)
    shutil.copytree(args.policy, args.out)
    model.save(Path(args.out) / "model.zip")
    venv.save(str(Path(args.out) / "vecnormalize.pkl"))
    print(f"repaired policy in {args.out} ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
