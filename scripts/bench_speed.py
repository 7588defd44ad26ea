#!/usr/bin/env python
"""Speed and accuracy of the fast solver against the paper preset; writes results/bench/bench_speed.{json,md}.

    python scripts/bench_speed.py [--out results/bench] [--quick]

Same as ``mdr-drive bench``. The paper preset's reference displacements on the accuracy grid are
cached in results/bench/reference_paper.npz (about half an hour of CPU to recompute).
"""

import sys

from mdr_drive_env.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
