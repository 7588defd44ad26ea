#!/usr/bin/env python
"""Check 1 of RULE.md: two teachers against the per-point search of searched blind seeds.

    python results/blind/steep_budget_decision/teacher_vs_search.py runs/s4/teacher_field.npz \
        results/recipe/teacher_field.npz results/blind/seed2026115[569]_drawn_scan ...

Per seed folder, each teacher's line of ``scripts/teacher_check.py --searched`` (fraction of the
search where it moves >= 2 mm/s: mean, min, points under 0.85; critical load over the best cycle's
at the seed's 25 k), then the sums the rule reads. Prints a markdown table.
"""

import re
import subprocess
import sys
from pathlib import Path

FRACTION = re.compile(r"fraction mean ([\d.]+), min ([\d.]+), (\d+) under 0.85")
CRITICAL = re.compile(r"critical load over that benchmark's best cycle's \((\d+) k\): min ([\d.]+), (\d+) at >= 0.97")


def teacher_line(field: str, folder: str) -> tuple[float, float, int, float, int, int]:
    out = subprocess.run([sys.executable, "scripts/teacher_check.py", "--n", "1", "--seed", "1", "--scan-ks", "1",
                          "--field", field, "--searched", f"{folder}/blind.json", "agents/pretrained/ppo_generalist"],
                         check=True, capture_output=True, text=True).stdout
    f, c = FRACTION.search(out), CRITICAL.search(out)
    return float(f[1]), float(f[2]), int(f[3]), float(c[2]), int(c[3]), int(c[1])


def main() -> int:
    new, old, *folders = sys.argv[1:]
    print(f"| seed | {old}: mean / min / under 0.85 / crit min (k at >= 0.97) | {new}: same |")
    print("|---|---|---|")
    sums = {new: [0.0, 0, 0], old: [0.0, 0, 0]}
    for folder in folders:
        cells = []
        for field in (old, new):
            mean, low, under, cmin, at, n = teacher_line(field, folder)
            sums[field][0] += mean / len(folders)
            sums[field][1] += under
            sums[field][2] += at == n
            cells.append(f"{mean:.3f} / {low:.3f} / {under} / {cmin:.3f} ({at}/{n})")
        print(f"| {Path(folder).name.split('_')[0].removeprefix('seed')} | {cells[0]} | {cells[1]} |", flush=True)
    for field, (mean, under, full) in sums.items():
        print(f"\n{field}: mean of the seeds' means {mean:.4f}; points under 0.85: {under}; "
              f"seeds with the critical load at >= 0.97 at every k: {full} of {len(folders)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
