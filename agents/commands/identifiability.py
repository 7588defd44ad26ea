"""``mdr-drive identifiability``: what a drive's sensors can tell of its hidden k, load and friction,
by the drive played and the sensor tier (``benchmarks.identifiability``).

    mdr-drive identifiability --seed 20261501 --out results/identifiability     # make identifiability
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "what each sensor tier can tell of the hidden k, load and friction, by the drive played"
DESCRIPTION = ("Play MDRDriveSensor-v0's hidden-parameter draws with a drive (the trapezoid, the deliberate probe, "
               "the full-observation teacher, a sensor policy on its own guesses; from rest or up to period "
               "--steady-end) for P periods, fit an MLP from each sensor tier's measurements of them to k, the load "
               "over mu F_ref, the load, mu1/mu, mu and mu1, and score it on other draws (standardised error: 0 "
               "exact, 1 no better than the mean). Writes identifiability.json, identifiability.md and "
               "identifiability.png; the drives are kept as they finish (--resume).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import int_range, output_dir, positive_int
    from mdr_drive_env.gym_envs.sensor import SENSOR_TIERS
    from mdr_drive_env.sweep import add_executor_arguments

    from ..benchmarks.identifiability import DRIVES, IdentifiabilityConfig
    from .evaluate import policy_path

    d = IdentifiabilityConfig(seed=0)
    p.add_argument("--seed", type=int_range(0), required=True,
                   help="seed of the hidden draws and the fits (-): keep one for your own choices, report on another")
    p.add_argument("--out", type=output_dir, required=True, help="output folder")
    p.add_argument("--episodes", type=int_range(2), default=d.episodes, help="draws each estimator is fitted on (-)")
    p.add_argument("--test-episodes", type=int_range(2), default=d.test_episodes,
                   help="further draws it is scored on (-)")
    p.add_argument("--periods", type=int_range(1, 64), nargs="+", default=list(d.periods), metavar="P",
                   help="periods the sensors measure, one study per value (-)")
    p.add_argument("--drives", nargs="+", choices=DRIVES, default=list(DRIVES), metavar="DRIVE",
                   help=f"what is played: {', '.join(repr(x) for x in DRIVES)} (a steady drive: the P periods that end "
                        "at --steady-end)")
    p.add_argument("--tiers", nargs="+", choices=SENSOR_TIERS, default=list(SENSOR_TIERS), metavar="TIER",
                   help=f"sensor tiers scored: {', '.join(SENSOR_TIERS)}")
    p.add_argument("--steady-end", type=positive_int, default=d.steady_end,
                   help="the period the steady drives' P periods end at (-)")
    p.add_argument("--teacher", type=policy_path, default=d.teacher,
                   help="the full-observation policy the teacher drives play (told k, the load and mu1/mu)")
    p.add_argument("--sensor-policy", type=policy_path, default=d.sensor_policy,
                   help="the sensor policy the sensor-steady drive plays, on its own sensor observation")
    p.add_argument("--steps", type=positive_int, default=d.steps, help="Adam steps of each estimator's fit (-)")
    p.add_argument("--force", action="store_true", help="replace an earlier study in --out")
    p.add_argument("--replot", action="store_true",
                   help="only redraw identifiability.md and the plot from OUT/identifiability.json (nothing recomputed)")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..benchmarks.identifiability import IdentifiabilityConfig, markdown, plot, run
    from ..run_record import command_line
    from . import replot

    out = Path(args.out)

    def work():
        if args.replot:
            replot(out, "identifiability", markdown, lambda res: plot(res, out / "identifiability.png"))
            return
        if (out / "identifiability.json").exists() and not (args.force or args.resume):
            raise ValueError(f"--out {out} already holds a study (identifiability.json); pass --force to replace it")
        config = IdentifiabilityConfig(seed=args.seed, episodes=args.episodes, test_episodes=args.test_episodes,
                                       periods=tuple(args.periods), drives=tuple(args.drives), tiers=tuple(args.tiers),
                                       steady_end=args.steady_end, teacher=args.teacher,
                                       sensor_policy=args.sensor_policy, steps=args.steps)
        print(markdown(run(config, out, command_line(), executor_from(args), args.resume)), end="")

    return run_command("mdr-drive identifiability", work,
                       f"finished drives are kept, continue with --resume --seed {args.seed} --out {out}")
