"""The rule's step 2 (RULE.md): CBBg (`runs/cbbg/policy`) on the fourteen decision seeds' stored searches,
written by `bash results/blind/fast_codebook_decision/check.sh cbbg`:

    python results/blind/fast_codebook_decision/check_table.py > results/blind/fast_codebook_decision/check_table.md
"""
import sys
from pathlib import Path

sys.path.insert(0, "results/blind/codebook_band_decision")
from check_table import misses  # noqa: E402

from mdr_drive_agents.model_card import blind_record  # noqa: E402

HERE = Path("results/blind/fast_codebook_decision")
SEEDS = (3232, 9292, *range(20261219, 20261225), *range(20261249, 20261255))
files = [HERE / f"cbbg_seed{s}" / "blind.json" for s in SEEDS]
print(f"### CBBg on the fourteen decision seeds (misses: {misses(files, 'runs/cbbg/policy')})\n")
print(blind_record(files, "runs/cbbg/policy"))
