"""The student network: a plain SB3 PPO ``MlpPolicy`` in a ``VecNormalize``, and the supervised fit
of its actions (Adam; a loss that lets the output pass the action box's edge where the target is on
it, or a cross-entropy over a table of actions).

What it is fitted to, and how the teacher's episodes are gathered: ``mdr_drive_agents.student.distill``
(the drive-field teacher) and ``mdr_drive_agents.student.estimator`` (the sensor policy's estimator).
At play time nothing but the network acts: ``PPO.load`` + ``VecNormalize.load`` + ``model.predict``
on the files ``save_student`` writes (``mdr_drive_agents.policy``).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..policy import Policy, save_policy
from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import TIME_QUANTUM

#: Teacher actions this close to the box's edge count as on it (the fit lets the output pass it).
EDGE = 0.999


def policy_mean(policy, obs):
    """The Gaussian mean action of an SB3 PPO policy on (normalised) observations, as a torch tensor
    (SB3 clips it to the box when acting)."""
    return policy.get_distribution(obs).distribution.mean


def policy_logits(policy, obs):
    """The action logits (log-probabilities) of an SB3 PPO policy over a ``Discrete`` action space on
    (normalised) observations, as a torch tensor: SB3's ``Categorical`` normalisation of the action
    net's output (its log-sum-exp subtracted, torch's own operation), without building the distribution
    and checking its arguments: the same tensor and gradients bit for bit (tested), a fit step a few
    per cent faster."""
    raw = policy_raw_logits(policy, obs)
    return raw - raw.logsumexp(dim=-1, keepdim=True)


def policy_raw_logits(policy, obs):
    """The action net's raw output of an SB3 PPO policy over a ``Discrete`` action space on
    (normalised) observations: :func:`policy_logits` before SB3's Categorical subtracts their
    log-sum-exp. A cross-entropy gives the same loss on either (up to rounding) at about half the cost
    of a codebook fit step, whose softmax over hundreds of actions is otherwise taken twice."""
    return policy.action_net(policy.mlp_extractor.forward_actor(policy.extract_features(obs, policy.pi_features_extractor)))


def edge_loss(mean, target, huber_delta: float = 0.0):
    """Squared error, except beyond the box's edge where the target is on it (SB3 clips there).

    With ``huber_delta`` > 0, the Huber loss instead (squared within ``huber_delta`` action units,
    linear beyond; scaled by ``2 / huber_delta`` so that it agrees with the squared error near zero):
    where neighbouring samples are labelled with different drives, a squared error is minimised by
    their mean, a blend that may drive nowhere; a loss linear in large errors by their median, one
    of the drives."""
    import torch

    upper, lower = target >= EDGE, target <= -EDGE
    clipped = torch.where(upper, torch.clamp(mean, max=1.0), torch.where(lower, torch.clamp(mean, min=-1.0), mean))
    target = torch.clamp(target, -1.0, 1.0)
    if huber_delta > 0.0:
        return 2.0 * torch.nn.functional.huber_loss(clipped, target, delta=huber_delta)
    return torch.mean((clipped - target) ** 2)


@dataclass
class Student:
    """The PPO model being distilled and its VecNormalize (observation statistics fixed after round 0)."""

    model: object
    venv: object
    history: list = field(default_factory=list)
    #: The z phase at action -1 of the env it acts in (``MDRDrive-v0``'s ``z_phase_origin``).
    z_phase_origin: float = 0.0
    #: The time quantum (s) of that env's rises and z phase (``MDRDrive-v0``'s ``time_quantum``).
    time_quantum: float = TIME_QUANTUM
    #: The (N, 5) Box actions a codebook student picks among (the env's ``action_codebook``), or None.
    codebook: np.ndarray | None = None
    #: The drive it acts on (the drive keywords of its env).
    drive: DriveDescription = PAPER_DRIVE

    @property
    def policy(self) -> Policy:
        """The network as a drive (``mdr_drive_agents.policy.Policy``), normalised with the training
        env's statistics as they stand."""
        return Policy(self.model, self.venv.normalize_obs, self.codebook,
                      {"env_kwargs": {**self.drive.env_kwargs, "z_phase_origin": self.z_phase_origin,
                                      "time_quantum": self.time_quantum}})

    def act(self, obs: np.ndarray) -> np.ndarray:
        """The Box actions (n, 5) the network plays at observations ``obs`` (n, d): its mean action, or
        the codebook row of its most likely index (``Policy.act``)."""
        return self.policy.act(obs)

    def codebook_index(self, actions: np.ndarray) -> np.ndarray:
        """The index of each action (n, 5) in the codebook (exact rows); ``ValueError`` for one not in it."""
        index = {row.tobytes(): i for i, row in enumerate(self.codebook)}
        rows = np.ascontiguousarray(actions, dtype=np.float64)
        try:
            return np.array([index[row.tobytes()] for row in rows], dtype=np.int64)
        except KeyError:
            raise ValueError("a teacher action is not a row of the action codebook (labels must be the grid's "
                             "quantum-centred actions)") from None


def make_student(net_arch, activation: str, log_std: float, seed: int, env_kwargs: dict,
                 hyperparameters: dict) -> Student:
    """An untrained PPO MlpPolicy (policy layers ``net_arch``, ``activation`` "relu" or "tanh", log
    standard deviation ``log_std``; the value network keeps SB3's 64, 64) over the batched training
    env in a VecNormalize."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from ..vec_env import BatchedVecEnv

    hyper = dict(hyperparameters)
    n_envs = int(hyper.pop("n_envs", 16))
    venv = VecNormalize(VecMonitor(BatchedVecEnv(n_envs, seed=seed, **env_kwargs)), norm_obs=True, norm_reward=True,
                        gamma=hyper.get("gamma", 0.99))
    activation_fn = {"relu": torch.nn.ReLU, "tanh": torch.nn.Tanh}[activation]
    policy_kwargs = {"net_arch": {"pi": list(net_arch), "vf": [64, 64]}, "activation_fn": activation_fn,
                     "log_std_init": log_std}
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", policy_kwargs=policy_kwargs, **hyper)
    return Student(model, venv, z_phase_origin=float(env_kwargs.get("z_phase_origin", 0.0)),
                   time_quantum=float(env_kwargs.get("time_quantum", TIME_QUANTUM)),
                   codebook=venv.get_attr("action_codebook")[0],
                   drive=DriveDescription.from_env_kwargs(env_kwargs))


def bf16_products(on: bool):
    """A context in which torch's matrix products run in bfloat16 (``torch.autocast``; the weights and
    the optimiser stay float32), or, with ``on`` false, one that changes nothing."""
    import torch

    return torch.autocast("cpu", dtype=torch.bfloat16) if on else contextlib.nullcontext()


@contextlib.contextmanager
def flushed_denormals(on: bool):
    """A context in which torch flushes denormal floats to zero (``torch.set_flush_denormal``; off
    again on leaving it), or, with ``on`` false, one that changes nothing."""
    import torch

    if not on:
        yield
        return
    torch.set_flush_denormal(True)
    try:
        yield
    finally:
        torch.set_flush_denormal(False)


def adam_fit(params, epoch, steps: int, batch: int, learning_rate: float, seed: int, desc: str,
             progress: bool = True, bf16_share: float = 0.0, fused: bool = False,
             flush_denormal: bool = False) -> float:
    """``steps`` Adam steps, the learning rate decaying linearly to zero; every epoch ``epoch()``
    gives ``(n, loss_of)``: its sample count and the loss of a minibatch of sample indices, visited
    in a shuffled order. The first ``bf16_share`` of the steps compute the loss under bfloat16
    autocast (matrix products in bfloat16, the weights and the optimiser in float32), the rest in
    float32; ``fused``: torch's fused Adam; ``flush_denormal``: the fit runs with denormal floats
    flushed to zero (``torch.set_flush_denormal``; turned off again after it). Returns the last
    epoch's mean loss."""
    import torch

    with flushed_denormals(flush_denormal):
        opt = torch.optim.Adam(list(params), lr=learning_rate, fused=True if fused else None)
        sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda s: max(1.0 - s / steps, 0.0))
        gen = torch.Generator().manual_seed(seed)
        low_precision_steps = int(round(bf16_share * steps))
        done, total, seen = 0, 0.0, 0
        bar = tqdm(total=steps, desc=desc, unit="step", disable=not progress, mininterval=2.0)
        while done < steps:
            n, loss_of = epoch()
            perm = torch.randperm(n, generator=gen)
            total, seen = 0.0, 0
            for i in range(0, n, batch):
                if done >= steps:
                    break
                idx = perm[i:i + batch]
                with bf16_products(done < low_precision_steps):
                    loss = loss_of(idx)
                opt.zero_grad()
                loss.backward()
                opt.step()
                sched.step()
                total, seen, done = total + float(loss.detach()) * len(idx), seen + len(idx), done + 1
                bar.update()
            bar.set_postfix(loss=f"{total / max(seen, 1):.2e}")
        bar.close()
    return total / max(seen, 1)


def save_student(student: Student, out: str | Path, record: dict) -> None:
    """The student's policy folder in ``out`` (``mdr_drive_agents.policy.save_policy``): its model,
    observation statistics, ``record`` as run.json and, for a codebook student, its table."""
    save_policy(out, student.model, student.venv, record, student.codebook)


__all__ = ["EDGE", "Student", "adam_fit", "bf16_products", "edge_loss", "flushed_denormals", "make_student",
           "policy_logits", "policy_mean", "policy_raw_logits", "save_student"]
