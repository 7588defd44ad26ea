"""``mdr-drive rl-baselines``: plain RL (PPO, SAC, TD3, RecurrentPPO) searched, trained over seeds and
scored on blind records (``mdr_drive_agents.rl_baselines``).

    mdr-drive rl-baselines agents/configs/rl_baselines.yaml --out results/rl_baselines   # make rl-baselines
"""

from __future__ import annotations

import argparse

HELP = "plain RL baselines: hyperparameter search, several seeds, normalised scores and learning curves"
DESCRIPTION = ("Train the agents of a config (Stable-Baselines3 PPO, SAC and TD3, sb3-contrib RecurrentPPO; "
               "from scratch unless an agent names a warm start or a training aid) on MDRDrive-v0: an Optuna search of each one's hyperparameters on "
               "the points of the validation blind record, then one run per training seed, each scored through "
               "training on the report records' points with the normalised score (0 the trapezoid, 1 the best "
               "drive the blind benchmark's search found) and aggregated as rliable does (IQM and mean, 95 % "
               "stratified-bootstrap intervals). Writes OUT/benchmark.md, OUT/curves.png, OUT/results.json and "
               "the tuned hyperparameters (OUT/hyperparameters/<agent>.yaml, for mdr-drive train --config); the "
               "trained runs go to --runs. Ctrl-C keeps every finished run: continue with --resume.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import input_file, output_dir
    from mdr_drive_env.sweep import add_executor_arguments

    from ..rl_baselines.pipeline import DEFAULT_CONFIG
    from . import add_recipe_arguments

    add_recipe_arguments(p, DEFAULT_CONFIG, "baselines YAML (default: agents/configs/rl_baselines.yaml; the fields "
                                            "of mdr_drive_agents.rl_baselines.config.BaselinesConfig)",
                         "results/rl_baselines")
    p.add_argument("--runs", default="runs/rl_baselines", type=output_dir,
                   help="where the trained runs go, RUNS/<agent>/s<seed> and RUNS/tuning/ (a Ray cluster needs it "
                        "on a shared file system); default runs/rl_baselines")
    p.add_argument("--ship", default=None, type=output_dir, metavar="DIR",
                   help="copy the run with the best mean score on the validation points to DIR/<algo>_plain, with "
                        "its model card; it replaces the plain policies DIR holds (DIR/*_plain), only with --force")
    p.add_argument("--records", nargs="+", default=None, type=input_file, metavar="BLIND.json",
                   help="with --report --ship: the blind benchmarks of the shipped folder (mdr-drive benchmark "
                        "--blind ... --policies DIR/<algo>_plain), quoted in its model card")
    p.add_argument("--report", action="store_true",
                   help="train nothing: write OUT's tables, figures and hyperparameter files again from its "
                        "results.json (the same config); with --ship, ship its best run again")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..rl_baselines.pipeline import report_only, run

    if args.records and not (args.report and args.ship):
        raise ValueError("--records goes with --report --ship (the card of the policy they judged)")
    if args.report:
        return run_command("mdr-drive rl-baselines",
                           lambda: report_only(args.config, args.out, args.ship, args.force, args.records or ()),
                           "nothing was written")
    return run_command("mdr-drive rl-baselines",
                       lambda: run(args.config, args.out, args.runs, executor_from(args), resume=args.resume,
                                   force=args.force, progress=not args.no_progress, ship=args.ship),
                       f"the finished runs are kept, continue with --resume --out {args.out}")


__all__ = ["add_arguments", "main"]
