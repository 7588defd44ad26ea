"""``mdr-drive dense``: where a policy is below the trapezoid on a dense grid of the whole domain
(``benchmarks.dense``).

    mdr-drive dense --policy agents/pretrained/ppo_generalist --ks 173 --loads 277 --out results/dense
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .evaluate import policy_path

HELP = "where a policy is below the trapezoid, on a dense grid (no search)"
DESCRIPTION = ("Play a policy and the trapezoid closed loop at every point of a dense grid of the blind benchmark's "
               "domain (k evenly spaced in [0, 0.6], loads from 0 to 1.25 x the trapezoid's critical load) and count "
               "where the policy is slower than the trapezoid by more than 0.05 mm/s. Writes dense.json, dense.md, "
               "below.csv and below_trapezoid.png. A sensor policy (MDRDriveSensor-v0) is checked over its hidden "
               "values instead: k x the load (0 to 0.4 of mu F_ref) x 9 friction pairs, each in its own env, counting "
               "the points below the trapezoid and where its period velocity swings (sensor_dense.json, "
               "sensor_dense.md, below.csv).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import int_range, output_dir

    p.add_argument("--policy", required=True, type=policy_path, help="policy folder (with model.zip)")
    p.add_argument("--ks", type=int_range(2, 1000), default=121, help="k values, evenly spaced in [0, 0.6] (-)")
    p.add_argument("--loads", type=int_range(2, 2000), default=200,
                   help="loads per k, evenly spaced from 0 to 1.25 x the trapezoid's critical load (-); for a sensor "
                        "policy from 0 to 0.4 of mu F_ref")
    p.add_argument("--out", type=output_dir, required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="replace an earlier dense check in --out")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def main(args: argparse.Namespace) -> int:
    from ..benchmarks import dense, sensor_dense
    from ..policy import read_run
    from ..run_record import command_line

    sensor = sensor_dense.is_sensor_run(read_run(args.policy))
    check = sensor_dense if sensor else dense
    name = "sensor_dense.json" if sensor else "dense.json"
    if (Path(args.out) / name).exists() and not args.force:
        raise ValueError(f"--out {args.out} already holds a dense check ({name}); pass --force to replace it")
    print(check.run(args.policy, args.ks, args.loads, args.out, command_line(), progress=not args.no_progress), end="")
    return 0
