"""Stable-Baselines3 policy files read without running any code they hold.

SB3 saves a model as a zip whose ``data`` entry is JSON, except for the objects it cannot write as
JSON (the policy class, the spaces, the schedules, the last observation), which it cloudpickles; and
``VecNormalize.save`` pickles the whole wrapper. Unpickling a file runs whatever code it names, so a
policy folder from someone else could run anything when loaded. Here nothing is unpickled:

* ``read_model``: the zip is read with every serialised entry replaced (SB3's ``custom_objects``)
  by an object built here from the entry's readable description, the policy's run record and the
  env it acts in; the network's tensors are read by ``torch.load(weights_only=True)``. An entry this
  module does not know how to rebuild is refused, never deserialised.
* ``NormalizationState``: the VecNormalize statistics in ``vecnormalize.npz`` (numbers only, read
  with ``allow_pickle=False``), beside the ``vecnormalize.pkl`` that plain SB3 users load.

Pickle files (``vecnormalize.pkl``, a task store from before) and SB3's own ``PPO.load`` execute
code: load them only from a source you trust.
"""

from __future__ import annotations

import json
import re
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

#: The numbers-only twin of ``vecnormalize.pkl`` in a policy folder.
NORMALIZATION_FILE = "vecnormalize.npz"
#: Activation functions a policy's ``policy_kwargs`` may name (torch.nn class names).
ACTIVATIONS = ("ReLU", "Tanh", "ELU", "LeakyReLU", "GELU", "SiLU", "Sigmoid")
#: Serialised entries of a saved model that are rebuilt as None (SB3 recreates them when it
#: trains: the last observation, episode buffers, the replay or rollout buffer class).
REBUILT_AS_NONE = ("_last_obs", "_last_lstm_states", "_last_episode_starts", "_last_original_obs", "ep_info_buffer",
                   "ep_success_buffer",
                   "rollout_buffer_class", "replay_buffer_class", "action_noise")


@dataclass(frozen=True)
class NormalizationState:
    """A ``VecNormalize``'s statistics and settings, numbers only.

    Attributes:
        obs_mean, obs_var, obs_count: running statistics of the observations.
        ret_mean, ret_var, ret_count: running statistics of the discounted returns.
        clip_obs, clip_reward: bounds of the normalised observations and rewards.
        epsilon: added to a variance before its square root.
        gamma: the discount of the return statistics.
        norm_obs, norm_reward: which of the two it normalises.
    """

    obs_mean: np.ndarray
    obs_var: np.ndarray
    obs_count: float
    ret_mean: float
    ret_var: float
    ret_count: float
    clip_obs: float
    clip_reward: float
    epsilon: float
    gamma: float
    norm_obs: bool
    norm_reward: bool

    @classmethod
    def of(cls, venv) -> "NormalizationState":
        """The state of a live SB3 ``VecNormalize``."""
        return cls(np.asarray(venv.obs_rms.mean, dtype=np.float64), np.asarray(venv.obs_rms.var, dtype=np.float64),
                   float(venv.obs_rms.count), float(np.asarray(venv.ret_rms.mean)), float(np.asarray(venv.ret_rms.var)),
                   float(venv.ret_rms.count), float(venv.clip_obs), float(venv.clip_reward), float(venv.epsilon),
                   float(venv.gamma), bool(venv.norm_obs), bool(venv.norm_reward))

    def save(self, path: str | Path) -> None:
        """Write the state to ``path`` (``.npz``, atomically)."""
        from mdr_drive_env.files import atomic_path

        with atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, **{key: np.asarray(value) for key, value in asdict(self).items()})

    @classmethod
    def load(cls, path: str | Path) -> "NormalizationState":
        """The state in ``path``; ``ValueError`` naming the file if it is not one."""
        try:
            with np.load(path, allow_pickle=False) as f:
                values = {key: f[key] for key in f.files}
            floats = {key: float(values.pop(key)) for key in ("obs_count", "ret_mean", "ret_var", "ret_count",
                                                              "clip_obs", "clip_reward", "epsilon", "gamma")}
            flags = {key: bool(values.pop(key)) for key in ("norm_obs", "norm_reward")}
            state = cls(obs_mean=values.pop("obs_mean").astype(np.float64),
                        obs_var=values.pop("obs_var").astype(np.float64), **floats, **flags)
        except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as e:
            raise ValueError(f"{path} is not a VecNormalize state (.npz of numbers): {type(e).__name__}: {e}") from None
        if values or state.obs_mean.shape != state.obs_var.shape or state.obs_mean.ndim != 1:
            raise ValueError(f"{path} is not a VecNormalize state: unexpected entries or shapes")
        return state

    def apply(self, venv) -> None:
        """Put the state into a live SB3 ``VecNormalize`` (built over the env it normalises)."""
        if venv.obs_rms.mean.shape != self.obs_mean.shape:
            raise ValueError(f"the saved observation statistics have shape {self.obs_mean.shape}, the env's "
                             f"observations {venv.obs_rms.mean.shape}")
        venv.obs_rms.mean, venv.obs_rms.var, venv.obs_rms.count = self.obs_mean.copy(), self.obs_var.copy(), self.obs_count
        venv.ret_rms.mean, venv.ret_rms.var, venv.ret_rms.count = self.ret_mean, self.ret_var, self.ret_count
        venv.clip_obs, venv.clip_reward, venv.epsilon, venv.gamma = self.clip_obs, self.clip_reward, self.epsilon, \
            self.gamma
        venv.norm_obs, venv.norm_reward = self.norm_obs, self.norm_reward


def _readable(entry: dict) -> dict:
    """A serialised entry's readable description (SB3 writes its attributes as text beside the pickle)."""
    return {key: value for key, value in entry.items() if key != ":serialized:"}


def _activation(text: str):
    import torch

    name = re.sub(r"^<class '(?:[\w.]*\.)?(\w+)'>$", r"\1", str(text))
    if name not in ACTIVATIONS:
        raise ValueError(f"policy_kwargs names the activation {text!r}, not one of {list(ACTIVATIONS)}")
    return getattr(torch.nn, name)


def _policy_kwargs(entry) -> dict:
    """``policy_kwargs`` from its readable description: plain values, the activation by name."""
    kwargs = _readable(entry) if isinstance(entry, dict) and ":serialized:" in entry else dict(entry)
    kwargs.pop(":type:", None)
    if "activation_fn" in kwargs:
        kwargs["activation_fn"] = _activation(kwargs["activation_fn"])
    for key, value in kwargs.items():
        if isinstance(value, str) and value.startswith("<"):
            raise ValueError(f"policy_kwargs[{key!r}] is an object ({value}) this loader does not rebuild")
    return kwargs


def _schedule_value(entry, fallback):
    """The value of a constant schedule from its readable description (``ConstantSchedule(val=0.1)``),
    else ``fallback``."""
    found = re.search(r"ConstantSchedule\(val=([-+0-9.eE]+)\)", json.dumps(entry))
    return float(found.group(1)) if found else fallback


def read_model(path: str | Path, algo_class, observation_space, action_space, hyperparameters: dict | None = None,
               env=None, device: str = "cpu", policy: str = "MlpPolicy", **kwargs):
    """``algo_class.load(path)`` with every serialised entry of the zip rebuilt, none deserialised:
    the spaces are the ones given (those of the env the policy acts in; refused if the saved
    description disagrees), the clip range a constant read from the description or
    ``hyperparameters`` (the learning rate's schedule SB3 rebuilds from its plain value), the policy
    class the algorithm's ``policy`` (an alias: ``MlpPolicy``, RecurrentPPO's ``MlpLstmPolicy``). ``env`` and ``kwargs`` as
    SB3's ``load`` takes them. ``ValueError`` for a file that is not a model or holds an entry that
    cannot be rebuilt."""
    hyper = dict(hyperparameters or {})
    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as e:
        raise ValueError(f"{path} is not a Stable-Baselines3 model (a zip with a JSON 'data' entry): {e}") from None
    custom = {}
    for key, entry in data.items():
        if not (isinstance(entry, dict) and ":serialized:" in entry):
            continue
        if key == "policy_class":
            custom[key] = algo_class.policy_aliases[policy]
        elif key == "policy_kwargs":
            custom[key] = _policy_kwargs(entry)
        elif key in ("observation_space", "action_space"):
            space = observation_space if key == "observation_space" else action_space
            described = _readable(entry)
            shape = described.get("_shape")
            if shape is not None and list(shape) != list(space.shape) or (
                    "n" in described and int(described["n"]) != int(getattr(space, "n", -1))):
                raise ValueError(f"{path}: its {key} ({described.get(':type:')}, shape {shape}, "
                                 f"n {described.get('n')}) is not the env's {space}")
            custom[key] = space
        elif key == "lr_schedule":  # SB3 rebuilds it from ``learning_rate`` (plain JSON)
            custom[key] = None
        elif key in ("clip_range", "clip_range_vf"):
            custom[key] = _schedule_value(entry, hyper.get(key, 0.2 if key == "clip_range" else None))
        elif key == "train_freq":
            custom[key] = hyper.get("train_freq", 1)
        elif key in REBUILT_AS_NONE:
            custom[key] = None
        else:
            raise ValueError(f"{path}: its entry {key!r} is a serialised object this loader does not rebuild "
                             "(it would run code to read it)")
    if "policy_kwargs" in data and not isinstance(data["policy_kwargs"], dict):
        raise ValueError(f"{path}: its policy_kwargs are not a mapping")
    if "policy_kwargs" in data and "policy_kwargs" not in custom:
        custom["policy_kwargs"] = _policy_kwargs(data["policy_kwargs"])
    try:
        return algo_class.load(path, env=env, device=device, custom_objects=custom, **kwargs)
    except (TypeError, KeyError, RuntimeError, AssertionError, AttributeError) as e:
        raise ValueError(f"{path} is not a {algo_class.__name__} model as its run record says "
                         f"({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''})") from None


__all__ = ["NORMALIZATION_FILE", "NormalizationState", "read_model"]
