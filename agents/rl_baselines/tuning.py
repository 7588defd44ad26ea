"""The hyperparameter search of ``mdr-drive rl-baselines``: Optuna's TPE sampler (seeded) over the
search spaces below (reduced from the RL Zoo's ``hyperparams_opt.py``), asked and told in batches
so that the trials train on the sweep executor; a trial's objective is the mean normalised score on
the validation record's points at the end of a short run.
"""

from __future__ import annotations

from typing import Any

#: Network sizes a search picks among (hidden layers of the actor and the critic).
NET_ARCHS = {"small": [64, 64], "medium": [256, 256]}


def _ppo_family(trial, recurrent: bool) -> dict[str, Any]:
    params = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
        "n_steps": trial.suggest_categorical("n_steps", [64, 128, 256]),
        "batch_size": trial.suggest_categorical("batch_size", [256, 512, 1024]),
        "n_epochs": trial.suggest_categorical("n_epochs", [5, 10, 20]),
        "gamma": trial.suggest_categorical("gamma", [0.9, 0.95, 0.98, 0.99]),
        "gae_lambda": trial.suggest_categorical("gae_lambda", [0.9, 0.95, 0.98]),
        "clip_range": trial.suggest_categorical("clip_range", [0.1, 0.2, 0.3]),
        "ent_coef": trial.suggest_float("ent_coef", 1e-8, 1e-2, log=True),
    }
    policy_kwargs: dict[str, Any] = {"net_arch": NET_ARCHS[trial.suggest_categorical("net_arch", list(NET_ARCHS))],
                                     "log_std_init": trial.suggest_float("log_std_init", -2.0, 0.0)}
    if recurrent:
        policy_kwargs["lstm_hidden_size"] = trial.suggest_categorical("lstm_hidden_size", [32, 64, 128])
    return {**params, "policy_kwargs": policy_kwargs}


def _off_policy(trial, algo: str) -> dict[str, Any]:
    params = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 3e-3, log=True),
        "batch_size": trial.suggest_categorical("batch_size", [128, 256, 512]),
        "gamma": trial.suggest_categorical("gamma", [0.9, 0.95, 0.98, 0.99]),
        "tau": trial.suggest_categorical("tau", [0.005, 0.01, 0.02]),
        "learning_starts": trial.suggest_categorical("learning_starts", [256, 1000, 5000]),
        "policy_kwargs": {"net_arch": NET_ARCHS[trial.suggest_categorical("net_arch", list(NET_ARCHS))]},
    }
    if algo == "sac":
        params["ent_coef"] = trial.suggest_categorical("ent_coef", ["auto", "auto_0.1", "auto_0.01"])
    else:
        params["action_noise_std"] = trial.suggest_categorical("action_noise_std", [0.05, 0.1, 0.2, 0.4])
    return params


def sample_hyperparameters(trial, algo: str) -> dict[str, Any]:
    """The hyperparameters a trial of ``algo`` tries (SB3 keywords, ``policy_kwargs`` included)."""
    if algo in ("ppo", "recurrent_ppo"):
        return _ppo_family(trial, algo == "recurrent_ppo")
    return _off_policy(trial, algo)


def make_study(seed: int, startup_trials: int):
    """An Optuna study that maximises, with TPE seeded with ``seed`` (its first ``startup_trials``
    trials random)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna.create_study(direction="maximize",
                               sampler=optuna.samplers.TPESampler(seed=seed, n_startup_trials=startup_trials))


def fixed_hyperparameters(params: dict, algo: str) -> dict[str, Any]:
    """The hyperparameters of a finished trial's ``params`` (``sample_hyperparameters`` replayed)."""
    import optuna

    return sample_hyperparameters(optuna.trial.FixedTrial(params), algo)


__all__ = ["NET_ARCHS", "fixed_hyperparameters", "make_study", "sample_hyperparameters"]
