"""Two variants of a codebook fit step that might keep the weights bit for bit, timed against SB3's own
path: the hand-normalised logits (SB3's Categorical's own operation, now ``student.policy_logits``, the
recipe's) and Adam's foreach path; ``raw``, the raw-logit loss, changes the weights.

    python results/recipe/fit_step_bit_identical.py 400 [ROUNDS]    # runs/cbbr/policy: results/blind/codebook_band_decision/rebuild_check/cbbr_policy
"""
import copy, sys, time
import numpy as np, torch
from stable_baselines3 import PPO
sys.path.insert(0, ".")
from mdr_drive_agents.student import policy_logits, policy_raw_logits, adam_fit

torch.set_num_threads(2)
model = PPO.load("runs/cbbr/policy/model.zip", device="cpu")
base = model.policy
rng = np.random.default_rng(0)
n = 20000
x = torch.as_tensor(rng.normal(size=(n, 14)), dtype=torch.float32)
y = torch.as_tensor(rng.integers(0, 657, n))

def sb3_logits(policy, obs):
    return policy.get_distribution(obs).distribution.logits

def run(fn, steps, fused=False):
    policy = copy.deepcopy(base)
    policy.set_training_mode(True)
    t = time.perf_counter()
    loss = adam_fit([*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()],
                    lambda: (n, lambda idx: torch.nn.functional.cross_entropy(fn(policy, x[idx]), y[idx])),
                    steps, 256, 1e-3, 1, "p", progress=False, fused=fused)
    dt = time.perf_counter() - t
    return policy, loss, steps / dt

steps = int(sys.argv[1]) if len(sys.argv) > 1 else 400
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 1
variants = (("sb3", sb3_logits), ("hand", policy_logits), ("raw", policy_raw_logits)) + (("sb3", sb3_logits), ("hand", policy_logits)) * rounds
for name, fn in variants:
    p, loss, rate = run(fn, steps)
    if name == "sb3":
        ref = p
    same = all(torch.equal(a, b) for a, b in zip(ref.state_dict().values(), p.state_dict().values()))
    print(f"{name}: {rate:.1f} steps/s, loss {loss:.8f}, same weights as sb3: {same}", flush=True)


def run_adam(steps, **adam_kw):
    policy = copy.deepcopy(base); policy.set_training_mode(True)
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    opt = torch.optim.Adam(params, lr=1e-3, **adam_kw)
    sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: max(1.0 - s / steps, 0.0))
    gen = torch.Generator().manual_seed(1)
    perm = torch.randperm(n, generator=gen)
    t = time.perf_counter(); tf = 0.0
    for i in range(steps):
        idx = perm[(i * 256) % (n - 256):(i * 256) % (n - 256) + 256]
        t0 = time.perf_counter()
        loss = torch.nn.functional.cross_entropy(sb3_logits(policy, x[idx]), y[idx])
        opt.zero_grad(); loss.backward()
        t1 = time.perf_counter()
        opt.step(); sched.step()
        tf += time.perf_counter() - t1
        float(loss.detach())
    dt = time.perf_counter() - t
    return policy, steps / dt, tf / steps * 1e3

for name, kw in (("loop", {}), ("foreach", {"foreach": True}), ("loop", {}), ("foreach", {"foreach": True})):
    p, rate, adam_ms = run_adam(steps, **kw)
    if name == "loop": ref = p
    same = all(torch.equal(a, b) for a, b in zip(ref.state_dict().values(), p.state_dict().values()))
    print(f"{name}: {rate:.1f} steps/s, adam+sched {adam_ms:.2f} ms/step, same as loop: {same}", flush=True)
