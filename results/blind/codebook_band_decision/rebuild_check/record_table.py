"""CBBr's record on the fresh report seeds `RULE.md` named (``../../seedS_drawn_scan``), as the model card
tabulates it (``model_card.blind_record``; the targets judged by ``blind.missed_targets``): the first record,
20261255-60, or the seeds FIRST-LAST given (the second record: 20261273 20261278):

    python results/blind/codebook_band_decision/rebuild_check/record_table.py [FIRST LAST]
"""
import sys
from pathlib import Path

from mdr_drive_agents.blind_record import blind_record

first, last = (int(sys.argv[1]), int(sys.argv[2])) if len(sys.argv) == 3 else (20261255, 20261260)
files = [f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in range(first, last + 1)]
print(blind_record([f for f in files if Path(f).exists()], "runs/cbbr/policy"))
