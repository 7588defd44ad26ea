"""Label map near stall: the teacher's drive family and each policy's stalls on a fine (k, load) grid."""
import sys; sys.path.insert(0, "/tmp/lm"); import finepatch
import sys, numpy as np
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.teacher_data import teacher_drives, drive_difference, stall_fractions
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.evaluate import load_policy, policy_velocity
field = DriveField.load("results/recipe/teacher_field.npz")
cfg = load_recipe(DEFAULT_CONFIG)["distill"]
k0, k1, nk = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
f0, f1, nf = float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
pols = sys.argv[7:]
ks = np.linspace(k0, k1, nk)
stall = np.interp(ks, field.ks, stall_fractions(field))
crit = np.interp(ks, field.ks, field.trapezoid_critical)
fr = np.linspace(f0, f1, nf)  # fractions of the teacher's stall load
pts = [(k, f * s * c) for k, s, c in zip(ks, stall, crit) for f in fr]
d, v = teacher_drives(field, pts, cfg)
protos = []
lab = np.empty(len(d), int)
for n, x in enumerate(d):
    for m, p in enumerate(protos):
        if drive_difference(x[None], p[None])[0] <= 0.3:
            lab[n] = m; break
    else:
        protos.append(x); lab[n] = len(protos) - 1
lab = lab.reshape(nk, nf); v = v.reshape(nk, nf)
pv = [policy_velocity(load_policy(p), pts).reshape(nk, nf) for p in pols]
sym = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789"
print(f"rows k, columns load {f0}-{f1} of the teacher's stall load; letter: the teacher's drive family "
      f"(drives within 0.3 action units of a first one); '.': teacher stalls; after '|', per policy: '#' stalls where the teacher moves")
for i, k in enumerate(ks):
    row = "".join("." if v[i, j] <= 0 else sym[lab[i, j] % len(sym)] for j in range(nf))
    marks = ["".join("#" if (q[i, j] <= 0 and v[i, j] > 0) else ("-" if v[i, j] > 0 else " ") for j in range(nf)) for q in pv]
    print(f"{k:.5f} {row} | " + " | ".join(marks))
print("families:", len(protos))
