"""CBB's recipe as `make train` rebuilt it (`runs/cbbr/policy`, a copy of its `runs/recipe/policy`; run.json
in `rebuilt_run.json`) on the fourteen decision seeds' stored searches, written by
`bash results/blind/dense_band_decision/check.sh cbbr` (then moved here), as information:

    python results/blind/codebook_band_decision/rebuild_check/table.py
"""
import sys
from pathlib import Path

sys.path.insert(0, "results/blind/codebook_band_decision")
from check_table import misses  # noqa: E402

from mdr_drive_agents.blind_record import blind_record  # noqa: E402

HERE = Path("results/blind/codebook_band_decision/rebuild_check")
GROUPS = {"decision seeds 3232, 9292": (3232, 9292),
          "F1s1's spent record seeds 20261219-24": range(20261219, 20261225),
          "CBB's record seeds 20261249-54": range(20261249, 20261255)}
for title, seeds in GROUPS.items():
    files = [HERE / f"cbbr_seed{s}" / "blind.json" for s in seeds]
    print(f"### the rebuilt student, {title} (misses: {misses(files, 'runs/cbbr/policy')})\n")
    print(blind_record(files, "runs/cbbr/policy"))
    print()
