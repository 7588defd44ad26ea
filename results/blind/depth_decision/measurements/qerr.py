import sys, numpy as np
from mdr_drive_agents.cycles import cycle_action
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.distill import DistillConfig
from mdr_drive_agents.teacher_data import draw_points, labelled_episodes
from mdr_drive_agents.evaluate import load_policy, ACTION_MAP
from mdr_drive_env.gym_envs.spaces import ObservationLayout
field = DriveField.load("results/recipe/teacher_field.npz")
cfg = DistillConfig(teacher_radius=2, quantum_centres=True, periods=8)
# python qerr.py POLICY [SEED]: 1,500 fresh points of SEED (555); SEED "train": the first 1,500 of the
# recipe's own round-0 points (its seed 0 draws 4,096), played as the recipe played them (episode seed 0)
train = len(sys.argv) > 2 and sys.argv[2] == "train"
rng = np.random.default_rng(0 if train else int(sys.argv[2]) if len(sys.argv) > 2 else 555)
pts = draw_points(field, 4096, rng, cfg)[:1500] if train else draw_points(field, 1500, rng, cfg)
drives, v = field.best(pts, radius=2)
obs, sd = labelled_episodes(field, pts, None, cfg, 0 if train else 1, drives=drives)
prev = ObservationLayout.structure["previous_action"]
y = cycle_action(sd, obs[:, prev])
pol = load_policy(sys.argv[1])
a = np.clip(np.asarray(pol(obs)), -1, 1)
pa = ACTION_MAP.to_params_batch(a); py = ACTION_MAP.to_params_batch(y)
vt = np.tile(v, 8)
for name, mask in [("all", vt > -1), ("v<1mm/s", (vt < 1e-3) & (vt > 0)), ("v<3mm/s", (vt < 3e-3) & (vt > 0))]:
    print(name, mask.sum())
    for d, nm in [(1, "xrise"), (3, "zrise"), (4, "phase")]:
        diff = np.rint(np.abs(pa[mask, d] - py[mask, d]) / (1e-5 if d != 4 else 1/200)).astype(int)
        if d == 4: diff = np.minimum(diff, 200 - diff)
        print(f"  {nm}: off0 {np.mean(diff==0):.3f} off1 {np.mean(diff==1):.3f} off>=2 {np.mean(diff>=2):.3f}")
    for d, nm in [(0, "xamp"), (2, "zamp")]:
        e = np.abs(a[mask, d] - np.clip(y[mask, d], -1, 1))
        print(f"  {nm}: median {np.median(e):.4f} p90 {np.quantile(e,0.9):.4f} >0.01 {np.mean(e>0.01):.3f}")
st = ObservationLayout.structure
obs2 = obs.copy()
for key in ("dynamics", "episode_fraction"):
    obs2[:, st[key]] = pol.obs_rms.mean[st[key]]
a = np.clip(np.asarray(pol(obs2)), -1, 1)
pa = ACTION_MAP.to_params_batch(a)
print("dynamics at their mean")
for d, nm in [(1, "xrise"), (3, "zrise"), (4, "phase")]:
    diff = np.rint(np.abs(pa[:, d] - py[:, d]) / (1e-5 if d != 4 else 1/200)).astype(int)
    if d == 4: diff = np.minimum(diff, 200 - diff)
    print(f"  {nm}: off0 {np.mean(diff==0):.3f} off1 {np.mean(diff==1):.3f} off>=2 {np.mean(diff>=2):.3f}")
print(st)
a = np.clip(np.asarray(pol(obs)), -1, 1); pa = ACTION_MAP.to_params_batch(a)
cyc = np.abs(sd[:, 0] - sd[:, 1]).max(axis=1) > 1e-6
print("two-action cycle share", cyc.mean())
for name, mask in [("fixed", ~cyc), ("cycle", cyc)]:
    for d, nm in [(1, "xrise"), (3, "zrise"), (4, "phase")]:
        diff = np.rint(np.abs(pa[mask, d] - py[mask, d]) / (1e-5 if d != 4 else 1/200)).astype(int)
        if d == 4: diff = np.minimum(diff, 200 - diff)
        e = np.abs(a[mask, d] - y[mask, d])
        print(f"  {name} {nm}: off0 {np.mean(diff==0):.3f} off>=2 {np.mean(diff>=2):.3f} med err {np.median(e):.4f}")
