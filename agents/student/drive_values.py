"""A sensor policy that predicts what each drive of a table is worth and plays the best one.

The sensor hides k, the load and friction, so no observation tells for sure which drive of a
``teacher.DriveTable`` is fastest. A network fitted by squared error to each drive's worth at the hidden
point learns its expected worth given what the sensor has shown (the conditional mean), and the drive
of the highest expected worth is the best decision under that uncertainty: where the observation
cannot tell two hidden points apart, it picks a drive that does well at both, not the fastest drive
of one of them (decision-focused learning; a contextual bandit with every arm's reward known).

* ``DriveValueTargets``: what each drive of the table is worth at each hidden point, from their steady
  velocities there: the velocity's fraction of the table's best there, penalised below ``knee`` and
  below the trapezoid (``worth``); where every drive slides back under the load (a runaway load), how
  little it slides back against the best, so that the network learns to brake there.
* ``pick_rows``: how a drive is played. The env's action table holds each drive's two actions in turn
  (``DriveTable.rows``; a fixed action twice), and each period the policy plays the row that maximises
  its drive's worth less ``continuation`` times the squared distance between the previous action and
  the row's partner (the drive's other action): the drive's next action costs nothing, so a cycle's
  actions alternate, and another drive is started only where it is worth more by that margin.
* ``DriveValueNetwork``: an MLP from the sensor observation (standardised; the episode's elapsed
  fraction is ignored, so it plays alike in episodes of any length) to each drive's worth, with a
  second head for the hidden entries the motion can tell (``student.estimator.HIDDEN`` and mu1 / mu),
  fitted beside it; written as one SB3 PPO ``MlpPolicy`` over ``Discrete(rows)`` (``policy``) whose
  most likely action is the row ``pick_rows`` plays (its layers carry the previous action beside the
  network's, and its action net adds the continuation term), and the estimates as an ``Estimator``
  (``estimator``) for plots.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np

from mdr_drive_env.core.params import check_int, check_range

from ..protocol import BELOW_TOLERANCE, MOVING_THRESHOLD, SENSOR_ID
from .estimator import FINE_TUNE_PPO, Estimator
from .network import Student, adam_fit

#: The action net's output is the pick's score over this: SB3's Categorical then picks the row of the
#: highest score all but surely when it samples, as ``predict(deterministic=True)`` always does.
TEMPERATURE = 0.01
#: Two actions this close in every component are the same (the observation holds them as float32).
SAME_ACTION = 1e-6


class DriveValueTargets:
    """What each drive of a table is worth at each of a set of hidden points (module docstring).

    Args:
        velocities: (points, drives) steady velocity (m/s) of each drive of the table at each point.
        trapezoid: the trapezoid's drive index.
        knee, shortfall_weight: a fraction of the best below ``knee`` costs ``shortfall_weight`` times
            its shortfall below it besides (-): a drive far below the best is worse than its mean.
        below_weight: a velocity below the trapezoid's (by more than ``BELOW_TOLERANCE``) costs this
            times its shortfall, as a fraction of the best (-).
    """

    def __init__(self, velocities: np.ndarray, trapezoid: int = 0, knee: float = 0.85, shortfall_weight: float = 1.0,
                 below_weight: float = 5.0):
        v = np.asarray(velocities, dtype=np.float64)
        self.velocities = v
        self.best = v.max(axis=1)
        self.scale = np.maximum(self.best, MOVING_THRESHOLD)  # fractions of at least 2 mm/s
        fraction = v / self.scale[:, None]
        below = np.maximum((v[:, [trapezoid]] - BELOW_TOLERANCE - v) / self.scale[:, None], 0.0)
        worth = np.minimum(fraction, 1.0) - shortfall_weight * np.maximum(knee - fraction, 0.0) - below_weight * below
        backward = self.best < 0.0  # every drive slides back under the load: worth is how little, in [-1, 0]
        if backward.any():
            vb, best = v[backward], self.best[backward, None]
            below_b = np.maximum(vb[:, [trapezoid]] - BELOW_TOLERANCE - vb, 0.0) / -best
            worth[backward] = best / vb - 1.0 - below_weight * below_b  # best / vb in (0, 1], 1 for the best
        #: (points, drives) in [-1, 1]: the velocity's fraction of the best (at least ``MOVING_THRESHOLD``),
        #: at most 1, less the shortfall and below-trapezoid costs; where every drive slides back, the
        #: best's velocity over the drive's, less 1 and the below-trapezoid cost (the best 0).
        self.worth = np.clip(worth, -1.0, 1.0).astype(np.float32)

    @classmethod
    def of(cls, velocities: np.ndarray, settings) -> "DriveValueTargets":
        """The targets of ``velocities`` (points, drives) m/s with the ``knee``, ``shortfall_weight`` and
        ``below_weight`` of ``settings`` (a recipe's config: ``train.sensor.SensorConfig``,
        ``student.told.WorthConfig``)."""
        return cls(velocities, knee=settings.knee, shortfall_weight=settings.shortfall_weight,
                   below_weight=settings.below_weight)


def check_fit_settings(config) -> None:
    """The checks every worth network's settings share (``train.sensor.SensorConfig``,
    ``student.told.WorthConfig``): ``ValueError`` naming the first bad one of ``steps``, ``batch`` and
    ``torch_threads`` (>= 1), ``arch`` (positive layer sizes), ``continuation`` and ``knee`` (0-1),
    ``shortfall_weight`` and ``below_weight`` (0-100) and ``learning_rate`` (0-1, above 0)."""
    for name in ("steps", "batch", "torch_threads"):
        check_int(name, getattr(config, name), 1)
    if not config.arch or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in config.arch):
        raise ValueError(f"arch={config.arch!r} must be positive layer sizes")
    for name in ("continuation", "knee"):
        check_range(name, getattr(config, name), 0.0, 1.0)
    for name in ("shortfall_weight", "below_weight"):
        check_range(name, getattr(config, name), 0.0, 100.0)
    check_range("learning_rate", config.learning_rate, 0.0, 1.0, low_open=True)


def pick_rows(worth: np.ndarray, previous: np.ndarray, partners: np.ndarray, continuation: float,
              switch_cost: float = 0.0) -> np.ndarray:
    """The rows (n,) played given each drive's worth (n, drives), the previous actions (n, 5) (zeros
    before the first) and each row's partner (2 drives, 5) (``DriveTable.partners``): the row of the
    highest ``worth[drive] - continuation * |previous - partner|^2``, less ``switch_cost`` unless the
    previous action is the row's partner (the row continues the drive just played)."""
    gap = np.asarray(previous, dtype=np.float64)[:, None, :] - partners[None, :, :]
    score = np.repeat(worth, 2, axis=1) - continuation * (gap ** 2).sum(axis=-1)
    if switch_cost > 0.0:  # the rows whose partner is the previous action (to float32's precision) continue
        score = score + switch_cost * np.all(np.abs(gap) <= SAME_ACTION, axis=-1)
    return np.argmax(score, axis=1)


def row_key(partners: np.ndarray, tries: int = 2000) -> np.ndarray:
    """A direction w (5,) that tells the distinct partner actions apart on one axis: of ``tries`` seeded
    random directions (|w|_1 = 1), the one whose projections of the partners and of the zero action
    (the previous action before the first period) are furthest apart at their closest pair."""
    points = np.unique(np.vstack([np.asarray(partners, dtype=np.float64), np.zeros((1, partners.shape[1]))]), axis=0)
    directions = np.random.default_rng(0).normal(size=(tries, points.shape[1]))
    directions /= np.abs(directions).sum(axis=1, keepdims=True)
    gaps = np.diff(np.sort(points @ directions.T, axis=0), axis=0).min(axis=0)
    return directions[int(np.argmax(gaps))]


class DriveValueNetwork:
    """The sensor policy's network (module docstring): observation -> each drive's worth and the estimates.

    Args:
        obs_dim: entries of the sensor observation.
        partners: (2 drives, 5) each row's partner (``DriveTable.partners``).
        previous: the observation's entries that hold the previous action (5).
        continuation: ``pick_rows``' weight (-).
        estimate_names: the hidden entries its second head estimates (privileged observation names).
        arch: hidden layer sizes (ReLU).
        ignored: observation entries it does not read (the episode's elapsed fraction).
    """

    def __init__(self, obs_dim: int, partners: np.ndarray, previous: slice, continuation: float,
                 estimate_names: tuple[str, ...], arch: tuple[int, ...], seed: int, ignored: tuple[int, ...] = ()):
        import torch

        torch.manual_seed(seed)
        layers, width = [], obs_dim
        for n in arch:
            layers += [torch.nn.Linear(width, n), torch.nn.ReLU()]
            width = n
        self.trunk = torch.nn.Sequential(*layers)
        self.partners = np.asarray(partners, dtype=np.float64)
        self.worth = torch.nn.Linear(width, len(self.partners) // 2)
        with warnings.catch_warnings():  # a head of no estimates (a told policy) has nothing to initialise
            warnings.filterwarnings("ignore", "Initializing zero-element tensors")
            self.estimate_head = torch.nn.Linear(width, len(estimate_names))
        self.previous = list(range(obs_dim))[previous]
        self.continuation = float(continuation)
        #: ``pick_rows``' switch cost: 0 while the rounds drive; the recipe sets its ``play_switch_cost``
        #: before the network is merged.
        self.switch_cost = 0.0
        self.estimate_names = tuple(estimate_names)
        self.mask = np.ones(obs_dim, dtype=np.float32)
        self.mask[list(ignored)] = 0.0
        self.scales = None  # (x mean, x std, estimate mean, estimate std)

    def parameters(self) -> list:
        return [*self.trunk.parameters(), *self.worth.parameters(), *self.estimate_head.parameters()]

    def standardise_with(self, x: np.ndarray, estimates: np.ndarray) -> None:
        """Fix the standardisation of the inputs and the estimates to the statistics of ``x`` (n, d)
        and ``estimates`` (n, e); an ignored entry is left as it is (mean 0, std 1) and multiplied by 0."""
        mean, std = x.mean(axis=0), x.std(axis=0) + 1e-6
        mean[self.mask == 0.0], std[self.mask == 0.0] = 0.0, 1.0
        self.scales = (mean, std, estimates.mean(axis=0), estimates.std(axis=0) + 1e-6)

    def _inputs(self, x: np.ndarray):
        import torch

        mean, std = self.scales[:2]
        return torch.as_tensor((x - mean) / std * self.mask, dtype=torch.float32)

    def predicted_worth(self, x: np.ndarray) -> np.ndarray:
        """Each drive's predicted worth (n, drives) at sensor observations ``x`` (n, d)."""
        import torch

        with torch.no_grad():
            return self.worth(self.trunk(self._inputs(x))).numpy()

    def act(self, x: np.ndarray) -> np.ndarray:
        """The rows (n,) it plays: ``pick_rows`` on its predicted worth and the observed previous action."""
        return pick_rows(self.predicted_worth(x), x[:, self.previous], self.partners, self.continuation,
                         self.switch_cost)

    def estimates(self, x: np.ndarray) -> np.ndarray:
        """The estimates (n, e) of the hidden entries, in the privileged observation's units."""
        import torch

        with torch.no_grad():
            out = self.estimate_head(self.trunk(self._inputs(x))).numpy()
        return out * self.scales[3] + self.scales[2]

    def fit(self, x: np.ndarray, point: np.ndarray, estimates: np.ndarray, targets: DriveValueTargets, steps: int,
            batch: int, learning_rate: float, seed: int, estimate_weight: float = 0.2, progress: bool = True,
            top_weight: float = 0.0, top_margin: float = 0.1, desc: str = "sensor: value network") -> float:
        """``steps`` Adam steps (``student.adam_fit``) of the squared error of every drive's predicted
        worth against ``targets.worth`` at each sample's hidden point (``point``: indices), the drives
        within ``top_margin`` of the point's best worth weighted ``1 + top_weight`` (the pick needs the
        best drives' order, not the worst drives' worth), plus ``estimate_weight`` times that of the
        standardised estimates against ``estimates``; returns the last epoch's loss."""
        import torch

        xt = self._inputs(x)
        yt = torch.as_tensor((estimates - self.scales[2]) / self.scales[3], dtype=torch.float32)
        worth, point = torch.as_tensor(targets.worth), torch.as_tensor(point)
        weight = 1.0 + top_weight * (worth >= worth.max(dim=1, keepdim=True).values - top_margin).float()
        weight = weight / weight.mean(dim=1, keepdim=True)

        def loss_of(idx):
            h = self.trunk(xt[idx])
            loss = torch.mean(weight[point[idx]] * (self.worth(h) - worth[point[idx]]) ** 2)
            if self.estimate_names:  # a told policy estimates nothing
                loss = loss + estimate_weight * torch.mean((self.estimate_head(h) - yt[idx]) ** 2)
            return loss

        return adam_fit(self.parameters(), lambda: (len(xt), loss_of), steps, batch, learning_rate, seed,
                        desc, progress)

    def _trunk_layers(self) -> list:
        return [m for m in self.trunk if hasattr(m, "weight")]

    def _linear(self) -> list:
        return self._trunk_layers() + [self.worth, self.estimate_head]

    def state(self) -> dict:
        """Weights and standardisation as numbers (``load_state``)."""
        out = {f"weight{i}": m.weight.detach().numpy().copy() for i, m in enumerate(self._linear())}
        out.update({f"bias{i}": m.bias.detach().numpy().copy() for i, m in enumerate(self._linear())})
        out.update(dict(zip(("x_mean", "x_std", "y_mean", "y_std"), self.scales)), mask=self.mask)
        return out

    def load_state(self, state: dict) -> None:
        import torch

        with torch.no_grad():
            for i, m in enumerate(self._linear()):
                m.weight.copy_(torch.as_tensor(state[f"weight{i}"]))
                m.bias.copy_(torch.as_tensor(state[f"bias{i}"]))
        self.scales = tuple(np.asarray(state[key]) for key in ("x_mean", "x_std", "y_mean", "y_std"))
        self.mask = np.asarray(state["mask"], dtype=np.float32)

    def estimator(self) -> Estimator:
        """The estimate head as an ``Estimator`` (the trunk, then the head; the ignored entries' first
        weights zeroed): what ``estimator.npz`` holds."""
        import torch

        arch = tuple(m.out_features for m in self._trunk_layers())
        est = Estimator(len(self.mask), arch, seed=0, n_out=len(self.estimate_names), names=self.estimate_names)
        src = self._trunk_layers() + [self.estimate_head]
        dst = [m for m in est.net if hasattr(m, "weight")]
        with torch.no_grad():
            for i, (a, b) in enumerate(zip(src, dst)):
                b.weight.copy_(a.weight * (torch.as_tensor(self.mask)[None, :] if i == 0 else 1.0))
                b.bias.copy_(a.bias)
        est.scales = self.scales
        return est

    def _switch_units(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the merged policy adds for the switch cost (none without one): a direction ``key`` (5,)
        that tells the distinct partners apart (``row_key``), the knots of its hat functions (the sorted
        projections of the partners and of the zero action, and one beyond each end), and each row's
        weights (rows, knots) on the units relu(key . a - knot): the hat that is 1 where the previous
        action a projects onto the row's partner and 0 from the neighbouring projections on."""
        if self.switch_cost == 0.0:
            return np.zeros(len(self.previous)), np.zeros(0), np.zeros((len(self.partners), 0))
        key = row_key(self.partners)
        projections = self.partners @ key
        centres = np.unique(np.append(projections, 0.0))
        knots = np.concatenate([[centres[0] - 1.0], centres, [centres[-1] + 1.0]])
        hats = np.zeros((len(self.partners), len(knots)))
        for r, i in enumerate(np.searchsorted(knots, projections)):  # each projection is a knot
            left, right = knots[i] - knots[i - 1], knots[i + 1] - knots[i]
            hats[r, i - 1], hats[r, i], hats[r, i + 1] = 1.0 / left, -1.0 / left - 1.0 / right, 1.0 / right
        return key, knots, hats

    def policy(self, env_kwargs: dict, rows: np.ndarray, seed: int = 0, env_id: str = SENSOR_ID) -> Student:
        """One SB3 PPO ``MlpPolicy`` over ``gym.make(env_id, **env_kwargs, action_codebook=rows)`` whose
        most likely action is :meth:`act`'s row: its ``VecNormalize`` standardises as the network does;
        its policy layers are the trunk (the ignored entries' weights zeroed), each with ten more units
        that carry the previous action (relu(a) and relu(-a)); its action net gives each row its drive's
        worth less the continuation term, over ``TEMPERATURE`` (the previous action's own square, the same
        for every row, left out). With a ``switch_cost``, the layers also carry the previous action's
        projection on a key direction, and the last holds units that tell which row it was
        (``_switch_units``); the action net adds the cost to the rows that continue it (the same pick as
        the cost taken from every other row)."""
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

        play_env = {**env_kwargs, "action_codebook": np.asarray(rows)}
        venv = VecNormalize(VecMonitor(DummyVecEnv([lambda: gym.make(env_id, **play_env)])),
                            norm_obs=True, norm_reward=True, gamma=FINE_TUNE_PPO["gamma"], clip_obs=1e6)
        mean, std = self.scales[:2]
        venv.obs_rms.mean = mean.astype(np.float64)
        venv.obs_rms.var = std.astype(np.float64) ** 2 - venv.epsilon
        venv.obs_rms.count = 1e6
        src = self._trunk_layers()
        k = len(self.previous)
        key, knots, hats = self._switch_units()
        n_knots = len(knots)
        # the switch cost's units: the key's projection of the previous action, relu(s) and relu(-s), carried
        # to the last layer, which holds relu(s - knot) for every knot
        extra = [(2 if i < len(src) - 1 else n_knots) if n_knots else 0 for i in range(len(src))]
        model = PPO("MlpPolicy", venv, seed=seed, device="cpu",
                    policy_kwargs={"net_arch": {"pi": [m.out_features + 2 * k + e for m, e in zip(src, extra)],
                                                "vf": [64, 64]},
                                   "activation_fn": torch.nn.ReLU},
                    **{key: v for key, v in FINE_TUNE_PPO.items() if key != "n_envs"})
        dst = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
        mask = torch.as_tensor(self.mask, dtype=torch.float64)
        s_prev = torch.as_tensor(std[self.previous], dtype=torch.float64)
        m_prev = torch.as_tensor(mean[self.previous], dtype=torch.float64)
        with torch.no_grad():
            for i, (a, b) in enumerate(zip(src, dst)):
                w = torch.zeros_like(b.weight, dtype=torch.float64)
                bias = torch.zeros_like(b.bias, dtype=torch.float64)
                h = a.out_features
                w[:h, :a.in_features] = a.weight.double() * (mask[None, :] if i == 0 else 1.0)
                bias[:h] = a.bias.double()
                for j in range(k):  # relu(a_j), relu(-a_j) of the previous action
                    if i == 0:  # from the standardised observation: a = std x + mean
                        col = self.previous[j]
                        w[h + j, col], bias[h + j] = s_prev[j], m_prev[j]
                        w[h + k + j, col], bias[h + k + j] = -s_prev[j], -m_prev[j]
                    else:
                        prev_h = src[i - 1].out_features
                        w[h + j, prev_h + j] = w[h + k + j, prev_h + k + j] = 1.0
                last = i == len(src) - 1
                for q in range(extra[i]):  # relu(+-s) or, in the last layer, relu(s - knot q)
                    sign, shift = (1.0, knots[q]) if last else ((1.0, -1.0)[q], 0.0)
                    if i == 0:  # s = key . a, from the standardised observation
                        for j in range(k):
                            w[h + 2 * k + q, self.previous[j]] = sign * key[j] * s_prev[j]
                        bias[h + 2 * k + q] = sign * float(np.dot(key, m_prev.numpy())) - shift
                    else:  # from the carried relu(s) and relu(-s)
                        col = src[i - 1].out_features + 2 * k
                        w[h + 2 * k + q, col:col + 2] = torch.tensor([1.0, -1.0]) if last else torch.eye(2)[q]
                        bias[h + 2 * k + q] = -shift
                b.weight.copy_(w)
                b.bias.copy_(bias)
            drive = np.repeat(np.arange(len(self.partners) // 2), 2)
            partners = torch.as_tensor(self.partners, dtype=torch.float64)
            c = self.continuation
            h = src[-1].out_features
            w = torch.zeros_like(model.policy.action_net.weight, dtype=torch.float64)
            w[:, :h] = self.worth.weight.double()[drive]
            w[:, h:h + k] = 2.0 * c * partners  # -c |a - p|^2 = 2c a.p - c |p|^2 - c |a|^2
            w[:, h + k:h + 2 * k] = -2.0 * c * partners
            if n_knots:  # the switch cost, as a bonus for the row whose partner is the previous action
                w[:, h + 2 * k:] = self.switch_cost * torch.as_tensor(hats, dtype=torch.float64)
            bias = self.worth.bias.double()[drive] - c * (partners ** 2).sum(dim=1)
            model.policy.action_net.weight.copy_(w / TEMPERATURE)
            model.policy.action_net.bias.copy_(bias / TEMPERATURE)
        return Student(model, venv, codebook=np.asarray(rows))


__all__ = ["DriveValueNetwork", "DriveValueTargets", "check_fit_settings", "SAME_ACTION", "TEMPERATURE", "pick_rows", "row_key"]
