"""The sensor policy's network: an estimator of what the sensor hides, the teacher on its guesses,
and both written as one SB3 ``MlpPolicy`` (RMA's adaptation module and base policy, Kumar et al. 2021).

Used by ``mdr_drive_agents.train.sensor``, which trains the estimator and ships the merged network.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

from mdr_drive_env.gym_envs.spaces import ObservationLayout, PrivilegedLayout

from ..policy import Policy
from .network import Student, adam_fit, edge_loss, policy_mean

SENSOR_ID = "MDRDriveSensor-v0"
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


class SensorTeacher:
    """The teacher told the estimator's guesses for the hidden entries, its own average for the
    slider's motion and the contact forces (it was trained to ignore them), and, from the sensor
    observation, the previous action and the episode's elapsed fraction: a function of the sensor
    observation alone (RMA's base policy on its adaptation module's estimate)."""

    def __init__(self, teacher: Policy, estimator: Estimator, sensor_structure: dict):
        self.teacher, self.estimator = teacher, estimator
        layout = teacher_layout(teacher)
        self.n_full = len(layout.NAMES)
        full = layout.structure
        self.hidden = hidden_entries(layout)
        self.dynamics = list(range(full["dynamics"].start, full["dynamics"].stop))
        actions = sensor_structure["actions"]
        # full-observation entries copied from the sensor observation: the newest action, the fraction
        self.copied = [*range(full["previous_action"].start, full["previous_action"].stop),
                       full["episode_fraction"].start]
        self.sources = [*range(actions.start, actions.start + 5), sensor_structure["episode_fraction"].start]

    def full_observation(self, sensed: np.ndarray, hidden: np.ndarray | None = None) -> np.ndarray:
        """The full observation the teacher is given for sensor observations ``sensed`` (n, d): the
        estimator's guesses for the hidden entries, or ``hidden`` (n, len(self.hidden)) if given."""
        full = np.zeros((len(sensed), self.n_full), dtype=np.float32)
        full[:, self.dynamics] = self.teacher.normalize.mean[self.dynamics]
        full[:, self.copied] = sensed[:, self.sources]
        full[:, self.hidden] = self.estimator(sensed) if hidden is None else hidden
        return full

    def __call__(self, sensed: np.ndarray, privileged: np.ndarray | None = None) -> np.ndarray:
        return np.asarray(self.teacher.act(self.full_observation(sensed)), dtype=np.float32)

    def told_truth(self, sensed: np.ndarray, privileged: np.ndarray) -> np.ndarray:
        """The teacher's mean action (n, 5), before SB3's clip, told the true hidden entries of
        ``privileged`` and otherwise what this composition tells it: the label of
        :meth:`fit_actions`."""
        import torch

        full = self.full_observation(sensed, hidden=privileged[:, self.hidden])
        with torch.no_grad():
            return policy_mean(self.teacher.model.policy, torch.as_tensor(self._normalise(full))).numpy()

    def _normalise(self, full: np.ndarray) -> np.ndarray:
        return self.teacher.normalize(full)

    def fit_actions(self, sensed: np.ndarray, labels: np.ndarray, steps: int, batch: int, learning_rate: float,
                    seed: int, huber_delta: float = 0.05, progress: bool = True) -> float:
        """Fit the estimator through the frozen teacher: ``steps`` Adam steps (``student.adam_fit``)
        on the loss between the teacher's mean action on the estimator's guesses and ``labels`` (the
        teacher's action told the truth, :meth:`told_truth`), Huber with ``huber_delta``
        (``student.edge_loss``). The guesses then serve the actions rather than the hidden values:
        an entry the sensor cannot tell apart costs what it changes in the drive, not its variance.
        Returns the last epoch's loss."""
        import torch

        est, t = self.estimator, self.teacher
        stats = t.normalize
        xm, xs, ym, ys = est.scales
        base = torch.as_tensor(self._normalise(self.full_observation(  # hidden columns replaced below
            sensed, hidden=np.zeros((len(sensed), len(self.hidden)), dtype=np.float32))))
        xt = torch.as_tensor((sensed - xm) / xs, dtype=torch.float32)
        yt = torch.as_tensor(labels, dtype=torch.float32)
        cols = torch.as_tensor(self.hidden)
        mean = torch.as_tensor(stats.mean[self.hidden], dtype=torch.float32)
        std = torch.as_tensor(np.sqrt(stats.var[self.hidden] + stats.epsilon), dtype=torch.float32)
        ym_t, ys_t = torch.as_tensor(ym, dtype=torch.float32), torch.as_tensor(ys, dtype=torch.float32)
        for param in t.model.policy.parameters():
            param.requires_grad_(False)

        def loss_of(idx):
            guess = est.net(xt[idx]) * ys_t + ym_t
            z = base[idx].clone()
            z[:, cols] = torch.clamp((guess - mean) / std, -stats.clip_obs, stats.clip_obs)
            return edge_loss(policy_mean(t.model.policy, z), yt[idx], huber_delta)

        try:
            return adam_fit(est.net.parameters(), lambda: (len(xt), loss_of), steps, batch, learning_rate, seed,
                            "adapt: estimator through the teacher", progress)
        finally:
            for param in t.model.policy.parameters():
                param.requires_grad_(True)


def merged_policy(sensor_teacher: SensorTeacher, env_kwargs: dict, log_std: float, seed: int = 0) -> Student:
    """One SB3 PPO ``MlpPolicy`` (ReLU) on the sensor observation that computes ``sensor_teacher``
    exactly (as long as the teacher's normalised inputs stay inside its VecNormalize clip), over
    ``MDRDriveSensor-v0(**env_kwargs)`` (``train.sensor.sensor_env_kwargs``); ``log_std`` for PPO:

    * its ``VecNormalize`` standardises the observation as the estimator does (no clipping);
    * its first layers are the estimator's hidden layers, widened by units that carry the entries
      the teacher reads from the sensor observation (each as relu(x) and relu(-x));
    * the next layer is the teacher's first layer composed with the estimator's output layer and the
      teacher's observation normalisation (a product of linear maps);
    * the rest is the teacher's network (its later layers and action head) as it is: for a teacher
      that picks from an action table (``Discrete(N)``, a codebook student), its logits over the
      same table, which the merged network then picks from (the env's ``action_codebook``).
    """
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

    est, teacher = sensor_teacher.estimator, sensor_teacher.teacher
    n_full = sensor_teacher.n_full
    xm, xs, ym, ys = est.scales
    est_linear = [m for m in est.net if isinstance(m, torch.nn.Linear)]
    t_net = teacher.model.policy.mlp_extractor.policy_net
    t_linear = [m for m in t_net if isinstance(m, torch.nn.Linear)]
    if not all(isinstance(m, (torch.nn.Linear, torch.nn.ReLU)) for m in t_net):
        raise ValueError("the teacher's policy network is not Linear/ReLU layers")
    carried = sensor_teacher.sources
    n_c = len(carried)
    widths = [m.out_features + 2 * n_c for m in est_linear[:-1]]
    codebook = teacher.codebook  # a codebook teacher's merged network picks among the same table
    play_env = env_kwargs if codebook is None else {**env_kwargs, "action_codebook": codebook}
    venv = VecNormalize(VecMonitor(DummyVecEnv([lambda: gym.make(SENSOR_ID, **play_env)])),
                        norm_obs=True, norm_reward=True, gamma=0.98, clip_obs=1e6)
    venv.obs_rms.mean = xm.astype(np.float64)
    venv.obs_rms.var = xs.astype(np.float64) ** 2 - venv.epsilon
    venv.obs_rms.count = 1e6
    policy_kwargs = {"net_arch": {"pi": [*widths, *(m.out_features for m in t_linear)], "vf": [64, 64]},
                     "activation_fn": torch.nn.ReLU, "log_std_init": log_std}
    model = PPO("MlpPolicy", venv, seed=seed, device="cpu", policy_kwargs=policy_kwargs,
                **{key: v for key, v in FINE_TUNE_PPO.items() if key != "n_envs"})
    layers = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    stats = teacher.normalize
    tm = torch.as_tensor(stats.mean, dtype=torch.float64)
    ts = torch.sqrt(torch.as_tensor(stats.var, dtype=torch.float64) + stats.epsilon)
    with torch.no_grad():
        for i, (lin, src) in enumerate(zip(layers, est_linear[:-1])):  # estimator layers + carried units
            w = torch.zeros_like(lin.weight, dtype=torch.float64)
            b = torch.zeros_like(lin.bias, dtype=torch.float64)
            h = src.out_features
            w[:h, :src.in_features] = src.weight.double()
            b[:h] = src.bias.double()
            for j, c in enumerate(carried):
                if i == 0:  # from the standardised observation
                    w[h + j, c], w[h + n_c + j, c] = 1.0, -1.0
                else:  # relu(relu(x)) = relu(x)
                    prev_h = est_linear[i - 1].out_features
                    w[h + j, prev_h + j], w[h + n_c + j, prev_h + n_c + j] = 1.0, 1.0
            lin.weight.copy_(w)
            lin.bias.copy_(b)
        # the teacher's normalised input z = A h + B (c+ - c-) + c0, then its first layer
        out, h = est_linear[-1], est_linear[-1].in_features
        a_mat = torch.zeros((n_full, h), dtype=torch.float64)
        b_mat = torch.zeros((n_full, n_c), dtype=torch.float64)
        c0 = torch.zeros(n_full, dtype=torch.float64)
        for j, idx in enumerate(sensor_teacher.hidden):  # estimate, in the full observation's units
            a_mat[idx] = out.weight[j].double() * ys[j] / ts[idx]
            c0[idx] = (out.bias[j].double() * ys[j] + ym[j] - tm[idx]) / ts[idx]
        for j, (idx, c) in enumerate(zip(sensor_teacher.copied, carried)):  # copied entries
            b_mat[idx, j] = xs[c] / ts[idx]
            c0[idx] = (xm[c] - tm[idx]) / ts[idx]
        # the dynamics entries sit at the teacher's mean: 0 after normalisation
        first = t_linear[0]
        w1 = first.weight.double()
        lin = layers[len(widths)]
        lin.weight.copy_(torch.cat([w1 @ a_mat, w1 @ b_mat, -(w1 @ b_mat)], dim=1))
        lin.bias.copy_(first.bias.double() + w1 @ c0)
        for lin, src in zip(layers[len(widths) + 1:], t_linear[1:]):
            lin.weight.copy_(src.weight)
            lin.bias.copy_(src.bias)
        model.policy.action_net.weight.copy_(teacher.model.policy.action_net.weight)
        model.policy.action_net.bias.copy_(teacher.model.policy.action_net.bias)
    return Student(model, venv, codebook=codebook)
