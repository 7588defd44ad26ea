"""S3's points under 0.85 of the best on its report seeds, replayed in the env at TIME_QUANTUM."""
import sys, json, glob, numpy as np
sys.path.insert(0, "/tmp/lm"); import finepatch  # noqa
from mdr_drive_agents.evaluate import load_policy, policy_velocity
pol = load_policy("agents/pretrained/ppo_generalist")
rows = []
for path in sorted(glob.glob("results/blind/seed202611[5-8]*_drawn_scan/blind.json")):
    d = json.load(open(path))
    if "agents/pretrained/ppo_generalist" not in d["learned"]: continue
    best = np.array([b["velocity"] if b["velocity"] is not None else np.nan for b in d["best"]])
    lv = np.array(d["learned"]["agents/pretrained/ppo_generalist"], dtype=float)
    for i, (p, b, l) in enumerate(zip(d["points"], best, lv)):
        if b >= 2e-3 and l / b < 0.9:
            rows.append((d["seed"], p, b, l))
pts = [tuple(r[1]) for r in rows]
v = policy_velocity(pol, pts)
print(f"time quantum {finepatch.q}: S3 at its report points under 0.9 of the best (10 us references)")
print("| seed | k | load kg | best mm/s | S3 stored (10 us) | S3 now | fraction now |")
for r, x in zip(rows, v):
    print(f"| {r[0]} | {r[1][0]:.4f} | {r[1][1]:.4f} | {1e3*r[2]:.2f} | {1e3*r[3]:.2f} ({r[3]/r[2]:.3f}) | {1e3*x:.2f} | {x/r[2]:.3f} |")
