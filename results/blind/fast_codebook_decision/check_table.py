"""The rule's step 2 (RULE.md): a candidate (NAME: cbbf or cbbg, `runs/NAME/policy`) on the fourteen decision
seeds' stored searches, written by `bash results/blind/fast_codebook_decision/check.sh NAME`:

    python results/blind/fast_codebook_decision/check_table.py cbbf > results/blind/fast_codebook_decision/check_table.md
    python results/blind/fast_codebook_decision/check_table.py cbbg > results/blind/fast_codebook_decision/check_table_cbbg.md
"""
import sys
from pathlib import Path

sys.path.insert(0, "results/blind/codebook_band_decision")
from check_table import misses  # noqa: E402

from mdr_drive_agents.blind_record import blind_record  # noqa: E402

HERE = Path("results/blind/fast_codebook_decision")
SEEDS = (3232, 9292, *range(20261219, 20261225), *range(20261249, 20261255))
name = sys.argv[1] if len(sys.argv) > 1 else "cbbf"
files = [HERE / f"{name}_seed{s}" / "blind.json" for s in SEEDS]
print(f"### {name[:3].upper()}{name[3:]} on the fourteen decision seeds (misses: {misses(files, f'runs/{name}/policy')})\n")
print(blind_record(files, f"runs/{name}/policy"))
