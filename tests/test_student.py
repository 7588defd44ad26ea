"""The student's Adam fit (``agents/student.py``)."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from mdr_drive_agents import student  # noqa: E402


def test_zero_subnormal_moments_zeroes_only_the_subnormal_entries():
    param = torch.nn.Parameter(torch.zeros(6))
    opt = torch.optim.Adam([param])
    tiny = torch.finfo(torch.float32).tiny
    values = torch.tensor([1.0, -2e-3, 0.0, tiny, tiny / 2, -tiny / 1024])
    opt.state[param] = {"step": torch.tensor(3.0), "exp_avg": values.clone(), "exp_avg_sq": values.abs().clone()}
    assert student.zero_subnormal_moments(opt) == 4
    expected = torch.tensor([1.0, -2e-3, 0.0, tiny, 0.0, 0.0])
    assert torch.equal(opt.state[param]["exp_avg"], expected)
    assert torch.equal(opt.state[param]["exp_avg_sq"], expected.abs())


def _fit(monkeypatch, sweep_steps: int) -> tuple[torch.Tensor, int]:
    """A linear fit whose second half of inputs is zero after the first epoch: those weights'
    gradients stop, and their first moments decay into the subnormal range and stick there."""
    monkeypatch.setattr(student, "SUBNORMAL_SWEEP_STEPS", sweep_steps)
    zeroed = []
    sweep = student.zero_subnormal_moments
    monkeypatch.setattr(student, "zero_subnormal_moments", lambda opt: zeroed.append(sweep(opt)) or zeroed[-1])
    torch.manual_seed(0)
    rng = np.random.default_rng(0)
    x = torch.tensor(rng.normal(size=(64, 40)), dtype=torch.float32)
    y = torch.tensor(rng.normal(size=(64, 1)), dtype=torch.float32)
    layer = torch.nn.Linear(40, 1)
    epochs = []

    def epoch():
        inputs = x.clone()
        if epochs:
            inputs[:, 20:] = 0.0
        epochs.append(1)
        return len(x), lambda idx: torch.mean((layer(inputs[idx]) - y[idx]) ** 2)

    student.adam_fit(layer.parameters(), epoch, steps=1600, batch=16, learning_rate=1e-2, seed=0, desc="test",
                     progress=False)
    return torch.cat([layer.weight.detach().ravel(), layer.bias.detach()]), sum(zeroed)


def test_zeroing_subnormal_moments_leaves_the_fit_bit_for_bit(monkeypatch):
    swept, zeroed = _fit(monkeypatch, 16)
    kept, none = _fit(monkeypatch, 10**9)
    assert none == 0
    assert zeroed > 0  # the sweep had subnormal moments to zero
    assert torch.equal(swept, kept)
