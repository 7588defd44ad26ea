"""Where a step of the student's fit goes: the shipped policy's actor, the recipe's batch, loss and
Adam, on the recipe's torch thread count, timed and profiled (docs/performance.md).

    PYTHONPATH=. python results/recipe/profile_fit_step.py [--steps 300] [--policy DIR] [--config YAML]
        [--bf16] [--fused-adam] [--threads N] [--raw-logits]

A codebook policy (``Discrete`` actions, ``distill.action_codebook``) is timed with its loss, the
cross-entropy of its logits against random labels.

The inputs are random normal observations (the time of a dense step does not depend on the
values); the epoch's data preparation (``distill.fit``'s ``epoch``) is not included. ``--bf16``
and ``--fused-adam`` time the cheaper steps a new build could take (their weights differ from the
recipe's: bfloat16 matrix products under ``torch.autocast``; ``torch.optim.Adam(fused=True)``).
"""

from __future__ import annotations

import argparse
import time

import torch
from stable_baselines3 import PPO
from torch.profiler import ProfilerActivity, profile

from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
from mdr_drive_agents.student import bf16_products, edge_loss, policy_logits, policy_mean, policy_raw_logits


def matmul_flops(layers: list[torch.nn.Linear], batch: int) -> int:
    """Multiply-adds x 2 of one forward and backward pass: every layer's product and weight
    gradient, and every layer's input gradient but the first's (its input needs none)."""
    products = [batch * layer.in_features * layer.out_features for layer in layers]
    return 2 * (2 * sum(products) + sum(products[1:]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=300, help="timed Adam steps (after 30 warm-up steps)")
    ap.add_argument("--policy", default="agents/pretrained/ppo_generalist", help="folder of model.zip")
    ap.add_argument("--config", default=DEFAULT_CONFIG, help="the recipe YAML (batch, loss, threads)")
    ap.add_argument("--bf16", action="store_true", help="bfloat16 matrix products (torch.autocast)")
    ap.add_argument("--fused-adam", action="store_true", help="torch's fused Adam (other weights than the recipe's)")
    ap.add_argument("--threads", type=int, default=None, help="torch threads (default: the recipe's)")
    ap.add_argument("--raw-logits", action="store_true",
                    help="codebook: the cross-entropy of the action net's output itself, not of the normalised "
                         "log-probabilities SB3's Categorical makes of it (one softmax pass fewer; other weights)")
    a = ap.parse_args()
    config = load_recipe(a.config)["distill"]
    threads = a.threads or config.torch_threads
    torch.set_num_threads(threads)
    policy = PPO.load(f"{a.policy}/model.zip", device="cpu").policy
    policy.set_training_mode(True)
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    layers = [m for m in policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)] + [policy.action_net]
    opt = torch.optim.Adam(params, lr=1e-6, fused=True if a.fused_adam else None)
    gen = torch.Generator().manual_seed(0)
    x = torch.randn(config.batch, policy.observation_space.shape[0], generator=gen)
    codebook = hasattr(policy.action_space, "n")  # Discrete: a codebook student
    if codebook:
        y = torch.randint(int(policy.action_space.n), (config.batch,), generator=gen)
    else:
        y = torch.randn(config.batch, policy.action_space.shape[0], generator=gen).clamp(-1, 1)

    def step():
        with bf16_products(a.bf16):
            if codebook and a.raw_logits:
                loss = torch.nn.functional.cross_entropy(policy_raw_logits(policy, x), y)
            elif codebook:
                loss = torch.nn.functional.cross_entropy(policy_logits(policy, x), y)
            else:
                loss = edge_loss(policy_mean(policy, x), y, config.huber_delta)
        opt.zero_grad()
        loss.backward()
        opt.step()

    for _ in range(30):
        step()
    start = time.perf_counter()
    for _ in range(a.steps):
        step()
    seconds = (time.perf_counter() - start) / a.steps
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(a.steps):
            step()
    by_op = {e.key: e.self_cpu_time_total for e in prof.key_averages()}
    total = sum(by_op.values())
    products = sum(by_op.get(op, 0.0) for op in ("aten::mm", "aten::addmm", "aten::linear"))
    flops = matmul_flops(layers, config.batch)
    print(f"actor {[layer.out_features for layer in layers]}, batch {config.batch}, {threads} torch threads"
          f"{', bfloat16 products' if a.bf16 else ''}{', fused Adam' if a.fused_adam else ''}"
          f"{', raw logits' if a.raw_logits else ''}")
    print(f"{1 / seconds:.1f} Adam steps/s ({seconds * 1e3:.2f} ms a step), {flops / 1e9:.2f} GFLOP of matrix products a step")
    print(f"profiled: matrix products (aten::mm, aten::addmm, aten::linear) {products / total:.1%} of the step's self CPU time, "
          f"at {flops / (products / a.steps * 1e-6) / 1e9:.0f} GFLOP/s")
    for key, value in sorted(by_op.items(), key=lambda kv: -kv[1])[:6]:
        print(f"  {key}: {value / total:.1%}")


if __name__ == "__main__":
    main()
