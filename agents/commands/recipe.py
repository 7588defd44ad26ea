"""``mdr-drive recipe``: a policy for a drive told its k and load, teacher to student (``train.recipe``).

    mdr-drive recipe agents/configs/recipe.yaml --out runs/recipe --force      # make train
"""

from __future__ import annotations

import argparse

HELP = "build a policy for a drive: CMA-ES teacher, then the distilled PPO student"
DESCRIPTION = ("Build a policy that is told k and the load, for the paper's drive or --drive FILE "
               "(agents/configs/recipe.yaml, docs/results.md, docs/your_drive.md): "
               "1. the teacher, the best open-loop drives CMA-ES finds on a grid of k and load, polished and refined "
               "stage by stage (OUT/teacher_field.npz); 2. the student, a plain SB3 PPO MlpPolicy fitted to the "
               "teacher's actions by DAgger (OUT/policy/). Each stage's wall time is printed and kept in "
               "OUT/recipe.json. Ctrl-C keeps the teacher's finished k slices and the student's first round "
               "once labelled or fitted: continue with --resume.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import input_file
    from mdr_drive_env.sweep import add_executor_arguments

    from ..train.recipe import DEFAULT_CONFIG
    from . import add_drive_argument, add_recipe_arguments

    add_recipe_arguments(p, DEFAULT_CONFIG, "recipe YAML (default: agents/configs/recipe.yaml)", "runs/recipe")
    p.add_argument("--teacher", type=input_file, default=None,
                   help="a saved teacher field (.npz, a recipe's teacher_field.npz): skip the teacher search")
    p.add_argument("--snapshots", action="store_true",
                   help="also save the student after each hole round, in OUT/snapshots/hole_round<H>/")
    add_drive_argument(p, "to build the policy for (its run.json records it)")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..blas import pin_command
    from ..train.recipe import run

    pin_command()
    return run_command("mdr-drive recipe",
                       lambda: run(args.config, args.out, executor_from(args), resume=args.resume, force=args.force,
                                   progress=not args.no_progress, teacher=args.teacher, snapshots=args.snapshots,
                                   drive=args.drive),
                       f"the teacher's finished slices and the student's first round, once labelled or fitted, "
                       f"are kept, continue with --resume --out {args.out}")
