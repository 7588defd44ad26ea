"""Plain RL on MDRDrive-v0, measured as RL papers measure it (``mdr-drive rl-baselines``).

Stable-Baselines3's PPO, SAC and TD3 and sb3-contrib's RecurrentPPO, each from scratch (no teacher,
no action table, no warm start): hyperparameters found by an Optuna search on the points of one
blind benchmark (the validation record), then several training seeds with those hyperparameters,
each scored through training on the points of other blind benchmarks (the report records) with the
normalised score ``(V - V_trapezoid) / (V_best - V_trapezoid)`` (``benchmarks.score``) and
aggregated as rliable does (IQM and mean, 95 % stratified-bootstrap intervals over training seeds
and points). Writes the RL Zoo's kind of ``benchmark.md``, the learning curves and the tuned
hyperparameters as RL-Zoo YAML files.

    config.py     the run's settings (``BaselinesConfig``, from agents/configs/rl_baselines.yaml)
    curve.py      the learning-curve callback and the score of a live model
    tuning.py     the hyperparameter search spaces and the Optuna study (ask and tell)
    runner.py     the tasks (one training run each) on the sweep executor, with resume
    report.py     benchmark.md, results.json and curves.png
    card.py       the shipped plain policy's model card
    pipeline.py   the command's run, config to outputs

The references are blind benchmarks' points (``benchmarks.reference``).
"""
