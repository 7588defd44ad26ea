"""F1s1's record (seeds 20261219-24) and F1 (seed 0) beside it on the same seeds, points, searches
and scans, as the model card tabulates them (``model_card.blind_record``, the targets judged by
``blind.missed_targets``): python results/blind/f1_seed_decision/record_table.py"""
from mdr_drive_agents.blind_record import blind_record

SEEDS = range(20261219, 20261225)
print("F1s1 (student seed 1), policy 1 of `seedS_drawn_scan`:\n")
print(blind_record([f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in SEEDS],
                   "agents/pretrained/ppo_generalist"))
print("\nF1 (student seed 0), policy 2 of `seedS_drawn_scan_f1_beside` (the same searches):\n")
print(blind_record([f"results/blind/seed{seed}_drawn_scan_f1_beside/blind.json" for seed in SEEDS],
                   "runs/recipe/policy"))
