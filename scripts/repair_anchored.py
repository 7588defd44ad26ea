"""Exploratory ablation (not shipped, retired after its commit): the repair of scripts/repair_student.py (git show d1936ae:scripts/repair_student.py), but the rest of the network is held to its own outputs (anchors: the student's closed-loop observations at ARG6 random points, 16 periods each, labelled with its own mean action; those within 0.01 of k and 3 % of the load of a repaired point dropped), a function-space regulariser in place of the teacher's episodes.

    python scripts/repair_anchored.py OUT ROUNDS PROBES STEPS LEARNING_RATE ANCHOR_POINTS
"""
import sys, time, shutil
import numpy as np
from concurrent.futures import ProcessPoolExecutor
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize, VecMonitor
from mdr_drive_agents.drive_field import DriveField, cycle_action
from mdr_drive_agents.distill import Student, draw_points, rollout, policy_mean, edge_loss, perturb_previous_actions
from mdr_drive_agents.evaluate import open_loop_velocity, trapezoid_action, steady_velocity_of
from mdr_drive_agents.baselines import best_cma_run
from mdr_drive_agents.blind import below_trapezoid
from mdr_drive_agents.recipe import load_recipe, DEFAULT_CONFIG
from mdr_drive_agents.vec_env import BatchedVecEnv
from mdr_drive_env.gym_envs.spaces import ObservationLayout

out, rounds, probes, steps, lr, anchors_n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
torch.set_num_threads(2)
rec = load_recipe(DEFAULT_CONFIG); cfg = rec["distill"]
field = DriveField.load("results/recipe/teacher_field.npz")
src = "agents/pretrained/ppo_generalist"
model = PPO.load(f"{src}/model.zip", device="cpu")
venv = VecNormalize.load(f"{src}/vecnormalize.pkl", VecMonitor(BatchedVecEnv(16, seed=0, **rec["env_kwargs"])))
venv.training = False
model.set_env(venv)
student = Student(model, venv)
policy = model.policy
prev_slice = ObservationLayout.structure["previous_action"]
rng = np.random.default_rng(626262)
t0 = time.time()
apts = draw_points(field, anchors_n, rng, cfg)
aobs, _, _ = rollout(apts, np.zeros((len(apts), 2, 5)), student.act, 16)
apoint = np.tile(np.array([(p[0], p[1]) for p in apts]), (16, 1))
with torch.no_grad():
    ax = torch.as_tensor(venv.normalize_obs(aobs.astype(np.float64)), dtype=torch.float32)
    ay = torch.cat([policy_mean(policy, ax[i:i + 8192]) for i in range(0, len(ax), 8192)])
print(f"anchors {len(ax)} ({time.time()-t0:.0f}s)", flush=True)

def job(a):
    p, c, i = a
    r = best_cma_run(p[0], p[1], [c], 160, popsize=16, sigma0=0.1, cycle=2, seed=i)
    return np.asarray(r.action), r.velocity

rep_obs, rep_drv, rep_pts = [], [], []
crit_of = lambda k: float(np.interp(k, field.ks, field.trapezoid_critical))
params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
for rnd in range(rounds):
    t1 = time.time()
    pts = draw_points(field, probes, rng, cfg)
    acts = []
    def act(o):
        a = student.act(o); acts.append(np.asarray(a).reshape(len(pts), 5)); return a
    _, _, disp = rollout(pts, np.zeros((len(pts), 2, 5)), act, 30)
    cyc = np.stack([acts[-2], acts[-1]], axis=1).astype(np.float64)
    vs = steady_velocity_of(disp)
    vtrap = open_loop_velocity(pts, trapezoid_action())
    sus = np.flatnonzero((vs < 3e-3) | (vs < vtrap + 0.5e-3))
    vt = np.full(len(pts), -np.inf)
    vt[sus] = field.best([pts[i] for i in sus], radius=cfg.teacher_radius)[1]
    below, _, _ = below_trapezoid(vtrap, vs)
    short = vs < vt - np.maximum(cfg.hole_shortfall * np.abs(vt), 1e-3)
    fail = np.flatnonzero(below | short)
    with ProcessPoolExecutor(2) as ex:
        found = list(ex.map(job, [(pts[i], cyc[i], int(i) + 100000 * rnd) for i in fail]))
    C = np.array([f[0] for f in found]).reshape(-1, 2, 5); vc = np.array([f[1] for f in found])
    keep = vc > np.maximum(vs[fail], vtrap[fail])
    print(f"round {rnd}: below {below.sum()} short {short.sum()} fail {len(fail)} improved {keep.sum()} ({time.time()-t1:.0f}s)", flush=True)
    fp = [pts[i] for i in fail[keep]]
    o, d, _ = rollout(fp, C[keep], None, cfg.periods, seed=rnd)
    rep_obs.append(o); rep_drv.append(d); rep_pts += fp
    RO = np.concatenate(rep_obs); RD = np.concatenate(rep_drv)
    # drop anchors near repaired points
    rp = np.array([(p[0], p[1] / crit_of(p[0])) for p in rep_pts])
    a_s = np.array([apoint[:, 1] / np.array([crit_of(k) for k in apoint[:len(apts), 0]]).repeat(1)[np.arange(len(apoint)) % len(apts)]])[0]
    near = np.zeros(len(apoint), bool)
    for k, s in rp:
        near |= (np.abs(apoint[:, 0] - k) < 0.01) & (np.abs(a_s - s) < 0.03)
    idx_anchor = np.flatnonzero(~near)
    opt = torch.optim.Adam(params, lr=lr)
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: max(1.0 - s / steps, 0.0))
    g = np.random.default_rng(rnd)
    policy.set_training_mode(True)
    tot = [0.0, 0.0]
    for step in range(steps):
        if step % 200 == 0:
            x = perturb_previous_actions(RO, RD, g, cfg.perturbed_share, prev_slice)
            ry = torch.as_tensor(cycle_action(RD, x[:, prev_slice]), dtype=torch.float32)
            rx = torch.as_tensor(venv.normalize_obs(x.astype(np.float64)), dtype=torch.float32)
        ai = torch.as_tensor(g.choice(idx_anchor, 256))
        ri = torch.as_tensor(g.integers(0, len(rx), 64))
        la = torch.mean((policy_mean(policy, ax[ai]) - ay[ai]) ** 2)
        lr_ = edge_loss(policy_mean(policy, rx[ri]), ry[ri], cfg.huber_delta)
        loss = la + lr_
        opt.zero_grad(); loss.backward(); opt.step(); sched.step()
        tot[0] += float(la); tot[1] += float(lr_)
    policy.set_training_mode(False)
    print(f"  fit: anchors dropped {near.sum()}, anchor loss {tot[0]/steps:.2e}, repair loss {tot[1]/steps:.2e}; total {time.time()-t0:.0f}s", flush=True)
shutil.copytree(src, out, dirs_exist_ok=True)
model.save(f"{out}/model.zip"); venv.save(f"{out}/vecnormalize.pkl")
print("saved", out, f"{time.time()-t0:.0f}s", flush=True)
