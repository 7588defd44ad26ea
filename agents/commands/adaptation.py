"""``mdr-drive adaptation``: a sensor policy on draws of the hidden parameters and through load steps
(``benchmarks.adaptation``).

    mdr-drive adaptation --seed 20261125 --out results/adaptation      # make adaptation
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .evaluate import policy_path

HELP = "a sensor policy on hidden-parameter draws and load steps"
DESCRIPTION = ("Sensor policies (k, the load and friction hidden; one per sensor tier) against the trapezoid, a waveform tuned once, its "
               "full-observation teacher and the best drive a CMA-ES search finds at each of N draws of the hidden "
               "parameters, and through M load steps (recovery within 5 periods). Writes adaptation.json, "
               "adaptation.md, CSVs and plots; the per-point searches are kept as they finish (--resume).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import input_file, output_dir, positive_int
    from mdr_drive_env.sweep import add_executor_arguments

    from ..benchmarks.adaptation import FULL_POLICY, SENSOR_POLICY

    p.add_argument("--sensor-policy", action="append", default=None, type=policy_path, metavar="FOLDER",
                   help=f"a sensor policy's folder, each played in its own sensor tier; give it once per tier to "
                        f"compare tiers side by side (default: {SENSOR_POLICY})")
    p.add_argument("--full-policy", default=FULL_POLICY, type=policy_path,
                   help="the full-observation policy's folder, the upper bound, built for the sensor policies' drive "
                        "(default: the paper drive's, told k, the load and mu1/mu; for a sensor policy of "
                        "`mdr-drive recipe --drive`, the recipe's OUT/policy, told k and the load)")
    p.add_argument("--blind", type=positive_int, default=48, metavar="N", help="draws of the hidden parameters (-)")
    p.add_argument("--load-steps", type=positive_int, default=24, metavar="M", help="load-step episodes (-)")
    p.add_argument("--seed", type=int, required=True,
                   help="seed of the draws (-): keep one for your own choices, report on another")
    p.add_argument("--out", default=None, type=output_dir, help="output folder (default: runs/adaptation/seed<S>)")
    p.add_argument("--quick", action="store_true", help="tiny per-point searches (CI)")
    p.add_argument("--replot", action="store_true",
                   help="only redraw the plots and adaptation.md from OUT/adaptation.json (nothing recomputed)")
    p.add_argument("--reuse-search", default=None, metavar="ADAPTATION.json", type=input_file,
                   help="take the per-point searches from an earlier adaptation.json of the same seed, --blind and "
                        "budgets; only the drives run")
    add_executor_arguments(p)


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.cli_args import run_command
    from mdr_drive_env.sweep import executor_from

    from ..benchmarks.adaptation import SENSOR_POLICY, markdown, plot, run
    from ..blas import pin_command
    from . import replot

    out = Path(args.out or f"runs/adaptation/seed{args.seed}")
    if args.replot:
        replot(out, "adaptation", markdown, lambda res: plot(res, out))
        return 0
    pin_command()

    def work():
        res = run(args.sensor_policy or [SENSOR_POLICY], args.full_policy, args.blind, args.load_steps, args.seed, out, quick=args.quick,
                  executor=executor_from(args), resume=args.resume, reuse=args.reuse_search)
        print(markdown(res).split("\n| k |")[0])

    return run_command("mdr-drive adaptation", work, "finished searches are kept, continue with --resume "
                                                     f"--seed {args.seed} --out {out}")
