#!/usr/bin/env python
"""Reproduce the paper's Figs. 3-5 and the h_N/h_T sensitivity plot (PNG + CSV under results/paper/).

    python scripts/reproduce_paper.py [--numerics paper|default] [--out results/paper] [--quick]

Same as ``mdr-drive reproduce``; see its --help for every option.
"""

import sys

from mdr_drive_env.cli import main

if __name__ == "__main__":
    sys.exit(main(["reproduce", *sys.argv[1:]]))
