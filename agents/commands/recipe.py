"""``mdr-drive recipe``: a drive's policies, teacher to the student told k and the load and the sensor policy
(``train.recipe``).

    mdr-drive recipe agents/configs/recipe.yaml --out runs/recipe --force      # make train
"""

from __future__ import annotations

import argparse

HELP = "build a drive's policies: CMA-ES teacher, a student told k and the load, a sensor policy"
DESCRIPTION = ("Build a drive's policies, for the paper's drive or --drive FILE "
               "(agents/configs/recipe.yaml, docs/results.md, docs/your_drive.md): "
               "1. the teacher, the best open-loop drives CMA-ES finds on a grid of k and load, polished and refined "
               "stage by stage (OUT/teacher_field.npz); 2. the student, a plain SB3 PPO MlpPolicy (OUT/policy/): "
               "with 'distill' (the YAML's student), a classifier fitted to the teacher's picks by DAgger; with "
               "--student worth, a network that predicts the worth of each of the teacher's drives from k and the "
               "load, fitted to their velocities at random points, which plays the best; 3. with the YAML's 'sensor_policy' "
               "section and without --only told, the sensor policy (OUT/sensor_policy/), told nothing of k, the load or "
               "friction: a table of the teacher's drives and of searches at draws of the hidden values started from "
               "them (OUT/drive_table.npz), and a network that picks from it by the worth it predicts from the sensor, "
               "trained by DAgger (docs/adaptation.md); on --drive FILE it hides k and the load over the drive's ranges "
               "and the friction pair over the ranges the file sets, or x 2/3-4/3 (mu) and x 0.7-1.3 (mu1) of its pair. "
               "Each stage's wall time is printed and kept "
               "in OUT/recipe.json. Ctrl-C keeps the teacher's finished k slices, the student's labelled "
               "points (with 'distill', its first round once labelled or fitted), the sensor table's searches and "
               "values and its episodes' values: continue with --resume.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import input_file
    from mdr_drive_env.sweep import add_executor_arguments

    from ..train.recipe import DEFAULT_CONFIG, ONLY, STUDENTS
    from . import add_drive_argument, add_recipe_arguments, add_sensor_tier_argument

    add_recipe_arguments(p, DEFAULT_CONFIG, "recipe YAML (default: agents/configs/recipe.yaml)", "runs/recipe")
    p.add_argument("--teacher", type=input_file, default=None,
                   help="a saved teacher field (.npz, a recipe's teacher_field.npz): skip the teacher search")
    p.add_argument("--snapshots", action="store_true",
                   help="also save the student after each hole round, in OUT/snapshots/hole_round<H>/ ('distill' only)")
    p.add_argument("--student", choices=STUDENTS, default=None,
                   help="the student, instead of the YAML's 'student': 'distill', a classifier fitted to the teacher's "
                        "picks by DAgger; 'worth', a network of each of the teacher's drives' worth at k and the load "
                        "(the YAML's 'worth' section)")
    p.add_argument("--only", choices=ONLY, default=None,
                   help="build only this policy: 'told', the policy told k and the load (OUT/policy/), without the "
                        "sensor policy of the YAML's 'sensor_policy' section")
    add_sensor_tier_argument(p, "the sensor policy (OUT/sensor_policy/)")
    add_drive_argument(p, "to build the policies for (their run.json records it; friction_coefficient and "
                          "base_friction_coefficient may be [low, high] ranges: the sensor policy's hidden friction)")
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
                                   drive=args.drive, student_kind=args.student, only=args.only,
                                   sensor_tier=args.sensor_tier),
                       f"the teacher's finished slices and the student's first round, once labelled or fitted, "
                       f"are kept, continue with --resume --out {args.out}")
