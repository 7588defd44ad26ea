"""What a sensor can tell of the hidden k, load and friction: the entries a sensor policy estimates
(``hidden_entries``), an MLP estimator of them (``Estimator``, saved as numbers), its score
(``standardised_error``), and the full-observation policy a sensor policy is measured against
(``sensor_teacher_policy``).

Used by ``mdr_drive_agents.train.sensor`` (the sensor policy's estimates, ``estimator.npz``) and
``mdr_drive_agents.benchmarks.identifiability`` (what each sensor tier can tell).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mdr_drive_env.gym_envs.spaces import ObservationLayout, PrivilegedLayout

from ..policy import Policy
from .network import adam_fit

#: The full observation's entries the sensor observation hides (ObservationLayout.structure names);
#: a teacher on the privileged observation is told ``"friction_ratio"`` (mu1 / mu) too. These are what
#: the slider's motion can tell (k, the load over mu F_ref, the load, mu1 / mu), never mu and mu1
#: apart: position shows forces only as mass times acceleration, and k and mu trade off along
#: mu F_ref(k) = const.
HIDDEN = ("k", "load_over_friction", "load_over_10N")
#: PPO settings of the shipped network: what ``mdr-drive train --resume`` fine-tunes it with (small
#: steps: near an optimal drive the velocity changes steeply with the action).
FINE_TUNE_PPO = {"n_steps": 128, "batch_size": 128, "n_epochs": 10, "gamma": 0.98, "gae_lambda": 0.95,
                 "learning_rate": 3e-5, "clip_range": 0.1, "ent_coef": 0.0, "n_envs": 8}


def teacher_layout(teacher: Policy):
    """The observation layout ``teacher`` was trained on: ``ObservationLayout`` (the full
    observation) or ``PrivilegedLayout`` (friction too), from its run.json."""
    return PrivilegedLayout if teacher.play_kwargs.get("observation") == "privileged" else ObservationLayout


def sensor_teacher_policy(folder: str) -> Policy:
    """The policy at ``folder`` as a sensor policy's teacher: a ``ValueError`` unless it sees the full
    (or privileged) observation and acts with the sensor env's action map (``z_phase_origin`` 0)."""
    from ..policy import load_policy

    teacher = load_policy(folder)
    play = teacher.play_kwargs
    if play.get("observation") == "sensor" or play.get("z_phase_origin", 0.0) != 0.0:
        raise ValueError(f"teacher={folder!r} is not a full-observation policy on the sensor env's action map "
                         f"(its run.json: observation={play.get('observation')!r}, "
                         f"z_phase_origin={play.get('z_phase_origin', 0.0)!r})")
    return teacher


def hidden_entries(layout) -> list[int]:
    """Indices of the entries of ``layout`` the sensor observation hides: ``HIDDEN``, and the
    friction ratio in the privileged layout."""
    names = HIDDEN + (("friction_ratio",) if layout is PrivilegedLayout else ())
    return [i for name in names for i in range(*layout.structure[name].indices(len(layout.NAMES)))]


def standardised_error(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Root mean square error of each column over that column's standard deviation in ``truth``
    (0 exact, 1 no better than the mean): how well an estimator reads each hidden entry."""
    return np.sqrt(np.mean((estimate - truth) ** 2, axis=0)) / (truth.std(axis=0) + 1e-12)


class Estimator:
    """An MLP from the sensor observation to the entries the sensor hides (``hidden_entries``), both
    standardised with the statistics of the first data it is fitted on; ``names``: those entries'
    names in the teacher's observation layout."""

    def __init__(self, obs_dim: int, arch: tuple[int, ...], seed: int, n_out: int = len(HIDDEN),
                 names: tuple[str, ...] = ()):
        import torch

        torch.manual_seed(seed)
        layers, width = [], obs_dim
        for n in arch:
            layers += [torch.nn.Linear(width, n), torch.nn.ReLU()]
            width = n
        self.net = torch.nn.Sequential(*layers, torch.nn.Linear(width, n_out))
        self.scales = None  # (x mean, x std, y mean, y std)
        self.names = tuple(names)

    def save(self, path: str | Path) -> None:
        """Weights, standardisation and entry names as numbers (``.npz``, written atomically)."""
        from mdr_drive_env.files import atomic_path

        linear = [m for m in self.net if hasattr(m, "weight")]
        arrays = {f"weight{i}": m.weight.detach().numpy() for i, m in enumerate(linear)}
        arrays.update({f"bias{i}": m.bias.detach().numpy() for i, m in enumerate(linear)})
        arrays.update(dict(zip(("x_mean", "x_std", "y_mean", "y_std"), self.scales)), names=np.array(self.names))
        with atomic_path(path) as tmp:
            np.savez(tmp, **arrays)

    @classmethod
    def load(cls, path: str | Path) -> "Estimator":
        """The estimator :meth:`save` wrote (read without unpickling anything)."""
        import torch

        with np.load(path, allow_pickle=False) as f:
            n = sum(1 for key in f.files if key.startswith("weight"))
            weights = [f[f"weight{i}"] for i in range(n)]
            est = cls(weights[0].shape[1], tuple(w.shape[0] for w in weights[:-1]), seed=0, n_out=weights[-1].shape[0],
                      names=tuple(str(x) for x in f["names"]))
            linear = [m for m in est.net if hasattr(m, "weight")]
            with torch.no_grad():
                for i, m in enumerate(linear):
                    m.weight.copy_(torch.as_tensor(weights[i]))
                    m.bias.copy_(torch.as_tensor(f[f"bias{i}"]))
            est.scales = tuple(f[key] for key in ("x_mean", "x_std", "y_mean", "y_std"))
        return est

    def fit(self, x: np.ndarray, y: np.ndarray, steps: int, batch: int, learning_rate: float, seed: int,
            progress: bool = True) -> float:
        """``steps`` Adam steps (``student.adam_fit``) of squared error on standardised targets;
        returns the last epoch's loss."""
        import torch

        if self.scales is None:
            self.scales = (x.mean(axis=0), x.std(axis=0) + 1e-6, y.mean(axis=0), y.std(axis=0) + 1e-6)
        xm, xs, ym, ys = self.scales
        xt = torch.as_tensor((x - xm) / xs, dtype=torch.float32)
        yt = torch.as_tensor((y - ym) / ys, dtype=torch.float32)
        loss_of = lambda idx: torch.mean((self.net(xt[idx]) - yt[idx]) ** 2)  # noqa: E731
        return adam_fit(self.net.parameters(), lambda: (len(xt), loss_of), steps, batch, learning_rate, seed,
                        "adapt: estimator", progress)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        import torch

        xm, xs, ym, ys = self.scales
        with torch.no_grad():
            out = self.net(torch.as_tensor((x - xm) / xs, dtype=torch.float32)).numpy()
        return out * ys + ym


__all__ = ["FINE_TUNE_PPO", "HIDDEN", "Estimator", "hidden_entries", "sensor_teacher_policy",
           "standardised_error", "teacher_layout"]
