"""S3 (10 us) and Q1 (5 us) at Q1's report points, against the same stored 5 us searches."""
import json, numpy as np
from mdr_drive_agents.evaluate import load_policy, policy_velocity
s3 = load_policy("runs/s3_policy")
print("| seed | points (best >= 2 mm/s) | Q1: mean / min / under 0.85 | S3: mean / min / under 0.85 |")
print("|---|---|---|---|")
for seed in range(20261207, 20261213):
    d = json.load(open(f"results/blind/seed{seed}_drawn_scan/blind.json"))
    pts = [tuple(p) for p in d["points"]]
    best = np.array([b["velocity"] if b["velocity"] is not None else np.nan for b in d["best"]])
    q1 = np.array(d["learned"]["agents/pretrained/ppo_generalist"], dtype=float)
    v3 = policy_velocity(s3, pts)
    m = best >= 2e-3
    row = []
    for v in (q1, v3):
        f = v[m] / best[m]
        row.append(f"{np.nanmean(f):.3f} / {np.nanmin(f):.3f} / {int(np.sum(f < 0.85))}")
    print(f"| {seed} | {int(m.sum())} | {row[0]} | {row[1]} |")
