"""CBB's record on the fresh report seeds its rule named (20261249-54, `../seedS_drawn_scan`), as the model
card tabulates it (``model_card.blind_record``; the targets judged by ``blind.missed_targets``):

    python results/blind/codebook_band_decision/record_table.py
"""
from mdr_drive_agents.blind_record import blind_record

SEEDS = range(20261249, 20261255)
print(blind_record([f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in SEEDS], "runs/cbb/policy"))
