"""The rule's table (RULE.md): CBD and its recipe's student seeds 0 and 2 (the addendum) against CBB on
fourteen decision seeds' stored searches (3232, 9292; the spent report seeds 20261219-24 and
20261249-54), as the model card tabulates them
(``model_card.blind_record``; the targets judged by ``blind.missed_targets``), and the rule's miss
count (points under 0.85 + points below the trapezoid + scanned k under 0.97) per seed group:

    python results/blind/dense_band_decision/check_table.py
"""
import sys
from pathlib import Path

sys.path.insert(0, "results/blind/codebook_band_decision")
from check_table import misses  # noqa: E402

from mdr_drive_agents.blind_record import blind_record  # noqa: E402

HERE = Path("results/blind/dense_band_decision")
GROUPS = {"decision seeds 3232, 9292": (3232, 9292),
          "F1s1's spent record seeds 20261219-24": range(20261219, 20261225),
          "CBB's spent record seeds 20261249-54": range(20261249, 20261255)}


def cbb_file(seed: int) -> Path:
    if seed in (3232, 9292):
        return Path("results/blind/codebook_band_decision") / f"cbb_seed{seed}" / "blind.json"
    if seed < 20261249:
        return Path("results/blind/codebook_decision") / f"cbb_seed{seed}" / "blind.json"
    return Path("results/blind") / f"seed{seed}_drawn_scan" / "blind.json"


NAMES = {"cbd": "CBD (student seed 1)", "cbd_s0": "student seed 0", "cbd_s2": "student seed 2"}

for name, label in NAMES.items():
    for title, seeds in GROUPS.items():
        files = [HERE / f"{name}_seed{s}" / "blind.json" for s in seeds]
        cbb = [cbb_file(s) for s in seeds]
        print(f"### {label}, {title} (misses: {misses(files, f'runs/{name}/policy')}; CBB's: "
              f"{misses(cbb, 'runs/cbb/policy')})\n")
        print(blind_record(files, f"runs/{name}/policy"))
        print()
