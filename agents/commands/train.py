"""``mdr-drive train``: its options (each with its unit) and the call of ``train.sb3.train``, or of
``train.seeds.train_seeds`` for several seeds as one sweep; prints the run's summary as JSON and
exits 130 when interrupted (the run saved, ``--resume`` continues it).

    mdr-drive train --algo ppo --k 0 0.6 --cargo-mass 0 1.0 --steps 1000000 --seed 0 --out runs/ppo_s0
"""

from __future__ import annotations

import argparse
import json

HELP = "train PPO, SAC, TD3 or RecurrentPPO from scratch on MDRDrive-v0 (Stable-Baselines3, sb3-contrib)"
DESCRIPTION = ("Train a waveform policy on MDRDrive-v0 with Stable-Baselines3 PPO, SAC or TD3 or sb3-contrib's "
               "RecurrentPPO, hyperparameters from an RL-Zoo-style YAML (agents/configs/<algo>.yaml); TensorBoard logs in OUT/tb. The shipped policy is "
               "made by `mdr-drive recipe` instead (a teacher distilled into the network).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import folder_with, input_file, int_range, output_dir, positive_int
    from mdr_drive_env.sweep import add_executor_arguments

    from ..policy import ALGORITHMS

    p.add_argument("--algo", choices=ALGORITHMS, default=None,
                   help="SB3 algorithm (default: ppo; a resumed run keeps its own, and another is an error)")
    p.add_argument("--k", type=float, nargs="+", default=None,
                   help="grading exponent k, one value or a low high range sampled per episode (-)")
    p.add_argument("--cargo-mass", type=float, nargs="+", default=None,
                   help="cargo mass m, one value or a low high range sampled per episode; replaces the "
                        "config's load ratio (kg)")
    p.add_argument("--load-ratio", type=float, nargs="+", default=None,
                   help="load as a fraction of mu F_ref, one value or a low high range (-); default from the config")
    p.add_argument("--steps", type=positive_int, default=None,
                   help="the run's total of environment steps (drive periods), >= 1, critic warm-up included; "
                        "with --resume a new total, said in one line; PPO rounds up to whole rollouts and says so "
                        "(-); default: the config's, or a resumed run's own")
    p.add_argument("--seed", type=int, default=0, help="seed of the policy and the environments (-)")
    p.add_argument("--n-envs", type=positive_int, default=None,
                   help="drives stepped together in the batched env, >= 1 (-); default from the config")
    p.add_argument("--torch-threads", type=positive_int, default=1,
                   help="torch threads of this process (-); 1 is fastest for these small MLPs")
    p.add_argument("--force", action="store_true", help="overwrite a run already in --out")
    p.add_argument("--config", default=None, type=input_file, help="RL-Zoo-style YAML (default: agents/configs/<algo>.yaml)")
    p.add_argument("--out", default=None, type=output_dir, help="output folder (default: runs/<algo>_s<seed>)")
    p.add_argument("--resume", default=None, metavar="DIR", type=folder_with("model.zip", "run.json"),
                   help="continue the run in DIR to its total (same step counter; --steps sets a new one); a "
                        "distilled or adapted policy keeps the observation statistics it was fitted on and its "
                        "provenance in run.json")
    p.add_argument("--critic-warmup", type=int_range(0), default=0, metavar="STEPS",
                   help="first train only the value function for STEPS environment steps, the actor frozen, >= 0 "
                        "(-); for fine-tuning a distilled or adapted policy, which has no trained critic")
    from ..train.hyperparameters import WARM_STARTS, key_value

    p.add_argument("--hyperparams", nargs="+", default=None, type=key_value, metavar="KEY:VALUE",
                   help="SB3 hyperparameters that replace the config's, or the run's when resuming, as the RL "
                        "Zoo's -params (e.g. learning_rate:1e-5 n_steps:512; values read as YAML)")
    p.add_argument("--eval-freq", type=positive_int, default=20_000, help="evaluate on held-out points every N steps (-)")
    p.add_argument("--checkpoint-freq", type=positive_int, default=100_000, help="checkpoint every N steps (-)")
    p.add_argument("--warm-start", default=None, choices=WARM_STARTS,
                   help="initial policy: as is, or its mean at the trapezoid; default from the config (the "
                        "shipped policy is distilled from a teacher instead: mdr-drive recipe)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    m = p.add_argument_group("several seeds as one sweep: OUT/s<seed> per seed")
    m.add_argument("--seeds", type=int, nargs="+", default=None, metavar="SEED",
                   help="train one run per seed (instead of --seed) into OUT/s<SEED>; seeds already trained "
                        "there are kept unless --force (-)")
    add_executor_arguments(m, resume=False)


def main(args: argparse.Namespace) -> int:
    from ..train.sb3 import train

    if args.seeds:
        from mdr_drive_env.sweep import executor_from

        from ..train.seeds import train_seeds

        if args.resume:
            raise ValueError("--resume continues one run; with --seeds, run the same command again to train "
                             "the seeds that are missing")
        out = args.out or f"runs/{args.algo or 'ppo'}"
        folders = train_seeds(args.seeds, out, executor_from(args), force=args.force, algo=args.algo,
                              steps=args.steps, n_envs=args.n_envs, k=args.k, cargo_mass=args.cargo_mass,
                              load_ratio=args.load_ratio, config=args.config, eval_freq=args.eval_freq,
                              checkpoint_freq=args.checkpoint_freq, warm_start=args.warm_start,
                              torch_threads=args.torch_threads, critic_warmup=args.critic_warmup,
                              hyperparams=dict(args.hyperparams or ()))
        for seed, folder in folders.items():
            run = json.loads((folder / "run.json").read_text())
            print(f"seed {seed}: {folder} ({run['total_timesteps']} steps, {run['wall_time_s']} s)")
        return 0
    out = args.out or f"runs/{args.algo or 'ppo'}_s{args.seed}"
    record = train(args.algo, args.steps, args.seed, out, args.n_envs, args.k, args.cargo_mass, args.load_ratio,
                   args.config,
                   args.resume, args.eval_freq, args.checkpoint_freq, warm_start=args.warm_start,
                   progress_bar=not args.no_progress, force=args.force, torch_threads=args.torch_threads,
                   critic_warmup=args.critic_warmup, hyperparams=dict(args.hyperparams or ()))
    print(json.dumps({key: record[key] for key in ("algo", "seed", "total_timesteps", "wall_time_s",
                                                    "steps_per_s_this_run", "interrupted")}, indent=2))
    return 130 if record["interrupted"] else 0


__all__ = ["add_arguments", "main"]
