"""Each policy's points under 0.85 of teacher_check.py's reference, or below the trapezoid, on 2,000 points of a
decision seed (as teacher_check.py draws and scores them), worst first, with the trapezoid's, the
teacher's and every policy's velocity (mm/s):

    python results/blind/jump_probe_decision/worst_points.py 4242 agents/pretrained/ppo_generalist runs/j4/policy
"""
import sys

import numpy as np

from mdr_drive_agents.blind import draw_points
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import load_policy, open_loop_velocity, policy_velocity, trapezoid_action


seed, pols = int(sys.argv[1]), sys.argv[2:]
pts, _ = draw_points(2000, seed)
trap = open_loop_velocity(pts, trapezoid_action())
field = DriveField.load("results/blind/steep_line_decision/t1_teacher_field.npz")
crit = np.interp([p[0] for p in pts], field.ks, field.trapezoid_critical)
_, teacher = field.best(pts, radius=3)
vs = {p: policy_velocity(load_policy(p), pts) for p in pols}
ref = np.fmax(np.fmax(trap, teacher), np.max(list(vs.values()), axis=0))
for p, v in vs.items():
    bad = np.flatnonzero(((ref >= 2e-3) & (v < 0.85 * ref)) | (v < trap - 0.05e-3))
    print(p)
    for i in bad[np.argsort(v[bad] / np.maximum(ref[bad], 1e-9))]:
        print(f"  k={pts[i][0]:.4f} m={pts[i][1]:.5f} ({pts[i][1]/crit[i]:.3f} crit) trap={trap[i]*1e3:.2f} teacher={teacher[i]*1e3:.2f} "
              + " ".join(f"{q.split('/')[-2]}={w[i]*1e3:.2f}" for q, w in vs.items()))
