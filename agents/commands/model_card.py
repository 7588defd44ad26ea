"""``mdr-drive model-card``: ship a trained policy with its model card (``benchmarks.model_card``).

    mdr-drive model-card runs/recipe/policy agents/pretrained/ppo_generalist results/record/seed*/blind.json
    mdr-drive model-card runs/sensor/policy agents/pretrained/ppo_sensor results/adaptation/adaptation.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "ship a trained policy: copy its files and write its model card"
DESCRIPTION = ("Copy a policy's files (model.zip, vecnormalize.npz and .pkl, run.json, its action table) to DST and write "
               "DST/MODEL_CARD.md: how to load it, how it was made, its limits, an evaluation table computed from the "
               "shipped files, and its blind record (one blind.json per report seed) or, for a sensor policy, its "
               "adaptation report.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import folder_with, input_file, output_dir

    from ..policy import FILES

    p.add_argument("src", type=folder_with(*FILES), help="the trained policy's folder (model.zip, vecnormalize.npz and .pkl, "
                                                         "run.json)")
    p.add_argument("dst", type=output_dir, help="where to ship it (its files are replaced, MODEL_CARD.md written)")
    p.add_argument("results", nargs="*", type=input_file, default=[],
                   help="blind.json of mdr-drive benchmark --blind, one per report seed (the card quotes each), or, "
                        "for a sensor policy, one adaptation.json of mdr-drive adaptation")
    p.add_argument("--ran-from", type=folder_with(*FILES), default=None,
                   help="the folder the blind results ran this policy from, if neither SRC nor DST: a copy of the "
                        "same network (checked before anything is copied)")


def main(args: argparse.Namespace) -> int:
    from ..benchmarks.model_card import ship, ship_sensor

    sensor = any(Path(r).name == "adaptation.json" for r in args.results)
    if sensor and len(args.results) != 1:
        raise ValueError(f"a sensor policy's card quotes one adaptation.json, got {len(args.results)} files")
    card = ship_sensor(args.src, args.dst, args.results[0]) if sensor else ship(args.src, args.dst, args.results,
                                                                                 args.ran_from)
    print(card.read_text())
    return 0
