"""``mdr-drive benchmark``: policies against the trapezoid and CMA-ES on the fixed grid
(``benchmarks.grid``), or on random points drawn with a seed (``--blind N --seed S``,
``benchmarks.blind``).

    mdr-drive benchmark --policies agents/pretrained/ppo_generalist --out results/benchmark
    mdr-drive benchmark --blind 120 --seed 20261255 --scan-draw --policies agents/pretrained/ppo_generalist
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .evaluate import policy_path

HELP = "policies vs the trapezoid vs CMA-ES: the fixed grid, or --blind random points"
DESCRIPTION = ("Judge policies against the paper's trapezoid and the best drive a stated CMA-ES search finds: on the "
               "fixed grid of k and cargo mass (tables and plots like the paper's), or with --blind N --seed S on N "
               "random points of the training domain that no choice was tuned on, with a critical-load scan over k. "
               "The searches run on local processes or a Ray cluster and are kept as they finish (--resume).")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import input_file, int_range, output_dir, positive_int
    from mdr_drive_env.sweep import add_executor_arguments

    from ..search import CMA_BUDGET

    p.add_argument("--policies", nargs="*", default=[], type=policy_path,
                   help="policy folders (model.zip, vecnormalize.npz, run.json; read as data), e.g. one per training seed")
    p.add_argument("--out", default=None, type=output_dir,
                   help="output folder (default: results/benchmark, or runs/blind/seed<S> with --blind)")
    p.add_argument("--quick", action="store_true", help="a CI-sized grid and CMA-ES budget")
    add_executor_arguments(p)  # the CMA-ES searches, of the grid and of --blind
    from . import add_drive_argument

    add_drive_argument(p, "to judge on, with --blind (the policies must have been built for it)")
    b = p.add_argument_group("blind benchmark: random points of the training domain")
    b.add_argument("--blind", type=positive_int, default=None, metavar="N",
                   help="draw N (k, load) points with --seed instead of the fixed grid (-)")
    b.add_argument("--seed", type=int, default=None, help="seed of the blind points (-); required with --blind")
    b.add_argument("--scan-ks", type=int_range(0), default=25,
                   help="k values of the critical-load scan, evenly spaced over the drive's k range (-); 0: no scan, "
                        "the points alone (a 4-point run then takes seconds)")
    b.add_argument("--scan-draw", action="store_true",
                   help="draw the scan's k values with --seed, one uniform k in each of --scan-ks equal cells of "
                        "[0, 0.6], instead of spacing them evenly (the same for every seed): the critical-load "
                        "target judged on k values nobody tuned to")
    b.add_argument("--reference", choices=("standard", "strong"), default="standard",
                   help="the search that finds each point's best drive: 'standard', CMA-ES over fixed actions and "
                        "over two-action cycles from the trapezoid and push/clamp; 'strong', then three rounds at "
                        "every point of CMA-ES from the fastest there of every point's best drive so far (the first "
                        "round also from 1,000 random cycles), which the recipe's policies do not beat on average "
                        "(about 2.5x the standard search's time per point)")
    b.add_argument("--reuse-search", default=None, metavar="BLIND.json", type=input_file,
                   help="take the points, the trapezoid and the searches from an earlier blind.json of the same "
                        "seed, size and budgets; only the policies run")
    p.add_argument("--cma-budget", type=positive_int, default=None,
                   help=f"CMA-ES evaluations per point of the fixed-action search (-) (default: {CMA_BUDGET})")


def main(args: argparse.Namespace) -> int:
    from mdr_drive_env.sweep import executor_from

    from ..blas import pin_command

    pin_command()
    if args.blind is not None:
        from ..benchmarks import blind

        if args.seed is None:
            raise ValueError("--blind needs --seed: the seed that draws the points (keep one for your own "
                             "choices, report on another)")
        out = args.out or f"runs/blind/seed{args.seed}"
        budget = {"fixed_budget": args.cma_budget} if args.cma_budget else {}
        blind.run(args.policies, args.blind, args.seed, out, quick=args.quick, scan_ks=args.scan_ks,
                  scan_draw=args.scan_draw, reuse=args.reuse_search, executor=executor_from(args), resume=args.resume,
                  drive=args.drive, reference=args.reference, **budget)
        print((Path(out) / "blind.md").read_text())
        print(f"tables and figures in {out}/")
        return 0
    if args.seed is not None:
        raise ValueError("--seed draws blind points: give --blind N too (the fixed grid has no seed)")
    if args.drive is not None:
        raise ValueError("--drive needs --blind N: the fixed grid is the paper drive's (its loads in kg); a blind "
                         "benchmark draws loads relative to the drive's trapezoid")
    from ..benchmarks.grid import run

    out = args.out or "results/benchmark"
    res = run(args.policies, out, args.quick, args.cma_budget, executor=executor_from(args), resume=args.resume)
    print((Path(out) / "benchmark.md").read_text())
    print(f"wall time {res['wall_time_s']} s; figures and tables in {out}/")
    return 0
