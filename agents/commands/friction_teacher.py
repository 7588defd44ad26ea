"""``mdr-drive friction-teacher``: a full-observation teacher told friction (``train.friction_teacher``).

    mdr-drive friction-teacher agents/configs/friction_teacher.yaml --out runs/friction_teacher
"""

from __future__ import annotations

import argparse

HELP = "a teacher told friction: drive fields at several mu1/mu, distilled into one network"
DESCRIPTION = ("Search drive fields at several ratios mu1 / mu (OUT/fields/rho*.npz), then distil them into one "
               "PPO MlpPolicy on MDRDrive-v0's privileged observation with friction drawn per episode "
               "(OUT/policy/): a teacher for a sensor policy that must estimate friction too. Ctrl-C keeps the "
               "finished fields and the student's first round once labelled or fitted: continue with --resume.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.sweep import add_executor_arguments

    from ..train.friction_teacher import DEFAULT_CONFIG
    from . import add_recipe_arguments

    add_recipe_arguments(p, DEFAULT_CONFIG, "YAML with seed, friction, teacher, distill, ppo and env_kwargs "
                         "(default: agents/configs/friction_teacher.yaml)", "runs/friction_teacher")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..blas import pin_command
    from ..train.friction_teacher import run

    pin_command()
    return run_command("mdr-drive friction-teacher",
                       lambda: run(args.config, args.out, executor_from(args), resume=args.resume, force=args.force,
                                   progress=not args.no_progress),
                       f"the finished fields and the student's first round, once labelled or fitted, are kept, "
                       f"continue with --resume --out {args.out}")
