"""Stable-Baselines3 hyperparameters for ``mdr-drive train``: read from an RL-Zoo-style YAML keyed by
the env id, replaced on the command line (``--hyperparams KEY:VALUE``), and checked before any work
(a bad value is a ``ValueError`` naming the key, the value and the allowed range).
"""

from __future__ import annotations

import argparse
import inspect
import math
from pathlib import Path
from typing import Any

import yaml

from mdr_drive_env import ENV_ID

from ..policy import sb3_class
from ..yaml_config import read_yaml

CONFIG_DIR = Path(__file__).parents[1] / "configs"
#: Config keys of ``mdr-drive train`` itself: recorded in run.json, not passed to SB3.
#: How a new run's policy starts: as SB3 builds it, or its mean action at the paper's trapezoid.
WARM_STARTS = ("none", "trapezoid")
NOT_SB3_KEYS = ("warm_start", "action_noise_std", "reward_baseline", "action_cycle", "load_curriculum")
#: Keys every algorithm takes besides its constructor's (the number of envs, normalisation, the
#: RL Zoo's step budget and policy name, the warm start, the exploration noise of an off-policy
#: algorithm: Gaussian, its standard deviation in the action box's units; the training env's reward
#: baseline, ``vec_env.REWARD_BASELINES``; periods one action sets, 1 or 2: ``vec_env.CycleActions``;
#: the fraction of the run over which the load range widens, ``train.curriculum``).
EXTRA_KEYS = ("n_envs", "normalize", "n_timesteps", "policy", "warm_start", "action_noise_std", "reward_baseline",
              "action_cycle", "load_curriculum")
#: Set by ``mdr-drive train`` itself, never by a config or --hyperparams.
SET_HERE = ("self", "policy", "env", "_init_setup_model", "device", "seed", "tensorboard_log", "verbose",
            "action_noise")
#: Numeric hyperparameters and their allowed ranges: (low, high, integer, low open).
NUMERIC = {
    "n_envs": (1, 4096, True, False), "n_steps": (2, math.inf, True, False), "batch_size": (2, math.inf, True, False),
    "n_epochs": (1, math.inf, True, False), "gamma": (0.0, 1.0, False, True), "gae_lambda": (0.0, 1.0, False, False),
    "learning_rate": (0.0, 1.0, False, True), "clip_range": (0.0, math.inf, False, True),
    "ent_coef": (0.0, math.inf, False, False), "vf_coef": (0.0, math.inf, False, False),
    "max_grad_norm": (0.0, math.inf, False, True), "buffer_size": (1, math.inf, True, False),
    "learning_starts": (0, math.inf, True, False), "tau": (0.0, 1.0, False, True),
    "train_freq": (1, math.inf, True, False), "gradient_steps": (1, math.inf, True, False),
    "n_timesteps": (1, math.inf, False, False), "action_noise_std": (0.0, 2.0, False, False),
    "load_curriculum": (0.0, 1.0, False, False),
}


def load_config(algo: str, path: str | Path | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """(hyperparameters, env_kwargs) from an RL-Zoo-style YAML file: the env id's block, whose
    ``env_kwargs`` (the training domain, as the RL Zoo reads them too) are returned apart; the
    top-level ``warm_start`` (not an RL Zoo key) is returned among the hyperparameters."""
    path = Path(path) if path else CONFIG_DIR / f"{algo}.yaml"
    data = read_yaml(path)
    if not isinstance(data.get(ENV_ID), dict):
        raise ValueError(f"{path}: no '{ENV_ID}' section of hyperparameters")
    unknown = sorted(set(data) - {ENV_ID, "warm_start"})
    if unknown:
        raise ValueError(f"{path}: unknown top-level key(s) {unknown}: hyperparameters and env_kwargs go in the "
                         f"'{ENV_ID}' block, beside it only warm_start")
    hyper = dict(data[ENV_ID])
    env_kwargs = hyper.pop("env_kwargs", None) or {}
    if not isinstance(env_kwargs, dict):
        raise ValueError(f"{path}: {ENV_ID}.env_kwargs must be a mapping of {ENV_ID} keywords")
    return {**hyper, "warm_start": data.get("warm_start", "none")}, dict(env_kwargs)


def known_keys(algo: str) -> list[str]:
    """The hyperparameters of ``algo`` a config or ``--hyperparams`` may set."""
    params = set(inspect.signature(sb3_class(algo).__init__).parameters)
    extra = set(EXTRA_KEYS) - (set() if "action_noise" in params else {"action_noise_std"})  # off-policy only
    return sorted(params - set(SET_HERE) | extra)


def check_hyperparameters(algo: str, hyper: dict[str, Any], source: str) -> None:
    """``ValueError`` naming ``source`` and the key for a hyperparameter ``algo`` does not take or a
    numeric one outside its range (``NUMERIC``)."""
    known = known_keys(algo)
    for key, value in hyper.items():
        if key not in known:
            raise ValueError(f"{source}: {key!r} is not a {algo.upper()} hyperparameter this command sets (seed, device "
                             f"and logging have their own); one of {known}")
        if key == "reward_baseline":
            from ..vec_env import REWARD_BASELINES

            if value not in REWARD_BASELINES:
                raise ValueError(f"{source}: reward_baseline={value!r} is not one of {list(REWARD_BASELINES)}")
        if key == "action_cycle" and value not in (1, 2):
            raise ValueError(f"{source}: action_cycle={value!r} is not one of [1, 2]")
        if key not in NUMERIC or (key == "ent_coef" and is_auto_entropy(value)):
            continue
        low, high, integer, low_open = NUMERIC[key]
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        ok = ok and (not integer or float(value).is_integer())
        ok = ok and (low < value if low_open else low <= value) and value <= high
        if not ok:
            kind = "an integer" if integer else "a number"
            bracket = "(" if low_open else "["
            also = " (or SAC's 'auto' / 'auto_<initial value>')" if key == "ent_coef" else ""
            raise ValueError(f"{source}: {key}={value!r} must be {kind} in the allowed range {bracket}{low}, {high}]{also}")


def is_auto_entropy(value) -> bool:
    """True for SB3's automatically tuned entropy weight: ``"auto"`` or ``"auto_<initial value>"``
    with a positive initial value (SAC)."""
    if not isinstance(value, str) or not (value == "auto" or value.startswith("auto_")):
        return False
    try:
        return value == "auto" or float(value[5:]) > 0.0
    except ValueError:
        return False


def key_value(text: str) -> tuple[str, Any]:
    """argparse type: ``KEY:VALUE`` as (key, value): a number as a number (``1e-5``, ``512``), anything
    else read as YAML (``[64, 64]``, ``true``)."""
    key, sep, value = text.partition(":")
    if not sep or not key.isidentifier():
        raise argparse.ArgumentTypeError(f"{text!r} is not KEY:VALUE (e.g. learning_rate:1e-5)")
    for number in (int, float):
        try:
            return key, number(value)
        except ValueError:
            pass
    try:
        return key, yaml.safe_load(value)
    except yaml.YAMLError:
        raise argparse.ArgumentTypeError(f"{text!r}: {value!r} is not a YAML value") from None


__all__ = ["CONFIG_DIR", "NOT_SB3_KEYS", "WARM_STARTS", "NUMERIC", "check_hyperparameters", "key_value", "known_keys", "load_config"]
