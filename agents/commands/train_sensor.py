"""``mdr-drive train-sensor``: the sensor policy's recipe (``train.sensor``).

    mdr-drive train-sensor agents/configs/sensor.yaml --out runs/sensor --force      # make train-sensor
"""

from __future__ import annotations

import argparse
import sys

HELP = "the sensor policy's recipe: a network that picks whole drives from a table by their predicted worth"
DESCRIPTION = ("Build a policy that drives MDRDriveSensor-v0 without being told k, the load or friction "
               "(agents/configs/sensor.yaml, docs/adaptation.md): a table of fixed actions and two-action cycles "
               "searched at draws of the hidden parameters (OUT/drive_table.npz), their steady velocities at the "
               "training episodes' hidden points (OUT/episode_values.npz), then rounds of DAgger in which a network "
               "learns each drive's worth from the sensor observation and plays the best; written as one plain SB3 "
               "MlpPolicy (OUT/policy/, OUT/adapt.json). The searches run on local processes or Ray and are kept as "
               "they finish (--resume). A Ctrl-C once the first round's fit has finished saves the policy of the last "
               "finished round and exits with 130.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import folder_with
    from mdr_drive_env.sweep import add_executor_arguments

    from ..train.sensor import DEFAULT_CONFIG, TABLE_FILE
    from . import add_recipe_arguments, add_sensor_tier_argument

    add_recipe_arguments(p, DEFAULT_CONFIG, "YAML with seed, validation_seed, table (DriveTableConfig) and sensor "
                         "(SensorConfig) (default: agents/configs/sensor.yaml)", "runs/sensor")
    add_sensor_tier_argument(p, "the policy")
    p.add_argument("--reuse", type=folder_with(TABLE_FILE), default=None, metavar="RUN",
                   help="an earlier train-sensor output folder whose drive table (and training episodes' values, "
                        "where they are for the same episodes) are used instead of building them: how the other "
                        "tiers are trained from one table")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..train.sensor import run

    summary = {}
    code = run_command("mdr-drive train-sensor",
                       lambda: summary.update(run(args.config, args.out, force=args.force, progress=not args.no_progress,
                                                  sensor_tier=args.sensor_tier, reuse=args.reuse, resume=args.resume,
                                                  executor=replace(executor_from(args),
                                                                   progress=not args.no_progress))),
                       "nothing was saved but the finished searches (the first round had not finished, or the save "
                       "was cut short); --resume continues the searches")
    if code == 0 and summary.get("interrupted"):
        print(f"mdr-drive train-sensor: interrupted; the policy of the last finished round is in {args.out}/policy "
              "(adapt.json: interrupted)", file=sys.stderr)
        return 130
    return code
