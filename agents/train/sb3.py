"""Train a waveform policy on MDRDrive-v0 with Stable-Baselines3 from scratch (``train``; its command
line is ``mdr-drive train``, ``mdr_drive_agents.commands.train``).

    mdr-drive train --algo ppo --k 0 0.6 --cargo-mass 0 1.0 --steps 1000000 --seed 0 --out runs/ppo_s0
    mdr-drive train --resume runs/ppo_s0 --steps 500000      # continue, same step counter

Writes into ``--out``: ``model.zip``, ``vecnormalize.pkl`` (normalisation statistics, needed to run
the policy), ``checkpoints/``, ``best/`` (best evaluation on held-out points, with its own
``vecnormalize.pkl``), ``tb/`` (TensorBoard), ``evaluations.npz`` and ``run.json`` (command,
versions, seed, steps, wall time, steps/s). Ctrl-C or SIGTERM stops training, saves all of these and
marks the run ``interrupted`` in run.json; ``--resume`` continues it. An existing run is never
overwritten without ``--force``. torch uses one thread unless ``--torch-threads`` says otherwise
(the policies are small MLPs; on a busy 2-core machine 2 threads made PPO 10-30 times slower).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mdr_drive_env import ENV_ID

from ..policy import run_env_kwargs, sb3_class
from ..protocol import trapezoid_action
from ..run_record import versions
from ..yaml_config import read_yaml

CONFIG_DIR = Path(__file__).parents[1] / "configs"
#: Config keys of this module itself: recorded in run.json, not passed to SB3.
NOT_SB3_KEYS = ("warm_start",)
#: (k, cargo mass in kg) points off the benchmark grid, for periodic evaluation during training.
HELD_OUT_POINTS = ((0.05, 0.4), (0.15, 0.12), (0.25, 0.04), (0.45, 0.0), (0.1, 0.25))


def load_config(algo: str, path: str | Path | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """(hyperparameters, env_kwargs) from an RL-Zoo-style YAML file; the top-level ``warm_start`` (not
    an RL Zoo key) is returned among the hyperparameters."""
    path = Path(path) if path else CONFIG_DIR / f"{algo}.yaml"
    data = read_yaml(path)
    if ENV_ID not in data:
        raise ValueError(f"{path}: no '{ENV_ID}' section")
    return {**data[ENV_ID], "warm_start": data.get("warm_start", "none")}, dict(data.get("env_kwargs", {}))


def _range(values: list[float] | None, default):
    if values is None:
        return default
    if len(values) not in (1, 2):
        raise ValueError(f"expected one value or a (low, high) pair, got {values}")
    return float(values[0]) if len(values) == 1 else (float(values[0]), float(values[1]))


def make_train_env(n_envs: int, seed: int, env_kwargs: dict[str, Any]):
    """The training env with a monitor: the batched vector env, or, for the sensor observation and
    load steps (which it does not step), ``n_envs`` single envs in a ``DummyVecEnv``."""
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    from ..vec_env import BatchedVecEnv

    if env_kwargs.get("observation", "full") != "full" or env_kwargs.get("load_step_period") is not None:
        import gymnasium as gym

        import mdr_drive_env  # noqa: F401  registers the env

        venv = DummyVecEnv([lambda: gym.make(ENV_ID, **env_kwargs) for _ in range(n_envs)])
        venv.seed(seed)
        return VecMonitor(venv)
    return VecMonitor(BatchedVecEnv(n_envs, seed=seed, **env_kwargs))


def make_eval_env(env_kwargs: dict[str, Any], points=HELD_OUT_POINTS):
    """One single env per held-out (k, cargo mass) point (fixed per env)."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    import mdr_drive_env  # noqa: F401  registers the env

    kw = {key: v for key, v in env_kwargs.items() if key not in ("k", "cargo_mass", "load_ratio")}
    return VecMonitor(DummyVecEnv([lambda k=k, m=m: gym.make(ENV_ID, k=k, cargo_mass=m, **kw) for k, m in points]))


def warm_start_at(model, action: np.ndarray) -> None:
    """Initialise the policy's mean action at ``action`` (the last layer's weights scaled down).

    PPO: the Gaussian mean is the action (clipped to the box by SB3). SAC: the mean is squashed by
    tanh, so the bias is ``atanh`` of the action kept inside (-0.95, 0.95).
    """
    import torch

    net = model.policy.action_net if hasattr(model.policy, "action_net") else model.policy.actor.mu
    a = np.asarray(action, dtype=np.float32)
    if not hasattr(model.policy, "action_net"):
        a = np.arctanh(np.clip(a, -0.95, 0.95))
    with torch.no_grad():
        net.weight.mul_(0.01)
        net.bias.copy_(torch.as_tensor(a))


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


def _save_normalisation_callback(path: Path):
    """An SB3 callback (for EvalCallback's ``callback_on_new_best``) that saves the training env's
    VecNormalize statistics beside the best model, so ``best/`` loads like the run's own folder."""
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecNormalize

    class SaveNormalisation(BaseCallback):
        def _on_step(self) -> bool:
            env = self.model.get_env()
            if isinstance(env, VecNormalize):
                path.parent.mkdir(parents=True, exist_ok=True)
                env.save(str(path))
            return True

    return SaveNormalisation()


def actor_parameters(model) -> list:
    """The parameters that set a policy's actions (PPO: the policy net, the action net and the log
    std; SAC: the actor): what ``frozen_actor`` holds still while the critic learns."""
    policy = model.policy
    if hasattr(policy, "action_net"):
        return [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters(), policy.log_std]
    return list(model.actor.parameters())


class frozen_actor:
    """Context in which ``model.learn`` trains only the critic: the actor's parameters get no
    gradient (Adam skips them), so its actions stay as they are while the value function learns the
    returns of the policy as it plays."""

    def __init__(self, model):
        self.params = actor_parameters(model)

    def __enter__(self):
        self.flags = [p.requires_grad for p in self.params]
        for p in self.params:
            p.requires_grad_(False)
        return self

    def __exit__(self, *exc):
        for p, flag in zip(self.params, self.flags):
            p.requires_grad_(flag)
        return False


class _Interrupted(Exception):
    """SIGTERM during training (handled like Ctrl-C)."""


def rounded_steps(algo: str, steps: int, n_envs: int, hyper: dict[str, Any]) -> int:
    """The steps SB3 will actually run: PPO collects whole rollouts of ``n_steps * n_envs``."""
    if algo == "ppo":
        rollout = int(hyper.get("n_steps", 2048)) * n_envs
        return -(-steps // rollout) * rollout
    return steps


def train(algo: str = "ppo", steps: int | None = None, seed: int = 0, out: str | Path = "runs/ppo",
          n_envs: int | None = None, k=None, cargo_mass=None, load_ratio=None, config: str | Path | None = None,
          resume: str | Path | None = None, eval_freq: int = 20_000, checkpoint_freq: int = 100_000,
          warm_start: str | None = None, progress_bar: bool = True, verbose: int = 0, force: bool = False,
          torch_threads: int = 1, critic_warmup: int = 0, hyperparams: dict[str, Any] | None = None) -> dict[str, Any]:
    """Train (or resume) a policy; returns the run record also written to ``run.json``.

    ``critic_warmup`` steps (rounded as ``steps`` are) come first and train only the critic, the
    actor frozen (``frozen_actor``): a distilled or adapted policy has no trained value function,
    and PPO's first updates would otherwise follow a random critic's advantages. ``hyperparams``
    replace the config's (or, resuming, the run's) SB3 hyperparameters, as the RL Zoo's ``-params``.

    Refuses to train into a folder that holds a run unless ``resume`` names it or ``force`` is set.
    Ctrl-C or SIGTERM saves the model, its normalisation and run.json (``"interrupted": true``).
    """
    import inspect
    import signal

    import torch
    from stable_baselines3.common.callbacks import CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    for name, value in (("steps", steps), ("n_envs", n_envs), ("torch_threads", torch_threads)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1):
            raise ValueError(f"{name}={value!r} is outside the allowed range [1, inf)")
    if isinstance(critic_warmup, bool) or not isinstance(critic_warmup, (int, np.integer)) or critic_warmup < 0:
        raise ValueError(f"critic_warmup={critic_warmup!r} is outside the allowed range [0, inf)")
    out = Path(resume or out)
    run_file = out / "run.json"
    if not resume and not force and ((out / "run.json").exists() or (out / "model.zip").exists()):
        raise ValueError(f"{out} already holds a run: continue it with --resume {out}, or overwrite it with --force")
    previous = json.loads(run_file.read_text()) if resume else None
    if resume:
        algo, seed = previous["algo"], previous["seed"]
        hyper, env_kwargs = previous["hyperparameters"], run_env_kwargs(out, previous)
    else:
        sb3_class(algo)  # an unknown algo: ValueError
        hyper, env_kwargs = load_config(algo, config)
        env_kwargs["k"] = _range(k, env_kwargs.get("k", 0.2))
        if cargo_mass is not None:  # an explicit cargo mass replaces the config's load ratio
            env_kwargs.pop("load_ratio", None)
            env_kwargs["cargo_mass"] = _range(cargo_mass, None)
        if load_ratio is not None:
            env_kwargs["load_ratio"] = _range(load_ratio, None)
        if n_envs:
            hyper["n_envs"] = n_envs
    hyper = dict(hyper)
    overrides = dict(hyperparams or {})
    set_here = {"self", "policy", "env", "_init_setup_model", "device", "seed", "tensorboard_log", "verbose"}
    known = sorted(set(inspect.signature(sb3_class(algo).__init__).parameters) - set_here | {"n_envs"})
    for key in overrides:
        if key not in known:
            raise ValueError(f"hyperparams: {key!r} is not a {algo.upper()} hyperparameter this option sets (seed, "
                             f"device and logging have their own); one of {known}")
    if resume and "policy_kwargs" in overrides:
        raise ValueError("hyperparams: policy_kwargs cannot change when resuming (the network is the run's)")
    hyper.update(overrides)
    n = int(hyper.pop("n_envs", 8))
    total = int(steps if steps is not None else hyper.pop("n_timesteps", 1e6))
    hyper.pop("n_timesteps", None)
    hyper.pop("policy", None)
    normalize = hyper.pop("normalize", True)
    threads = int(torch_threads)
    torch.set_num_threads(threads)
    for option, asked in (("--steps", total), ("--critic-warmup", int(critic_warmup))):
        actual = rounded_steps(algo, asked, n, hyper)
        if asked and actual != asked:
            rollout = int(hyper.get("n_steps", 2048))
            print(f"train: PPO collects whole rollouts of n_steps x n_envs = {rollout} x {n} = {rollout * n} steps: "
                  f"{option} {asked} runs {actual} steps", file=sys.stderr)
    if not resume:
        hyper["warm_start"] = warm_start or hyper.get("warm_start") or "trapezoid"
    warm = hyper.get("warm_start", "none")
    if warm not in ("none", "trapezoid"):
        raise ValueError(f"warm_start={warm!r} is not one of ['none', 'trapezoid']")
    if warm == "trapezoid" and env_kwargs.get("action_codebook") is not None:
        raise ValueError("warm_start='trapezoid' sets a Box action; with action_codebook (Discrete actions) use "
                         "warm_start: none")
    out.mkdir(parents=True, exist_ok=True)  # after every check: a refused run leaves no empty folder
    venv = make_train_env(n, seed + (previous["resumes"] + 1) * 1000 if resume else seed, env_kwargs)
    eval_env = make_eval_env(env_kwargs)
    if resume:
        venv = VecNormalize.load(str(out / "vecnormalize.pkl"), venv)
        if {"distilled_from", "adapted_from"} & set(previous):
            # A distilled (or adapted) network was fitted on these observation statistics: updated by
            # the PPO rollouts, they shift its inputs (measured: 200k steps then left the shipped
            # policy below the trapezoid at 293 of 1,024 points, docs/ablations.md). Frozen, with the
            # reward statistics.
            venv.training = False
        model = sb3_class(algo).load(out / "model.zip", env=venv, device="cpu", tensorboard_log=str(out / "tb"),
                                 **{key: v for key, v in overrides.items() if key != "n_envs"})
    else:
        if normalize:
            venv = VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=hyper.get("gamma", 0.99))
        model = sb3_class(algo)("MlpPolicy", venv, seed=seed, device="cpu", tensorboard_log=str(out / "tb"),
                            verbose=verbose, **{key: v for key, v in hyper.items() if key not in NOT_SB3_KEYS})
        if warm == "trapezoid":
            warm_start_at(model, trapezoid_action())
    if normalize or resume:
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False)
    callbacks = [
        CheckpointCallback(max(checkpoint_freq // n, 1), str(out / "checkpoints"), name_prefix=algo,
                           save_vecnormalize=True),
        EvalCallback(eval_env, n_eval_episodes=len(HELD_OUT_POINTS), eval_freq=max(eval_freq // n, 1),
                     best_model_save_path=str(out / "best"), log_path=str(out), deterministic=True,
                     callback_on_new_best=_save_normalisation_callback(out / "best" / "vecnormalize.pkl")),
    ]
    start_steps = model.num_timesteps
    main_start = None if critic_warmup else start_steps  # the step the actor starts learning at
    t0 = time.perf_counter()

    def on_sigterm(signum, frame):
        raise _Interrupted

    interrupted = False
    old_handler = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        if critic_warmup:
            with frozen_actor(model):
                model.learn(int(critic_warmup), progress_bar=progress_bar, reset_num_timesteps=not resume,
                            tb_log_name=f"{algo}_critic_warmup")
            main_start = model.num_timesteps
        model.learn(total, callback=callbacks, progress_bar=progress_bar,
                    reset_num_timesteps=not (resume or critic_warmup), tb_log_name=algo)
    except (KeyboardInterrupt, _Interrupted):
        interrupted = True
        print(f"train: interrupted at step {model.num_timesteps}; saved, continue with --resume {out}", file=sys.stderr)
    finally:
        signal.signal(signal.SIGTERM, old_handler)
    wall = time.perf_counter() - t0
    model.save(out / "model.zip")
    if isinstance(model.get_env(), VecNormalize):
        model.get_env().save(str(out / "vecnormalize.pkl"))
    record = {
        "algo": algo, "seed": seed, "env_id": previous.get("env_id", ENV_ID) if previous else ENV_ID,
        "env_kwargs": previous["env_kwargs"] if previous else env_kwargs,  # a codebook file stays relative
        "hyperparameters": {**hyper, "n_envs": n, "normalize": normalize},
        "command": " ".join(sys.argv), "versions": versions(), "torch_threads": threads,
        "total_timesteps": int(model.num_timesteps), "steps_this_run": int(model.num_timesteps - start_steps),
        "critic_warmup_steps_this_run": int((model.num_timesteps if main_start is None else main_start) - start_steps),
        "wall_time_s": round(wall + (previous["wall_time_s"] if previous else 0.0), 3),
        "steps_per_s_this_run": round((model.num_timesteps - start_steps) / max(wall, 1e-9), 1),
        "resumes": (previous["resumes"] + 1) if previous else 0,
        "held_out_points": HELD_OUT_POINTS,
        "interrupted": interrupted,
    }
    run_file.write_text(json.dumps(record, indent=2))
    return record
