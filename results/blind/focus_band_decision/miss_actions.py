"""Q1's record misses: teacher label vs Q1's played cycle, velocity along the line between (5 us env).

python results/blind/focus_band_decision/miss_actions.py runs/q1/policy
(runs/q1/policy: Q1, the same weights as `git show 263ed8d:agents/pretrained/ppo_generalist/FILE`)."""
import csv
import sys

import numpy as np

from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import ACTION_MAP, load_policy, open_loop_velocity, policy_rollout
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.teacher_data import teacher_drives

field = DriveField.load("results/recipe/teacher_field.npz")
cfg = load_recipe(DEFAULT_CONFIG)["distill"]
pol = load_policy(sys.argv[1])
pts = [(0.117, 0.0086), (0.183, 0.1964), (0.161, 0.2898), (0.239, 0.1355), (0.239, 0.1516)]
full = []
for s in range(20261207, 20261213):
    for r in csv.DictReader(open(f"results/blind/seed{s}_drawn_scan/points.csv")):
        full.append((float(r['k']), float(r['cargo_mass_kg']), float(r['best_m_s'])))
P = []
for k, m in pts:
    j = min(range(len(full)), key=lambda i: abs(full[i][0]-k)+abs(full[i][1]-m)); P.append(full[j])
points = [(p[0], p[1]) for p in P]
d, v = teacher_drives(field, points, cfg)
d = ACTION_MAP.quantum_centre(d)
disp, actions, _ = policy_rollout(pol, points)
last2 = np.stack([actions[-1], actions[-2]], 1)
np.set_printoptions(precision=3, suppress=True, linewidth=160)
for i, p in enumerate(P):
    s = align_phase(last2[i], d[i])
    v10 = open_loop_velocity([points[i]], d[i][None])[0]
    v5 = open_loop_velocity([points[i]], d[i][None], time_quantum=5e-6)[0]
    vs = open_loop_velocity([points[i]], s[None], time_quantum=5e-6)[0]
    print(f"k={p[0]:.4f} m={p[1]:.4f} best {1e3*p[2]:.2f}: teacher 10us {1e3*v10:.2f} 5us {1e3*v5:.2f}; student cl {disp[20:, i].mean()*1e3/2e-3:.2f} ol {1e3*vs:.2f}")
    print("   teacher", d[i].ravel()); print("   diff   ", (s - d[i]).ravel())
    print("   line:", " ".join(f"{t}:{1e3*open_loop_velocity([points[i]], (d[i] + t*(s-d[i]))[None], time_quantum=5e-6)[0]:.2f}" for t in (0.1,0.25, 0.5, 0.75,0.9)))
