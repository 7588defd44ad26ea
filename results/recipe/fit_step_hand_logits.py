"""Is a hand-normalised logit path bit-identical to SB3's Categorical logits in a codebook fit, and faster?
(python results/recipe/fit_step_hand_logits.py 400; runs/cbbr/policy: results/blind/codebook_band_decision/rebuild_check/cbbr_policy)"""
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

def normalised(policy, obs):
    raw = policy_raw_logits(policy, obs)
    return raw - raw.logsumexp(dim=-1, keepdim=True)

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
for name, fn in (("sb3", policy_logits), ("hand", normalised), ("raw", policy_raw_logits), ("sb3", policy_logits), ("hand", normalised)):
    p, loss, rate = run(fn, steps)
    if name == "sb3":
        ref = p
    same = all(torch.equal(a, b) for a, b in zip(ref.state_dict().values(), p.state_dict().values()))
    print(f"{name}: {rate:.1f} steps/s, loss {loss:.8f}, same weights as sb3: {same}", flush=True)
