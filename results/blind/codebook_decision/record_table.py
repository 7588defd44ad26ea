"""The rule's table (RULE.md): F1s1's record on seeds 20261219-24 and each checked candidate on the same
points, searches and scans, as the model card tabulates them (``model_card.blind_record``, the targets
judged by ``blind.missed_targets``): python results/blind/codebook_decision/record_table.py"""
from pathlib import Path

from mdr_drive_agents.blind_record import blind_record

SEEDS = range(20261219, 20261225)
HERE = Path("results/blind/codebook_decision")
print("F1s1 (shipped), its record `seedS_drawn_scan`:\n")
print(blind_record([f"results/blind/seed{seed}_drawn_scan/blind.json" for seed in SEEDS],
                   "agents/pretrained/ppo_generalist"))
for name in ("cb60", "cbs", "cb30"):  # cb30 was stopped unjudged (RULE.md, addendum)
    files = [HERE / f"{name}_seed{seed}" / "blind.json" for seed in SEEDS]
    if all(f.exists() for f in files):
        print(f"\n{name} (`{name}_seedS`, the same searches):\n")
        print(blind_record(files, f"runs/{name}/policy"))
