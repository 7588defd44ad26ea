#!/usr/bin/env python
"""Learned waveforms vs the paper's trapezoid vs CMA-ES over k and the load (results/benchmark/).

    python scripts/benchmark_waveforms.py --policies runs/ppo_s0 runs/ppo_s1 runs/ppo_s2 [--quick]

Same as ``mdr-drive benchmark``; see its --help.
"""

import sys

from mdr_drive_env.cli import main

if __name__ == "__main__":
    sys.exit(main(["benchmark", *sys.argv[1:]]))
