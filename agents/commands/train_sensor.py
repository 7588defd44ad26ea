"""``mdr-drive train-sensor``: the sensor policy's recipe (``train.sensor``).

    mdr-drive train-sensor agents/configs/sensor.yaml --out runs/sensor --force      # make train-sensor
"""

from __future__ import annotations

import argparse
import sys

HELP = "the sensor policy's recipe: an estimator of k, the load and friction, merged with its teacher"
DESCRIPTION = ("Build a policy that drives MDRDriveSensor-v0 without being told k, the load or friction "
               "(agents/configs/sensor.yaml, docs/adaptation.md): an estimator of what the sensor hides is fitted on "
               "episodes its full-observation teacher drives, round by round on its own guesses (DAgger), then "
               "written with the teacher as one plain SB3 MlpPolicy (OUT/policy/, OUT/adapt.json). A Ctrl-C once the first "
               "round's fit has finished saves the policy of the last finished round and exits with 130.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..train.sensor import DEFAULT_CONFIG
    from . import add_recipe_arguments

    from mdr_drive_env.gym_envs.sensor import SENSOR_TIERS

    add_recipe_arguments(p, DEFAULT_CONFIG, "YAML with seed, validation_seed and the AdaptConfig fields (default: "
                         "agents/configs/sensor.yaml)", "runs/sensor")
    p.add_argument("--sensor-tier", choices=SENSOR_TIERS, default=None,
                   help="the sensor tier the policy drives with (default: the config's sensor_tier): encoder "
                        "(per-period summaries), trace (positions through each period), self-sensing (and the "
                        "piezo-sensed forces); docs/adaptation.md")


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command

    from ..train.sensor import run

    summary = {}
    code = run_command("mdr-drive train-sensor",
                       lambda: summary.update(run(args.config, args.out, force=args.force, progress=not args.no_progress,
                                                  sensor_tier=args.sensor_tier)),
                       "nothing was saved (the first round had not finished, or the save was cut short)")
    if code == 0 and summary.get("interrupted"):
        print(f"mdr-drive train-sensor: interrupted; the policy of the last finished round is in {args.out}/policy "
              "(adapt.json: interrupted)", file=sys.stderr)
        return 130
    return code
