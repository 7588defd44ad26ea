"""CBBr's record on the fresh report seeds `RULE.md` named (20261255-60, `../../seedS_drawn_scan`), as the
model card tabulates it (``model_card.blind_record``; the targets judged by ``blind.missed_targets``):

    python results/blind/codebook_band_decision/rebuild_check/record_table.py
"""
from pathlib import Path

from mdr_drive_agents.model_card import blind_record

files = [f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in range(20261255, 20261261)]
print(blind_record([f for f in files if Path(f).exists()], "runs/cbbr/policy"))
