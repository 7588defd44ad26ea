"""F1's record (seeds 20261213-18) as a table, from each seed's blind.json:
python results/blind/focus_band_decision/record_table.py"""
import json

POLICY = "agents/pretrained/ppo_generalist"
print("| seed | below the trapezoid | fraction mean | fraction min (under 0.85) | critical load / best cycle's: min (k at >= 0.97) | missed |")
print("|---|---|---|---|---|---|")
clean = 0
for seed in range(20261213, 20261219):
    d = json.load(open(f"results/blind/seed{seed}_drawn_scan/blind.json"))
    s = d["statistics"][POLICY]
    missed = [name for name, bad in (("below the trapezoid", s["points_below_trapezoid"] > 0),
                                     ("fraction mean", s["fraction_of_best_mean"] < 0.95),
                                     ("fraction min", s["fraction_of_best_min"] < 0.85),
                                     ("critical load", s["critical_load_over_best_cycle_min"] < 0.97)) if bad]
    clean += not missed
    print(f"| {seed} | {s['points_below_trapezoid']} | {s['fraction_of_best_mean']:.3f} | {s['fraction_of_best_min']:.3f} "
          f"({s['points_under_fraction_target']} of {s['points_scored']}) | {s['critical_load_over_best_cycle_min']:.3f} "
          f"({s['k_values_at_critical_load_target']}/25) | {', '.join(missed) or 'none'} |")
print(f"\nevery target on {clean} of 6")
