"""Fine-tune the shipped student with a loss variant; measure held-out quantum accuracy."""
import sys, time, numpy as np, torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize
import mdr_drive_agents.distill as D
import mdr_drive_agents.teacher_data as T
from mdr_drive_agents.cycles import cycle_action
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import ACTION_MAP
from mdr_drive_agents.vec_env import BatchedVecEnv
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_env.gym_envs.spaces import ObservationLayout
torch.set_num_threads(2)
variant, steps, lr = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
src = "agents/pretrained/ppo_generalist"
field = DriveField.load("results/recipe/teacher_field.npz")
cfg = load_recipe(DEFAULT_CONFIG)["distill"]
import os
cache = "/tmp/qa/data0.npz"
if os.path.exists(cache):
    z = np.load(cache); obs, sd = z["obs"], z["sd"]
else:
    t = time.time()
    rng = np.random.default_rng(0)
    pts = T.draw_points(field, cfg.points, rng, cfg)
    drives, _ = field.best(pts, radius=cfg.teacher_radius)
    extra, ed = T.jump_points(field, pts, drives, cfg)
    obs, sd = T.labelled_episodes(field, pts + extra, None, cfg, 0, drives=np.concatenate([drives, ed]))
    np.savez(cache, obs=obs, sd=sd); print("data", time.time() - t, flush=True)
hz = "/tmp/qa/held.npz"
if os.path.exists(hz):
    z = np.load(hz); hobs, hsd, hv = z["obs"], z["sd"], z["v"]
else:
    rng = np.random.default_rng(555)
    pts = T.draw_points(field, 1500, rng, cfg)
    drives, hv = field.best(pts, radius=2)
    hobs, hsd = T.labelled_episodes(field, pts, None, cfg, 1, drives=drives)
    np.savez(hz, obs=hobs, sd=hsd, v=hv)
model = PPO.load(f"{src}/model.zip", device="cpu")
venv = VecNormalize.load(f"{src}/vecnormalize.pkl", BatchedVecEnv(2))
venv.training = False
st = D.Student(model, venv)
prev = ObservationLayout.structure["previous_action"]
def acc(student):
    a = np.clip(student.act(hobs), -1, 1); y = cycle_action(hsd, hobs[:, prev])
    pa, py = ACTION_MAP.to_params_batch(a), ACTION_MAP.to_params_batch(y)
    out = []
    for d in (1, 3, 4):
        diff = np.rint(np.abs(pa[:, d] - py[:, d]) / (1e-5 if d != 4 else 1/200)).astype(int)
        if d == 4: diff = np.minimum(diff, 200 - diff)
        out.append(np.mean(diff == 0))
    e = np.abs(a[:, [0, 2]] - np.clip(y[:, [0, 2]], -1, 1))
    return " ".join(f"{x:.3f}" for x in out) + f" amp med {np.median(e):.4f}"
print("before", acc(st), flush=True)
if variant.startswith("huber"):
    cfg = D.DistillConfig(**{**cfg.__dict__, "huber_delta": float(variant[5:])})
elif variant.startswith("cauchy"):
    c = float(variant[6:])
    def cauchy(mean, target, huber_delta=0.0):
        upper, lower = target >= D.EDGE, target <= -D.EDGE
        clipped = torch.where(upper, torch.clamp(mean, max=1.0), torch.where(lower, torch.clamp(mean, min=-1.0), mean))
        e = clipped - torch.clamp(target, -1, 1)
        return torch.mean(c * c * torch.log1p((e / c) ** 2))
    D.edge_loss = cauchy
t = time.time()
loss = D.fit(st, obs, sd, steps, cfg, 7, progress=False, learning_rate=lr) if steps else 0.0
print("after", variant, steps, lr, acc(st), "loss", loss, "time", round(time.time() - t), flush=True)
# closed loop on held-out points: velocity vs teacher
rng = np.random.default_rng(556)
pts = T.draw_points(field, 1024, rng, cfg)
_, vt = field.best(pts, radius=2)
v = D.student_velocity(st, pts)
m = vt >= 2e-3
f = v[m] / vt[m]
print("closed loop: mean frac", f.mean().round(4), "under 0.85", int((f < 0.85).sum()), "under 0.95", int((f < 0.95).sum()), "short >0.1mm/s&10%", int((v < vt - np.maximum(0.1*np.abs(vt), 1e-4)).sum()), flush=True)
if len(sys.argv) > 4:
    D.save_student(st, sys.argv[4], {"variant": variant})
