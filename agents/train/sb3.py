"""Train a waveform policy on MDRDrive-v0 with Stable-Baselines3 from scratch, or continue one
(``train``; its command line is ``mdr-drive train``, ``mdr_drive_agents.commands.train``).

    mdr-drive train --algo ppo --k 0 0.6 --cargo-mass 0 1.0 --steps 1000000 --seed 0 --out runs/ppo_s0
    mdr-drive train --resume runs/ppo_s0                     # finish the run's own 1,000,000 steps
    mdr-drive train --resume runs/ppo_s0 --steps 2000000     # a new total, said in one line

Writes into ``--out``: ``model.zip``, ``vecnormalize.npz`` and ``vecnormalize.pkl`` (normalisation
statistics, needed to run the policy), ``checkpoints/``, ``best/`` (best evaluation on held-out
points, with its own statistics), ``tb/`` (TensorBoard), ``evaluations.npz`` and ``run.json``
(command, versions, seed, steps, wall time, steps/s). Every file is written atomically and
``run.json`` last, so a run killed at any moment keeps its last good model. Ctrl-C or SIGTERM stops
training, saves all of these and marks the run ``interrupted``; ``--resume`` continues it to its
total. One command at a time writes a folder (``RunLock``); an existing run is never overwritten
without ``--force``. Resuming reads nothing that runs code (``sb3_files``). torch uses one thread
unless ``--torch-threads`` says otherwise (the policies are small MLPs; on a busy 2-core machine 2
threads made PPO 10-30 times slower).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from mdr_drive_env import ENV_ID
from mdr_drive_env.files import remove_temporary

from ..policy import policy_name, run_env_kwargs, save_normalization, save_policy, sb3_class
from ..protocol import trapezoid_action
from ..run_record import RunLock, policy_record
from ..sb3_files import NORMALIZATION_FILE, NormalizationState, read_model
from .hyperparameters import NOT_SB3_KEYS, WARM_STARTS, check_hyperparameters, key_value, load_config  # noqa: F401

#: (k, cargo mass in kg) points off the benchmark grid, for periodic evaluation during training.
HELD_OUT_POINTS = ((0.05, 0.4), (0.15, 0.12), (0.25, 0.04), (0.45, 0.0), (0.1, 0.25))
#: run.json keys that say where a policy came from: a continued run keeps them.
PROVENANCE_KEYS = ("distilled_from", "adapted_from", "picks_from")


def _range(values: list[float] | None, default):
    if values is None:
        return default
    if len(values) not in (1, 2):
        raise ValueError(f"expected one value or a (low, high) pair, got {values}")
    return float(values[0]) if len(values) == 1 else (float(values[0]), float(values[1]))


def make_train_env(n_envs: int, seed: int, env_kwargs: dict[str, Any], reward_baseline: str = "none",
                   action_cycle: int = 1):
    """The training env with a monitor: the batched vector env (its rewards relative to the trapezoid's
    with ``reward_baseline="trapezoid"``, its actions two-period cycles with ``action_cycle=2``), or,
    for the sensor observation and load steps (which it does not step), ``n_envs`` single envs in a
    ``DummyVecEnv``."""
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    from ..vec_env import BatchedVecEnv, CycleActions

    if env_kwargs.get("observation", "full") != "full" or env_kwargs.get("load_step_period") is not None:
        if reward_baseline != "none" or action_cycle != 1:
            raise ValueError("reward_baseline and action_cycle need the batched env: the full observation without "
                             "load steps")
        import gymnasium as gym

        import mdr_drive_env  # noqa: F401  registers the env

        venv = DummyVecEnv([lambda: gym.make(ENV_ID, **env_kwargs) for _ in range(n_envs)])
        venv.seed(seed)
        return VecMonitor(venv)
    venv = BatchedVecEnv(n_envs, seed=seed, reward_baseline=reward_baseline, **env_kwargs)
    return VecMonitor(CycleActions(venv) if action_cycle == 2 else venv)


def make_eval_env(env_kwargs: dict[str, Any], points=HELD_OUT_POINTS, action_cycle: int = 1):
    """One single env per held-out (k, cargo mass) point (fixed per env), with two-period cycle actions
    if ``action_cycle`` is 2."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    import mdr_drive_env  # noqa: F401  registers the env

    from ..vec_env import CycleActions

    kw = {key: v for key, v in env_kwargs.items() if key not in ("k", "cargo_mass", "load_ratio")}
    venv = DummyVecEnv([lambda k=k, m=m: gym.make(ENV_ID, k=k, cargo_mass=m, **kw) for k, m in points])
    return VecMonitor(CycleActions(venv) if action_cycle == 2 else venv)


def warm_start_at(model, action: np.ndarray) -> None:
    """Initialise the policy's mean action at ``action`` (the last layer's weights scaled down).

    PPO (and RecurrentPPO): the Gaussian mean is the action (clipped to the box by SB3). SAC and TD3:
    the mean is squashed by tanh, so the bias is ``atanh`` of the action kept inside (-0.95, 0.95).
    """
    import torch

    squashed = not hasattr(model.policy, "action_net")
    net = model.policy.action_net if not squashed else model.policy.actor.mu
    if isinstance(net, torch.nn.Sequential):  # TD3: the actor's last linear layer, then tanh
        net = [layer for layer in net if isinstance(layer, torch.nn.Linear)][-1]
    a = np.asarray(action, dtype=np.float32)
    if squashed:
        a = np.arctanh(np.clip(a, -0.95, 0.95))
    with torch.no_grad():
        net.weight.mul_(0.01)
        net.bias.copy_(torch.as_tensor(a))


def _save_normalisation_callback(folder: Path):
    """An SB3 callback (for EvalCallback's ``callback_on_new_best``) that saves the training env's
    VecNormalize statistics beside the best model, so ``best/`` loads like the run's own folder."""
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecNormalize

    class SaveNormalisation(BaseCallback):
        def _on_step(self) -> bool:
            env = self.model.get_env()
            if isinstance(env, VecNormalize):
                save_normalization(env, folder)
            return True

    return SaveNormalisation()


def actor_parameters(model) -> list:
    """The parameters that set a policy's actions (PPO: the policy net, the action net and, for a
    Box action, the log std; SAC: the actor): what ``frozen_actor`` holds still while the critic
    learns."""
    import torch

    policy = model.policy
    if hasattr(policy, "action_net"):
        log_std = [policy.log_std] if isinstance(getattr(policy, "log_std", None), torch.nn.Parameter) else []
        return [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters(), *log_std]
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
    """The steps SB3 will actually run: PPO (and RecurrentPPO) collects whole rollouts of
    ``n_steps * n_envs``."""
    if algo in ("ppo", "recurrent_ppo"):
        rollout = int(hyper.get("n_steps", 2048)) * n_envs
        return -(-steps // rollout) * rollout
    return steps


def check_counts(**counts) -> None:
    """``ValueError`` naming a count that is not an integer >= its bound: (value, bound) by name."""
    for name, (value, low) in counts.items():
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low):
            raise ValueError(f"{name}={value!r} is outside the allowed range [{low}, inf)")


def new_run_settings(algo, config, k, cargo_mass, load_ratio, n_envs, env_overrides=None) -> tuple[dict, dict]:
    """(hyperparameters, env_kwargs) of a new run: the config's, with ``env_overrides`` and the
    command line's domain."""
    sb3_class(algo)  # an unknown algo: ValueError
    hyper, env_kwargs = load_config(algo, config)
    env_kwargs.update(env_overrides or {})
    env_kwargs["k"] = _range(k, env_kwargs.get("k", 0.2))
    if cargo_mass is not None:  # an explicit cargo mass replaces the config's load ratio
        env_kwargs.pop("load_ratio", None)
        env_kwargs["cargo_mass"] = _range(cargo_mass, None)
    if load_ratio is not None:
        env_kwargs["load_ratio"] = _range(load_ratio, None)
    if n_envs:
        hyper["n_envs"] = n_envs
    return hyper, env_kwargs


def load_run(out: Path, algo: str | None) -> dict:
    """The run record of the run to continue in ``out``; ``ValueError`` if there is none or if
    ``algo`` is given and is not the run's."""
    try:
        previous = json.loads((out / "run.json").read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"--resume {out}: no run record to continue (run.json: {type(e).__name__})") from None
    if algo is not None and algo != previous.get("algo"):
        raise ValueError(f"--algo {algo}: the run in {out} was trained with {previous.get('algo')!r}; a resumed run "
                         "keeps its algorithm (drop --algo, or train a new run)")
    return previous


def resumed_model(out: Path, previous: dict, venv, overrides: dict):
    """The model and its VecNormalize of the run in ``out``, read without running code, over ``venv``."""
    from stable_baselines3.common.vec_env import VecNormalize

    if (out / NORMALIZATION_FILE).exists():
        state = NormalizationState.load(out / NORMALIZATION_FILE)
        venv = VecNormalize(venv, norm_obs=state.norm_obs, norm_reward=state.norm_reward, gamma=state.gamma)
        state.apply(venv)
    elif (out / "vecnormalize.pkl").exists():
        raise ValueError(f"--resume {out}: it has vecnormalize.pkl but no {NORMALIZATION_FILE}; a pickle runs code "
                         "when read, so it is not read (a folder this package wrote has both)")
    algo = previous["algo"]
    model = read_model(out / "model.zip", sb3_class(algo), venv.observation_space, venv.action_space,
                       previous.get("hyperparameters"), env=venv, tensorboard_log=str(out / "tb"),
                       policy=policy_name(algo), **{key: v for key, v in overrides.items() if key not in NOT_SB3_KEYS
                                                    and key != "n_envs"})
    if previous.get("hyperparameters", {}).get("action_noise_std"):
        model.action_noise = action_noise(previous["hyperparameters"]["action_noise_std"], venv.action_space)
    return model


def action_noise(std: float, action_space):
    """TD3's (or SAC's) exploration noise: Gaussian, ``std`` in the action box's units (its half-width
    is 1)."""
    from stable_baselines3.common.noise import NormalActionNoise

    size = action_space.shape[0]
    return NormalActionNoise(np.zeros(size), np.full(size, float(std)))


def train(algo: str | None = None, steps: int | None = None, seed: int = 0, out: str | Path = "runs/ppo",
          n_envs: int | None = None, k=None, cargo_mass=None, load_ratio=None, config: str | Path | None = None,
          resume: str | Path | None = None, eval_freq: int = 20_000, checkpoint_freq: int = 100_000,
          warm_start: str | None = None, progress_bar: bool = True, verbose: int = 0, force: bool = False,
          torch_threads: int = 1, critic_warmup: int = 0, hyperparams: dict[str, Any] | None = None,
          callbacks: list | None = None, env_overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """Train (or resume) a policy; returns the run record also written to ``run.json``.

    ``steps`` is the run's total of environment steps (default: the config's ``n_timesteps``);
    ``resume`` continues the run in that folder to its total, or to ``steps`` if given (a new total,
    said in one line). ``critic_warmup`` steps (rounded as ``steps`` are) come first and train only
    the critic, the actor frozen (``frozen_actor``): a distilled or adapted policy has no trained
    value function, and PPO's first updates would otherwise follow a random critic's advantages.
    ``hyperparams`` replace the config's (or, resuming, the run's) SB3 hyperparameters, as the RL
    Zoo's ``-params``. ``callbacks``: further SB3 callbacks of the main training (after any critic
    warm-up), e.g. a learning curve's. ``env_overrides``: env keywords of a new run that replace the
    config's (``{"time_quantum": 5e-6}``).

    Refuses to train into a folder that holds a run unless ``resume`` names it or ``force`` is set,
    and a folder another command is writing (``RunLock``). Ctrl-C or SIGTERM saves the model, its
    normalisation and run.json (``"interrupted": true``).
    """
    check_counts(steps=(steps, 1), n_envs=(n_envs, 1), torch_threads=(torch_threads, 1),
                 critic_warmup=(critic_warmup, 0))
    out = Path(resume or out)
    if not resume and not force and (out / "run.json").exists():
        raise ValueError(f"{out} already holds a run: continue it with --resume {out}, or overwrite it with --force")
    if not resume and not force and (out / "model.zip").exists():  # run.json, written last, marks a whole set
        raise ValueError(f"{out} holds a model.zip without run.json (a save that did not finish): start the run "
                         "again with --force")
    previous = load_run(out, algo) if resume else None
    if previous:
        algo, seed = previous["algo"], previous["seed"]
        hyper, env_kwargs = dict(previous["hyperparameters"]), run_env_kwargs(out, previous)
    else:
        algo = algo or "ppo"
        hyper, env_kwargs = new_run_settings(algo, config, k, cargo_mass, load_ratio, n_envs, env_overrides)
    overrides = dict(hyperparams or {})
    check_hyperparameters(algo, overrides, "--hyperparams")
    if resume and "policy_kwargs" in overrides:
        raise ValueError("--hyperparams: policy_kwargs cannot change when resuming (the network is the run's)")
    hyper.update(overrides)
    check_hyperparameters(algo, {key: v for key, v in hyper.items() if key != "policy_kwargs"},
                          f"hyperparameters of {'the run' if resume else algo}")
    if previous is None:
        hyper["warm_start"] = warm_start or hyper.get("warm_start") or "trapezoid"
        if hyper["warm_start"] not in WARM_STARTS:
            raise ValueError(f"warm_start={hyper['warm_start']!r} is not one of {list(WARM_STARTS)}")
        if hyper.get("action_cycle", 1) == 2 and env_kwargs.get("action_codebook") is not None:
            raise ValueError("action_cycle=2 plays two Box actions a step; with action_codebook use action_cycle: 1")
        if hyper["warm_start"] == "trapezoid" and env_kwargs.get("action_codebook") is not None:
            raise ValueError("warm_start='trapezoid' sets a Box action; with action_codebook (Discrete actions) use "
                             "warm_start: none")
    with RunLock(out):  # after every check: a refused run leaves no folder
        return _train(algo, steps, seed, out, hyper, env_kwargs, previous, overrides, eval_freq, checkpoint_freq,
                      progress_bar, verbose, torch_threads, critic_warmup, list(callbacks or ()))


def _train(algo, steps, seed, out, hyper, env_kwargs, previous, overrides, eval_freq, checkpoint_freq,
           progress_bar, verbose, torch_threads, critic_warmup, extra_callbacks) -> dict[str, Any]:
    import signal

    import torch
    from stable_baselines3.common.callbacks import CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    n = int(hyper.pop("n_envs", 8))
    config_total = hyper.pop("n_timesteps", 1e6)
    hyper.pop("policy", None)
    normalize = hyper.pop("normalize", True)
    threads = int(torch_threads)
    torch.set_num_threads(threads)
    warm = hyper.get("warm_start", "none")
    out.mkdir(parents=True, exist_ok=True)
    remove_temporary(out)  # files a killed save left behind
    cycle = int(hyper.get("action_cycle", 1))
    venv = make_train_env(n, seed + (previous["resumes"] + 1) * 1000 if previous else seed, env_kwargs,
                          hyper.get("reward_baseline", "none"), cycle)
    eval_env = make_eval_env(env_kwargs, action_cycle=cycle)
    if previous:
        model = resumed_model(out, previous, venv, overrides)
        if set(PROVENANCE_KEYS) & set(previous) and isinstance(model.get_env(), VecNormalize):
            # A distilled (or adapted) network was fitted on these observation statistics: updated by
            # the PPO rollouts, they shift its inputs (docs/ablations.md). Frozen, with the rewards'.
            model.get_env().training = False
    else:
        if normalize:
            venv = VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=hyper.get("gamma", 0.99))
        noise = hyper.get("action_noise_std")
        model = sb3_class(algo)(policy_name(algo), venv, seed=seed, device="cpu", tensorboard_log=str(out / "tb"),
                                verbose=verbose, **{key: v for key, v in hyper.items() if key not in NOT_SB3_KEYS},
                                **({"action_noise": action_noise(noise, venv.action_space)} if noise else {}))
        if warm == "trapezoid":
            warm_start_at(model, np.tile(trapezoid_action(), cycle))
    start_steps = model.num_timesteps
    total = target_total(algo, steps, previous, config_total, start_steps, n, hyper, critic_warmup)
    if isinstance(model.get_env(), VecNormalize):
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False)
    callbacks = [
        CheckpointCallback(max(checkpoint_freq // n, 1), str(out / "checkpoints"), name_prefix=algo,
                           save_vecnormalize=True),
        EvalCallback(eval_env, n_eval_episodes=len(HELD_OUT_POINTS), eval_freq=max(eval_freq // n, 1),
                     best_model_save_path=str(out / "best"), log_path=str(out), deterministic=True,
                     callback_on_new_best=_save_normalisation_callback(out / "best"), verbose=verbose),
        *extra_callbacks,
    ]
    if hyper.get("load_curriculum"):
        from .curriculum import load_curriculum_callback

        callbacks.append(load_curriculum_callback(float(hyper["load_curriculum"]), total))
    main_start = None if critic_warmup else start_steps  # the step the actor starts learning at
    t0 = time.perf_counter()

    def on_sigterm(signum, frame):
        raise _Interrupted

    interrupted = False
    old_handler = signal.signal(signal.SIGTERM, on_sigterm)
    try:
        if critic_warmup:
            with frozen_actor(model):
                model.learn(int(critic_warmup), progress_bar=progress_bar, reset_num_timesteps=previous is None,
                            tb_log_name=f"{algo}_critic_warmup")
            main_start = model.num_timesteps
        remaining = total - model.num_timesteps
        if remaining > 0:
            model.learn(remaining, callback=callbacks, progress_bar=progress_bar,
                        reset_num_timesteps=not (previous or critic_warmup), tb_log_name=algo)
    except (KeyboardInterrupt, _Interrupted):
        interrupted = True
        print(f"train: interrupted at step {model.num_timesteps}; saved, continue with --resume {out}", file=sys.stderr)
    finally:
        signal.signal(signal.SIGTERM, old_handler)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the saves below finish whatever arrives now
    try:
        return save_run(out, model, previous, algo, seed, env_kwargs, hyper, n, normalize, threads, total, start_steps,
                        main_start, time.perf_counter() - t0, interrupted)
    finally:
        signal.signal(signal.SIGTERM, old_handler)


def target_total(algo, steps, previous, config_total, start_steps, n, hyper, critic_warmup) -> int:
    """The run's total of environment steps: ``steps``, else a resumed run's own total, else the
    config's; a new total of a resumed run and a rounding to PPO's whole rollouts are said in one line."""
    if previous is None:
        total = int(steps if steps is not None else config_total)
    else:
        total = int(steps) if steps is not None else int(previous.get("target_timesteps", 0))
        if steps is None and not total:
            raise ValueError("--resume: this run records no total of steps (a distilled or adapted policy): give "
                             "--steps, the total to train it to")
        if total <= start_steps:
            raise ValueError(f"--resume: the run has {start_steps} steps, its total is {total}: give --steps with a "
                             "larger total to train it further")
        if steps is not None and steps != previous.get("target_timesteps"):
            print(f"train: --steps {steps} sets the run's total (it has {start_steps} steps): "
                  f"{steps - start_steps} more", file=sys.stderr)
    for option, asked in (("--steps", total - start_steps), ("--critic-warmup", int(critic_warmup))):
        actual = rounded_steps(algo, asked, n, hyper)
        if asked > 0 and actual != asked:
            rollout = int(hyper.get("n_steps", 2048))
            print(f"train: PPO collects whole rollouts of n_steps x n_envs = {rollout} x {n} = {rollout * n} steps: "
                  f"{option} runs {actual} steps, not {asked}", file=sys.stderr)
    return start_steps + rounded_steps(algo, total - start_steps, n, hyper)


def save_run(out, model, previous, algo, seed, env_kwargs, hyper, n, normalize, threads, total, start_steps,
             main_start, wall, interrupted) -> dict[str, Any]:
    """Write the model, its normalisation and run.json (last: it marks the set complete), each
    atomically; returns the run record."""
    from stable_baselines3.common.vec_env import VecNormalize

    record = policy_record(
        algo=algo, seed=seed, env_id=previous.get("env_id", ENV_ID) if previous else ENV_ID,
        env_kwargs=previous["env_kwargs"] if previous else env_kwargs,  # a codebook file stays relative
        hyperparameters={**hyper, "n_envs": n, "normalize": normalize}, torch_threads=threads,
        target_timesteps=int(total),
        critic_warmup_steps_this_run=int((model.num_timesteps if main_start is None else main_start) - start_steps),
        held_out_points=HELD_OUT_POINTS,
        total_timesteps=model.num_timesteps, steps_this_run=model.num_timesteps - start_steps,
        wall_time_s=round(wall + (previous["wall_time_s"] if previous else 0.0), 3),
        steps_per_s_this_run=round((model.num_timesteps - start_steps) / max(wall, 1e-9), 1),
        resumes=(previous["resumes"] + 1) if previous else 0, interrupted=interrupted)
    if previous:  # where the policy came from, and how it was continued
        record.update({key: previous[key] for key in PROVENANCE_KEYS if key in previous})
        record["continued_from"] = [*previous.get("continued_from", []), {
            "command": previous.get("command"), "total_timesteps": previous.get("total_timesteps")}]
    venv = model.get_env()
    save_policy(out, model, venv if isinstance(venv, VecNormalize) else None, record)
    return record
