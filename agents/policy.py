"""A policy folder: a trained SB3 policy, its observation normalisation and its run record.

    from mdr_drive_agents import load_policy

    policy = load_policy("agents/pretrained/ppo_generalist")   # any folder, from any working directory
    env = policy.make_env(k=0.2, cargo_mass=0.1)               # the env it was trained for (run.json)
    obs, _ = env.reset(seed=0)
    for _ in range(30):
        obs, reward, terminated, truncated, info = env.step(policy.predict(obs))

A folder holds ``model.zip`` (SB3), ``vecnormalize.npz`` and ``vecnormalize.pkl`` (the observation
statistics the network was trained on, as numbers and as SB3's pickled ``VecNormalize``),
``run.json`` (how it was made, and the env keywords it acts in) and, for a policy that picks its
action from a table, that table (``action_codebook.npy``). ``load_policy`` reads them without
unpickling anything (``mdr_drive_agents.sb3_files``); the same files load with plain ``PPO.load`` +
``VecNormalize.load`` (each model card shows how), which run code from the files: load those only
from a source you trust.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from mdr_drive_env.gym_envs.spaces import load_action_codebook

from .drive import DRIVE_KEYS
from .sb3_files import NORMALIZATION_FILE, NormalizationState, read_model


def cycle_space(space):
    """The action space of a two-period cycle of ``space``'s Box actions: both halves side by side
    (``vec_env.CycleActions``)."""
    import gymnasium as gym

    return gym.spaces.Box(np.tile(space.low, 2), np.tile(space.high, 2), dtype=space.dtype)

#: The shipped policies.
PRETRAINED = Path(__file__).parent / "pretrained" / "ppo_generalist"
SENSOR_PRETRAINED = Path(__file__).parent / "pretrained" / "ppo_sensor"
#: The files every policy folder holds; a codebook policy's table too (``CODEBOOK_FILE``).
FILES = ("model.zip", NORMALIZATION_FILE, "vecnormalize.pkl", "run.json")
CODEBOOK_FILE = "action_codebook.npy"
#: A sensor policy's estimator of the hidden entries (``student.estimator.Estimator.save``), for plots.
ESTIMATOR_FILE = "estimator.npz"
#: Keys of a policy's env keywords (run.json) that shape its observation, and that set what its
#: Box actions mean: the closed-loop protocol builds its envs with them.
OBSERVATION_KEYS = ("observation", "history", "sensor_forces", "sensor_tier", "trace_samples", "encoder_noise",
                    "force_noise")
ACTION_KEYS = ("z_phase_origin", "time_quantum")
#: ... and the drive it was built for (``mdr_drive_agents.drive.DRIVE_KEYS``): it plays on that drive.
PLAY_KEYS = OBSERVATION_KEYS + ACTION_KEYS + tuple(DRIVE_KEYS)
#: The algorithms a policy folder's run.json may name (``algo``): Stable-Baselines3's PPO, SAC and TD3,
#: and sb3-contrib's RecurrentPPO (an LSTM policy).
ALGORITHMS = ("ppo", "sac", "td3", "recurrent_ppo")


def package_path(path: str | Path) -> Path:
    """``path`` as given if it exists (or is absolute); a relative ``agents/...`` path that does not
    exist from here names the package's own files (``agents/pretrained/ppo_generalist`` from any
    working directory, in a checkout or an installed package)."""
    path = Path(path)
    if path.is_absolute() or path.exists() or path.parts[:1] != ("agents",):
        return path
    return Path(__file__).parent.joinpath(*path.parts[1:])


def run_env_kwargs(folder: str | Path, run: dict) -> dict:
    """A policy folder's run.json ``env_kwargs`` with a relative ``action_codebook`` file name resolved
    against ``folder`` (an absolute path): ``gym.make(run["env_id"], **run_env_kwargs(folder, run))``
    is the env it was trained in, from any working directory."""
    env_kwargs = dict(run.get("env_kwargs", {}))
    if isinstance(env_kwargs.get("action_codebook"), str):
        env_kwargs["action_codebook"] = str((Path(folder) / env_kwargs["action_codebook"]).resolve())
    return env_kwargs


def sb3_class(algo: str):
    """The Stable-Baselines3 (or sb3-contrib) class of ``algo``, one of ``ALGORITHMS``; ``ValueError``
    for another."""
    if algo not in ALGORITHMS:
        raise ValueError(f"algo={algo!r} is not one of {sorted(ALGORITHMS)}")
    if algo == "recurrent_ppo":
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO
    import stable_baselines3

    return getattr(stable_baselines3, algo.upper())


def policy_name(algo: str) -> str:
    """The SB3 policy name a policy of ``algo`` is built with: ``MlpLstmPolicy`` for RecurrentPPO,
    else ``MlpPolicy``."""
    return "MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy"


@dataclass
class Policy:
    """A trained network as a drive: ``act`` (a batch of observations -> Box actions) for the
    evaluation protocol, ``predict`` (one observation -> one action of its env) for a user's loop.

    A recurrent policy (RecurrentPPO) carries its LSTM state from one ``act`` or ``predict`` to the
    next, and a policy trained with two-period cycle actions (``action_cycle: 2``, ``vec_env.CycleActions``)
    plays the second half of its last action every other period; ``reset`` forgets both (every
    episode starts with ``reset``; ``play`` and the evaluation protocol call it).

    Attributes:
        model: the SB3 model (one of ``ALGORITHMS``).
        normalize: its observation normalisation, ``obs -> normalised obs`` (an ``ObsNormalization``,
            or a training VecNormalize's ``normalize_obs``), or None (raw observations).
        codebook: the (N, 5) Box actions a ``Discrete(N)`` policy picks among, or None.
        run: its run record (run.json), ``{}`` if none.
        folder: the folder it was loaded from, or None.
    """

    model: object
    normalize: Callable[[np.ndarray], np.ndarray] | None
    codebook: np.ndarray | None = None
    run: dict = field(default_factory=dict)
    folder: Path | None = None
    _memory: object = field(default=None, init=False, repr=False, compare=False)
    _pending: object = field(default=None, init=False, repr=False, compare=False)

    @property
    def recurrent(self) -> bool:
        """Whether it remembers past observations (an LSTM policy)."""
        return self.run.get("algo") == "recurrent_ppo"

    @property
    def cycle(self) -> int:
        """Periods one action of the network sets: 1, or 2 for a two-period cycle (run.json's
        ``hyperparameters.action_cycle``)."""
        return int(self.run.get("hyperparameters", {}).get("action_cycle", 1))

    def reset(self) -> None:
        """Forget what a recurrent policy remembers and a cycle's second half: the next observation
        starts an episode."""
        self._memory = self._pending = None

    def _predict(self, obs: np.ndarray):
        if not self.recurrent:
            return self.model.predict(obs, deterministic=True)[0]
        memory = self._memory
        if memory is not None and memory[0].shape[1] != len(obs):  # another batch: another episode
            memory = None
        starts = np.full(len(obs), memory is None)
        action, self._memory = self.model.predict(obs, state=memory, episode_start=starts, deterministic=True)
        return action

    @property
    def env_id(self) -> str:
        """The env it was trained in (run.json's ``env_id``, default ``MDRDrive-v0``)."""
        return self.run.get("env_id", "MDRDrive-v0")

    @property
    def env_kwargs(self) -> dict:
        """Its training env's keywords (run.json), a codebook file as an absolute path."""
        return run_env_kwargs(self.folder or ".", self.run)

    @property
    def play_kwargs(self) -> dict:
        """The env keywords that shape the observation it was trained on and what its Box actions mean
        (``PLAY_KEYS`` of its run.json): an ``MDRDrive-v0`` built with them is the env it expects when it
        plays Box actions (``act``)."""
        env_kwargs = self.run.get("env_kwargs", {})
        return {key: env_kwargs[key] for key in PLAY_KEYS if key in env_kwargs}

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Box actions (n, 5) at observations ``obs`` (n, d), deterministic: the mean action, or the
        codebook row of the most likely index (so it plays in an env without the codebook alike)."""
        if self.cycle == 2 and self._pending is not None and len(self._pending) == len(obs):
            action, self._pending = self._pending, None  # the cycle's second period
            return action
        action = self._predict(self.normalized(obs))
        if self.cycle == 2:
            action = np.asarray(action).reshape(len(obs), 2, -1)
            self._pending = action[:, 1]
            return action[:, 0]
        return action if self.codebook is None else self.codebook[action]

    def normalized(self, obs: np.ndarray) -> np.ndarray:
        """Observations as the network takes them (its normalisation, if any)."""
        return obs if self.normalize is None else self.normalize(obs)

    def predict(self, obs: np.ndarray):
        """The action of its own env (``make_env``) at one observation ``obs`` (d,), deterministic and
        normalised with its statistics: a Box action (5,), or a codebook index."""
        if self.cycle == 2:
            return self.act(np.asarray(obs)[None])[0]
        return self._predict(self.normalized(np.asarray(obs)[None]))[0]

    def make_env(self, **overrides):
        """The gymnasium env it was trained for, built from its run.json (observation layout, time
        quantum, z phase origin, action codebook, training ranges), with ``overrides`` (``k=0.2,
        cargo_mass=0.1``: one point; a ``cargo_mass`` replaces the trained ``load_ratio``)."""

        import mdr_drive_env  # noqa: F401  registers the envs

        return make_env_of(self.folder or ".", self.run, **overrides)

    def check_env(self, env) -> None:
        """``ValueError`` naming the fix unless ``env``'s action space is the one it acts in."""
        space = getattr(env, "single_action_space", env.action_space)
        if space == self.model.action_space or self.cycle == 2 and cycle_space(space) == self.model.action_space:
            return
        if self.codebook is not None:
            raise ValueError(f"this policy picks one of {len(self.codebook)} drives (action space "
                             f"{self.model.action_space}); the env's action space is {space}: build it with "
                             f"action_codebook={str(self.env_kwargs['action_codebook'])!r} (policy.make_env() does)")
        raise ValueError(f"this policy acts in {self.model.action_space}, the env in {space}: build the env with "
                         "policy.make_env()")

    def play(self, env=None, periods: int = 30, seed: int = 0, **overrides) -> np.ndarray:
        """Play ``periods`` periods in ``env`` (default ``make_env(max_periods=periods, **overrides)``,
        an episode as long as the run, as ``mdr-drive evaluate`` plays it), reset with ``seed``; returns
        the mean velocity of each period (periods,) (m/s)."""
        env = self.make_env(**{"max_periods": periods, **overrides}) if env is None else env
        self.check_env(env)
        self.reset()
        obs, _ = env.reset(seed=seed)
        velocities = []
        for _ in range(periods):
            obs, _, _, _, info = env.step(self.predict(obs))
            velocities.append(info["mean_velocity"])
        return np.array(velocities)


@dataclass(frozen=True)
class ObsNormalization:
    """VecNormalize's observation normalisation with fixed statistics (``obs -> float32``).

    Attributes:
        mean, var: the running mean and variance of each observation entry.
        clip_obs: normalised entries are clipped to [-clip_obs, clip_obs].
        epsilon: added to the variance before its square root.
    """

    mean: np.ndarray
    var: np.ndarray
    clip_obs: float
    epsilon: float

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.clip((obs - self.mean) / np.sqrt(self.var + self.epsilon), -self.clip_obs,
                       self.clip_obs).astype(np.float32)

    @classmethod
    def of_state(cls, state: NormalizationState) -> "ObsNormalization":
        """The observation normalisation of a saved VecNormalize state."""
        return cls(state.obs_mean, state.obs_var, state.clip_obs, state.epsilon)

    @classmethod
    def of_folder(cls, folder: str | Path, trust_pickle: bool = False) -> "ObsNormalization | None":
        """The normalisation of the policy in ``folder``: its ``vecnormalize.npz``; with
        ``trust_pickle`` and no such file, its ``vecnormalize.pkl`` (a pickle, which runs code when
        read); None if it has neither (a policy trained without normalisation)."""
        folder = Path(folder)
        if (folder / NORMALIZATION_FILE).exists():
            return cls.of_state(NormalizationState.load(folder / NORMALIZATION_FILE))
        if not (folder / "vecnormalize.pkl").exists():
            return None
        if not trust_pickle:
            raise ValueError(f"{folder} has vecnormalize.pkl but no {NORMALIZATION_FILE}: a pickle runs code when it is "
                             "read, so it is not read; if you trust where the folder came from, load it with "
                             "load_policy(folder, trust_pickle=True) (mdr-drive evaluate --trust-pickle)")
        import pickle

        with open(folder / "vecnormalize.pkl", "rb") as f:
            return cls.of_state(NormalizationState.of(pickle.load(f)))


def read_run(folder: str | Path) -> dict:
    """A policy folder's run.json (``{}`` if it has none); ``ValueError`` if it is not JSON."""
    path = Path(folder) / "run.json"
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text())
    except ValueError as e:
        raise ValueError(f"{path} is not a run record (JSON: {e})") from None


def make_env_of(folder: str | Path, run: dict, **overrides):
    """The gymnasium env a policy folder's run.json describes (``Policy.make_env``)."""
    import gymnasium as gym

    import mdr_drive_env  # noqa: F401  registers the envs

    kwargs = run_env_kwargs(folder, run)
    if overrides.get("cargo_mass") is not None:
        kwargs.pop("load_ratio", None)
    return gym.make(run.get("env_id", "MDRDrive-v0"), **{**kwargs, **overrides})


def load_policy(folder: str | Path, trust_pickle: bool = False) -> Policy:
    """The policy in ``folder`` (``model.zip``, its ``vecnormalize.npz``, ``run.json``), from any
    working directory, without unpickling anything (``sb3_files.read_model``). ``trust_pickle``
    reads a folder that has only SB3's ``vecnormalize.pkl`` (a pickle runs code when read: only for
    a folder from a source you trust)."""
    folder = package_path(folder).resolve()
    if not (folder / "model.zip").is_file():
        raise ValueError(f"{folder} is not a policy folder (no model.zip)")
    run = read_run(folder)
    normalize = ObsNormalization.of_folder(folder, trust_pickle)  # refused before anything else is read
    env = make_env_of(folder, run)
    algo = run.get("algo", "ppo")
    cycle = run.get("hyperparameters", {}).get("action_cycle", 1) == 2
    model = read_model(folder / "model.zip", sb3_class(algo), env.observation_space,
                       cycle_space(env.action_space) if cycle else env.action_space, run.get("hyperparameters"),
                       policy=policy_name(algo))
    return Policy(model, normalize, load_action_codebook(run_env_kwargs(folder, run).get("action_codebook")), run,
                  folder)


def policy_label(path: str | Path) -> str:
    """How plots and tables name a policy: "shipped policy" for the shipped one, else what its run.json
    says (algorithm and seed) or its folder's name, never a path of the machine that trained it."""
    path = Path(path)
    if path.resolve() == PRETRAINED.resolve():
        return "shipped policy"
    run = read_run(path)
    name = path.name if path.name != "policy" else f"{path.parent.name}/{path.name}"  # a recipe's DIR/policy
    if "distilled_from" in run or run.get("picks_from", {}).get("observation") == "told":  # mdr-drive recipe's
        return f"recipe policy ({name})"  # student (its seed is the fit's, not an RL run's)
    if "picks_from" in run:
        return f"sensor policy, {run.get('env_kwargs', {}).get('sensor_tier', 'encoder')} tier ({name})"
    if run:
        return f"{run.get('algo', 'policy').upper()} seed {run.get('seed', '?')} ({name})"
    return f"policy {name}"


def policy_files(folder: str | Path) -> tuple[str, ...]:
    """The files a policy in ``folder`` is: ``FILES``, its action table if its run.json names one, and
    a sensor policy's estimator if it has one (``student.estimator.ESTIMATOR_FILE``)."""
    return (FILES + ((CODEBOOK_FILE,) if read_run(folder).get("env_kwargs", {}).get("action_codebook") else ())
            + ((ESTIMATOR_FILE,) if (Path(folder) / ESTIMATOR_FILE).is_file() else ()))


def save_normalization(venv, folder: str | Path) -> None:
    """A VecNormalize's statistics into ``folder``, atomically: ``vecnormalize.npz`` (numbers, what
    this package reads) and ``vecnormalize.pkl`` (what plain SB3 reads)."""
    from mdr_drive_env.files import atomic_path

    NormalizationState.of(venv).save(Path(folder) / NORMALIZATION_FILE)
    with atomic_path(Path(folder) / "vecnormalize.pkl") as tmp:
        venv.save(str(tmp))


def save_policy(out: str | Path, model, venv, record: dict, codebook: np.ndarray | None = None) -> None:
    """``model.zip``, ``vecnormalize.npz`` and ``vecnormalize.pkl`` (``venv``'s statistics; none when
    ``venv`` is None, a policy trained without normalisation) and ``run.json`` (``record``, last: it
    marks the set complete) into ``out``, each written atomically; a codebook policy's table too, as
    ``CODEBOOK_FILE``, which run.json's ``env_kwargs`` then name (``action_codebook``, relative to ``out``)."""
    from mdr_drive_env.files import atomic_path, write_text

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "model.zip") as tmp:
        model.save(tmp)
    if venv is not None:
        save_normalization(venv, out)
    if codebook is not None:
        with atomic_path(out / CODEBOOK_FILE) as tmp:
            with open(tmp, "wb") as f:
                np.save(f, np.asarray(codebook))
        record = {**record, "env_kwargs": {**record["env_kwargs"], "action_codebook": CODEBOOK_FILE}}
    write_text(out / "run.json", json.dumps(record, indent=2))


def same_weights(a: str | Path, b: str | Path) -> bool:
    """Whether the policies in folders ``a`` and ``b`` are the same network: equal tensors in their
    ``model.zip``'s ``policy.pth`` (read as tensors only), equal observation statistics and equal action
    tables."""
    import zipfile

    import torch

    def tensors(folder):
        with zipfile.ZipFile(Path(folder) / "model.zip") as z, z.open("policy.pth") as f:
            return torch.load(f, map_location="cpu", weights_only=True)

    ta, tb = tensors(a), tensors(b)
    if ta.keys() != tb.keys() or not all(torch.equal(ta[k], tb[k]) for k in ta):
        return False
    sa, sb = (ObsNormalization.of_folder(f) for f in (a, b))
    if (sa is None) != (sb is None) or sa is not None and not (np.array_equal(sa.mean, sb.mean)
                                                               and np.array_equal(sa.var, sb.var)):
        return False
    tables = [Path(f) / CODEBOOK_FILE for f in (a, b)]
    if any(t.exists() for t in tables):
        return all(t.exists() for t in tables) and np.array_equal(np.load(tables[0]), np.load(tables[1]))
    return True


__all__ = ["ACTION_KEYS", "CODEBOOK_FILE", "ESTIMATOR_FILE", "FILES", "OBSERVATION_KEYS", "ObsNormalization", "PLAY_KEYS", "PRETRAINED", "Policy", "package_path",
           "SENSOR_PRETRAINED", "load_policy", "policy_files", "policy_label", "read_run", "run_env_kwargs",
           "cycle_space", "policy_name", "same_weights", "save_normalization", "save_policy", "sb3_class"]
