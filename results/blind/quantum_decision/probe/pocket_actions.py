import sys, numpy as np
import sys; sys.path.insert(0, "/tmp/lm"); import finepatch
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.teacher_data import teacher_drives, stall_fractions, rollout
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.evaluate import load_policy, open_loop_velocity
from mdr_drive_agents.cycles import align_phase
field = DriveField.load("results/recipe/teacher_field.npz")
cfg = load_recipe(DEFAULT_CONFIG)["distill"]
k = float(sys.argv[1]); fr = [float(x) for x in sys.argv[2].split(",")]; pol = load_policy(sys.argv[3])
stall = float(np.interp(k, field.ks, stall_fractions(field))); crit = float(np.interp(k, field.ks, field.trapezoid_critical))
pts = [(k, f * stall * crit) for f in fr]
d, v = teacher_drives(field, pts, cfg)
from mdr_drive_agents.evaluate import policy_rollout
disp, actions, _ = policy_rollout(pol, pts)
last2 = np.stack([actions[-1], actions[-2]], 1)
np.set_printoptions(precision=3, suppress=True, linewidth=160)
for i, f in enumerate(fr):
    s = align_phase(last2[i], d[i])
    vs = open_loop_velocity([pts[i]], s[None])[0]
    print(f"f={f:.3f} teacher {1e3*v[i]:.2f} mm/s, student closed loop {disp[20:, i].mean()*1e3/2e-3:.2f}, student cycle open loop {1e3*vs:.2f}")
    print("   teacher", d[i].ravel()); print("   student", s.ravel()); print("   diff   ", (s - d[i]).ravel())
    # sensitivity: move from teacher toward student
    for t in (0.25, 0.5, 0.75):
        print(f"   t={t}: {1e3*open_loop_velocity([pts[i]], (d[i] + t*(s-d[i]))[None])[0]:.2f}", end="")
    print()
