"""Q1 beside F1 on F1's report seeds, on the same searches and scans (after the record; decides nothing):
bash: for S in 20261213 ... 20261218: mdr-drive benchmark --blind 120 --seed S --scan-draw --policies
agents/pretrained/ppo_generalist runs/q1/policy --reuse-search results/blind/seedS_drawn_scan/blind.json --out runs/q1_beside_S
(two at a time, about 90 s each), then: python results/blind/focus_band_decision/q1_beside.py"""
import json

from mdr_drive_agents.blind import missed_targets

NAMES = {"agents/pretrained/ppo_generalist": "F1", "runs/q1/policy": "Q1"}
print("| seed | build | below the trapezoid | fraction mean | fraction min (under 0.85) | critical load / best cycle's: min (k at >= 0.97) | missed |")
print("|---|---|---|---|---|---|---|")
clean = {name: 0 for name in NAMES.values()}
for seed in range(20261213, 20261219):
    stats = json.load(open(f"runs/q1_beside_{seed}/blind.json"))["statistics"]
    for path, name in NAMES.items():
        s = stats[path]
        missed = missed_targets(s)
        clean[name] += not missed
        print(f"| {seed} | {name} | {s['points_below_trapezoid']} | {s['fraction_of_best_mean']:.3f} | "
              f"{s['fraction_of_best_min']:.3f} ({s['points_under_fraction_target']} of {s['points_scored']}) | "
              f"{s['critical_load_over_best_cycle_min']:.3f} ({s['k_values_at_critical_load_target']}/25) | {', '.join(missed) or 'none'} |")
print("\nevery target: " + ", ".join(f"{n} on {c} of 6" for n, c in clean.items()))
