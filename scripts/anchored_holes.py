#!/usr/bin/env python
"""Anchored hole rounds: refit a distilled student where it falls short of the teacher, held in place elsewhere.

    python scripts/anchored_holes.py --out runs/exp_anchor/a1 --rounds 3                # teacher labels at holes
    python scripts/anchored_holes.py --out runs/exp_anchor/a2 --rounds 3 --repair       # repaired labels at holes

An ablation of the recipe's hole round (``agents/distill.py``), run on a saved student (default: the
shipped one). The recipe's hole round refits on all the teacher's episodes, which the network never
fits exactly, so the whole function moves and the holes move with it. Here the fit is anchored: the
labels everywhere but at the holes are the student's own current outputs (on 4,096 teacher
episodes of the recipe's distribution, with the recipe's perturbed previous actions and shuffled
motion entries), so the anchors cost nothing until the network moves. Each round draws fresh
probes, finds the holes as the recipe does (the student more than 10 % and 1 mm/s below the teacher),
adds episodes at each hole and 8 jittered points around it, and fits anchors + holes for
``--steps`` Adam steps (the learning rate decaying linearly to zero). Labels at the holes: the
teacher's drive, or with ``--repair`` a drive found by a local CMA-ES search from the student's own
steady cycle (``--budget`` evaluations, step size ``--sigma``), kept where it reaches 0.9 of the
teacher. Prints the probe statistics per round; judge the result with ``scripts/teacher_check.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("--start", type=folder_with("model.zip"), default="agents/pretrained/ppo_generalist",
                   help="the distilled student to start from (folder with model.zip and vecnormalize.pkl)")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--out", required=True, help="folder for the refitted student")
    p.add_argument("--rounds", type=int_range(1), default=3, help="anchored hole rounds (-)")
    p.add_argument("--steps", type=int_range(1), default=3000, help="Adam steps per round (-)")
    p.add_argument("--lr", type=float, default=1e-4, help="Adam step size, decaying linearly to zero per round (-)")
    p.add_argument("--probes", type=int_range(1), default=4096, help="random probe points per round (-)")
    p.add_argument("--anchor-points", type=int_range(1), default=4096, help="teacher episodes of the anchors (-)")
    p.add_argument("--repair", action="store_true", help="label the holes with a local search from the student's drive")
    p.add_argument("--budget", type=int_range(1), default=120, help="CMA-ES evaluations of each repair (-)")
    p.add_argument("--sigma", type=float, default=0.05, help="CMA-ES initial step size of each repair (action units)")
    p.add_argument("--seed", type=int, default=11, help="seed of the points, probes and fit (-)")
    args = p.parse_args(argv)

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from mdr_drive_agents.baselines import cma_optimize
    from mdr_drive_agents.distill import (Student, around, draw_points, edge_loss, labelled_episodes,
                                          perturb_previous_actions, policy_mean, rollout, save_student,
                                          student_velocity)
    from mdr_drive_agents.drive_field import DriveField, cycle_action
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.vec_env import BatchedVecEnv
    from mdr_drive_env.gym_envs.spaces import ObservationLayout

    torch.set_num_threads(1)
    cfg = load_recipe(DEFAULT_CONFIG)["distill"]
    field = DriveField.load(args.field)
    model = PPO.load(f"{args.start}/model.zip", device="cpu")
    venv = VecNormalize.load(f"{args.start}/vecnormalize.pkl", BatchedVecEnv(1))
    venv.training = False
    student = Student(model, venv)
    policy = model.policy
    rng = np.random.default_rng(args.seed)
    structure = ObservationLayout.structure
    prev = structure["previous_action"]
    shuffled = [*range(*structure["dynamics"].indices(14)), *range(*structure["episode_fraction"].indices(14))]

    def normalised(x):
        return torch.as_tensor(venv.normalize_obs(x.astype(np.float64)), dtype=torch.float32)

    # anchors: the student's own outputs on the recipe's kind of samples
    obs, drives = labelled_episodes(field, draw_points(field, args.anchor_points, rng, cfg), None, cfg, args.seed)
    anchor_x = perturb_previous_actions(obs, drives, rng, cfg.perturbed_share, prev)
    for column in shuffled:
        anchor_x[:, column] = anchor_x[rng.permutation(len(anchor_x)), column]
    anchor_x = normalised(np.concatenate([anchor_x, obs]))
    with torch.no_grad():
        anchor_y = policy_mean(policy, anchor_x).clone()
    hole_obs, hole_drives, log = [], [], []
    for r in range(args.rounds + 1):
        t0 = time.perf_counter()
        probe = draw_points(field, args.probes, rng, cfg)
        _, v_teacher = field.best(probe, radius=cfg.teacher_radius)
        v_student = student_velocity(student, probe)
        short = v_student < v_teacher - np.maximum(cfg.hole_shortfall * np.abs(v_teacher), 1e-3)
        moving = v_teacher >= 2e-3
        record = {"round": r, "holes": int(short.sum()),
                  "under_0.85_of_teacher": int((v_student[moving] < 0.85 * v_teacher[moving]).sum()),
                  "mean_fraction": round(float(np.mean(v_student[moving] / v_teacher[moving])), 4),
                  "probe_s": round(time.perf_counter() - t0, 1)}
        print(record, flush=True)
        log.append(record)
        if r == args.rounds:
            break
        holes = [pt for pt, h in zip(probe, short) if h]
        if args.repair:
            o_student, _, _ = rollout(holes, np.zeros((len(holes), 2, 5)), student.act, 30)
            o_student = o_student.reshape(30, len(holes), 14)
            points, labels = [], []
            for i, (k, m) in enumerate(holes):
                start = np.stack([o_student[-2, i, prev], o_student[-1, i, prev]])
                found = cma_optimize(k, m, args.budget, popsize=12, seed=r * 10000 + i, sigma0=args.sigma, cycle=2,
                                     x0=start)
                if found.velocity >= 0.9 * v_teacher[short][i]:
                    for q in around([(k, m)], cfg.hole_neighbours, rng, (0.0, 0.6)):
                        points.append(q)
                        labels.append(np.asarray(found.action))
            print(f"  repaired {len(points) // (cfg.hole_neighbours + 1)} of {len(holes)}", flush=True)
            o, d, _ = rollout(points, np.array(labels), None, cfg.periods, seed=args.seed + 100 + r)
        else:
            o, d = labelled_episodes(field, around(holes, cfg.hole_neighbours, rng, (0.0, 0.6)), None, cfg,
                                     args.seed + 100 + r)
        hole_obs.append(o)
        hole_drives.append(d)
        all_obs, all_drives = np.concatenate(hole_obs), np.concatenate(hole_drives)
        params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
        opt = torch.optim.Adam(params, lr=args.lr)
        sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: max(1.0 - s / args.steps, 0.0))
        policy.set_training_mode(True)
        step, anchor_total, hole_total = 0, 0.0, 0.0
        while step < args.steps:
            x = perturb_previous_actions(all_obs, all_drives, rng, cfg.perturbed_share, prev)
            y = torch.as_tensor(cycle_action(all_drives, x[:, prev]), dtype=torch.float32)
            for column in shuffled:
                x[:, column] = x[rng.permutation(len(x)), column]
            x = normalised(x)
            order = torch.randperm(len(x))
            for i in range(0, len(x), cfg.batch):
                if step >= args.steps:
                    break
                idx, anchor_idx = order[i:i + cfg.batch], torch.randint(0, len(anchor_x), (cfg.batch,))
                anchor_loss = torch.mean((policy_mean(policy, anchor_x[anchor_idx]) - anchor_y[anchor_idx]) ** 2)
                hole_loss = edge_loss(policy_mean(policy, x[idx]), y[idx])
                opt.zero_grad()
                (anchor_loss + hole_loss).backward()
                opt.step()
                sched.step()
                step += 1
                anchor_total += float(anchor_loss.detach())
                hole_total += float(hole_loss.detach())
        policy.set_training_mode(False)
        print(f"  fit: anchor loss {anchor_total / step:.2e}, hole loss {hole_total / step:.2e}", flush=True)
    save_student(student, args.out, {"algo": "ppo", "anchored_from": str(args.start), "rounds": log,
                                     "command": " ".join(sys.argv)})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
