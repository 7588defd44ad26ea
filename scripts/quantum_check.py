#!/usr/bin/env python
"""How often a policy's rises and z phase land in the teacher's time quantum, on the teacher's episodes.

    python scripts/quantum_check.py agents/pretrained/ppo_generalist [POLICY ...] --points 1500 --seed 5

An action's rise fractions and z phase select one of the period's time quanta (200 at the default
2 ms period and 10 us quantum), so an output within half a quantum of the label's centre plays the
teacher's waveform exactly, and one quantum off can move the steady velocity by a mm/s near stall.
At ``--points`` random (k, load) points of the recipe's domain (its ``draw_points``, ``--seed``) the
teacher plays its episodes (the recipe's settings, ``--field``); per policy and quantised entry, the
share of the samples whose output selects the label's quantum, one quantum off, two or more, and
the median and 90th percentile of the absolute error in action units (all five entries).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def quanta_off(actions: np.ndarray, labels: np.ndarray, action_map) -> np.ndarray:
    """How many time quanta each action's x rise, z rise and z phase are off the label's (n, 3) int:
    the difference of the waveforms they select (the phase the shorter way round the period)."""
    a, b = action_map.to_params_batch(actions), action_map.to_params_batch(labels)
    rise = np.abs(a[:, [1, 3]] - b[:, [1, 3]]) / action_map.time_quantum
    phase = np.abs(a[:, 4] - b[:, 4])
    phase = np.minimum(phase, 1.0 - phase) * action_map.quanta
    return np.rint(np.c_[rise, phase]).astype(np.int64)


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policies", nargs="+", type=folder_with("model.zip"), help="policy folders (with model.zip)")
    p.add_argument("--points", type=int_range(1), default=1500, help="random (k, load) points (-)")
    p.add_argument("--seed", type=int, default=5, help="seed of the points (-)")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    args = p.parse_args(argv)

    import gymnasium as gym

    from mdr_drive_agents.cycles import cycle_action
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import ACTION_MAP, load_policy
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import draw_points, labelled_episodes
    from mdr_drive_env import ENV_ID

    field = DriveField.load(args.field)
    config = load_recipe(DEFAULT_CONFIG)["distill"]
    points = draw_points(field, args.points, np.random.default_rng(args.seed), config)
    prev = gym.make(ENV_ID).unwrapped.observation_structure["previous_action"]
    print(f"{args.points} points (seed {args.seed}), the teacher's episodes of {config.periods} periods each; "
          "share of the samples in the label's quantum / one off / two or more; |error| median, 90th percentile")
    print("| policy | x rise | z rise | z phase | |error| median (5 entries) | 90th percentile |")
    print("|---|---|---|---|---|---|")
    obs, drives = labelled_episodes(field, points, None, config, seed=3)  # the teacher's: the same for every policy
    labels = np.clip(cycle_action(drives, obs[:, prev]), -1.0, 1.0)
    for path in args.policies:
        policy = load_policy(path)
        if policy.play_kwargs.get("z_phase_origin", 0.0) != 0.0:
            p.error(f"{path}: a policy with a moved z phase seam is not supported")
        actions = np.clip(np.asarray(policy(obs), dtype=np.float64).reshape(-1, 5), -1.0, 1.0)
        off = quanta_off(actions, labels, ACTION_MAP)
        shares = [f"{(o == 0).mean():.3f} / {(o == 1).mean():.3f} / {(o >= 2).mean():.3f}" for o in off.T]
        error = np.abs(actions - labels)
        print(f"| {path} | " + " | ".join(shares) + f" | {' '.join(f'{e:.4f}' for e in np.median(error, 0))} | "
              f"{' '.join(f'{e:.4f}' for e in np.percentile(error, 90, 0))} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
