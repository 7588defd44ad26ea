"""The student network (mdr_drive_agents.student.network): its logits, losses and Adam fit."""

from __future__ import annotations


import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.student.distill import DistillConfig

def test_the_raw_logit_cross_entropy_is_the_categoricals_and_needs_a_codebook():
    import torch
    from stable_baselines3 import PPO

    from mdr_drive_agents.student.network import policy_logits, policy_raw_logits

    table = np.random.default_rng(0).uniform(-1.0, 1.0, (7, 5))
    model = PPO("MlpPolicy", gym.make("MDRDrive-v0", action_codebook=table), device="cpu", seed=0)
    x = torch.as_tensor(np.random.default_rng(1).normal(size=(16, model.observation_space.shape[0])), dtype=torch.float32)
    labels = torch.as_tensor(np.arange(16) % 7)
    with torch.no_grad():
        raw, normalised = policy_raw_logits(model.policy, x), policy_logits(model.policy, x)
        assert not torch.allclose(raw, normalised)  # SB3 subtracts the log-sum-exp ...
        torch.testing.assert_close(torch.nn.functional.cross_entropy(raw, labels),  # ... the loss is the same
                                   torch.nn.functional.cross_entropy(normalised, labels))
    with pytest.raises(ValueError, match="raw_logits=true needs action_codebook=true"):
        DistillConfig(raw_logits=True)
    with pytest.raises(ValueError, match="raw_logits='yes' must be true or false"):
        DistillConfig(raw_logits="yes", action_codebook=True, quantum_centres=True)


def test_the_fits_logits_are_sb3s_categorical_logits_bit_for_bit_with_their_gradients():
    import torch
    from stable_baselines3 import PPO

    from mdr_drive_agents.student.network import policy_logits

    table = np.random.default_rng(0).uniform(-1.0, 1.0, (9, 5))
    x = torch.as_tensor(np.random.default_rng(1).normal(size=(32, 14)), dtype=torch.float32)
    labels = torch.as_tensor(np.arange(32) % 9)
    grads = []
    for logits_of in (policy_logits, lambda policy, obs: policy.get_distribution(obs).distribution.logits):
        model = PPO("MlpPolicy", gym.make("MDRDrive-v0", action_codebook=table), device="cpu", seed=0)
        logits = logits_of(model.policy, x)
        torch.nn.functional.cross_entropy(logits, labels).backward()
        grads.append((logits.detach(), [p.grad.clone() for p in model.policy.action_net.parameters()]
                      + [p.grad.clone() for p in model.policy.mlp_extractor.policy_net.parameters()]))
    (ours, our_grads), (sb3, sb3_grads) = grads
    assert torch.equal(ours, sb3)
    assert len(our_grads) == len(sb3_grads) and all(torch.equal(a, b) for a, b in zip(our_grads, sb3_grads))


def test_the_huber_loss_fits_one_of_two_conflicting_drives_where_the_squared_error_blends_them():
    import torch

    from mdr_drive_agents.student.network import edge_loss

    near, far = torch.tensor([[0.02, -0.03]]), torch.tensor([[0.5, -0.8]])
    zero = torch.zeros(1, 2)
    assert float(edge_loss(near, zero, 0.05)) == pytest.approx(float(edge_loss(near, zero)))  # squared within delta
    assert float(edge_loss(far, zero, 0.05)) == pytest.approx(0.05 * ((0.5 - 0.025) + (0.8 - 0.025)))  # linear beyond
    assert float(edge_loss(torch.tensor([[1.3]]), torch.tensor([[1.0]]), 0.05)) == 0.0  # past the box's edge: free
    # one output, three samples labelled with one drive's entry (0.2) and two with another's (0.9)
    labels = torch.tensor([[0.2], [0.2], [0.2], [0.9], [0.9]])
    fitted = {}
    for delta in (0.0, 0.05):
        x = torch.zeros(1, 1, requires_grad=True)
        opt = torch.optim.Adam([x], lr=0.01)
        for _ in range(3000):
            opt.zero_grad()
            edge_loss(x.expand(5, 1), labels, delta).backward()
            opt.step()
        fitted[delta] = float(x.detach())
    assert fitted[0.0] == pytest.approx(0.48, abs=0.01)  # the mean: a blend of the two
    # the median, up to the pull of the outvoted labels (2 x delta each) on the quadratic part (3 x 2 (x - 0.2)):
    assert fitted[0.05] == pytest.approx(0.2 + 2 * 0.05 / 3, abs=0.005)  # within delta of the majority's drive


def test_a_fit_with_flush_denormal_flushes_denormal_floats_only_while_it_runs():
    import torch

    from mdr_drive_agents.student.network import adam_fit

    torch.manual_seed(0)
    net = torch.nn.Linear(3, 1)
    x, y = torch.randn(64, 3), torch.randn(64, 1)
    tiny = []  # a float32 denormal as each step sees it: 0 when flushed

    def loss_of(idx):
        tiny.append(float(torch.tensor([1e-40], dtype=torch.float32) * 1.0))
        return torch.mean((net(x[idx]) - y[idx]) ** 2)

    adam_fit(net.parameters(), lambda: (len(x), loss_of), 4, 32, 1e-2, 0, "test", progress=False,
             flush_denormal=True)
    assert tiny == [0.0] * 4
    assert float(torch.tensor([1e-40], dtype=torch.float32) * 1.0) > 0.0  # turned off again after the fit
    adam_fit(net.parameters(), lambda: (len(x), loss_of), 2, 32, 1e-2, 0, "test", progress=False)
    assert len(tiny) == 6 and all(t > 0.0 for t in tiny[4:])  # the default leaves them alone


def test_a_fit_runs_its_first_steps_in_bfloat16_and_the_rest_in_float32():
    import torch

    from mdr_drive_agents.student.network import adam_fit

    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(3, 32), torch.nn.ReLU(), torch.nn.Linear(32, 1))
    x = torch.randn(512, 3)
    y = (x[:, :1] > 0).float()
    dtypes = []

    def loss_of(idx):
        out = net(x[idx])
        dtypes.append(out.dtype)
        return torch.mean((out.float() - y[idx]) ** 2)

    with torch.no_grad():
        first = float(torch.mean((net(x) - y) ** 2))
    last = adam_fit(net.parameters(), lambda: (len(x), loss_of), 40, 64, 1e-2, 0, "test", progress=False,
                    bf16_share=0.75, fused=True)
    assert dtypes == [torch.bfloat16] * 30 + [torch.float32] * 10
    assert all(p.dtype == torch.float32 for p in net.parameters())  # the weights stay float32
    assert last < first

