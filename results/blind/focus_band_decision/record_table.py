"""F1's record (seeds 20261213-18) as the model card tabulates it (``model_card.blind_record``, the
targets judged by ``blind.missed_targets``): python results/blind/focus_band_decision/record_table.py"""
from mdr_drive_agents.blind_record import blind_record

print(blind_record([f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in range(20261213, 20261219)],
                   "agents/pretrained/ppo_generalist"))
