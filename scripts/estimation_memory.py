#!/usr/bin/env python
"""Does a longer memory read the hidden parameters better? A frame-stacked MLP against an LSTM.

    python scripts/estimation_memory.py --episodes 2048 --seed 4747

The sensor policy estimates what the sensor hides (k, the load, mu and mu1) from its observation:
the last ``history`` periods of slider motion and actions, a frame stack read by an MLP
(``agents.estimator.Estimator``). A recurrent network could use the whole episode instead. This
measures what each can read, on the same data, before anything is built on it:

* episodes of ``MDRDriveSensor-v0`` (hidden k, load, mu and mu1 drawn per episode, no load step),
  driven by the shipped sensor policy's teacher told the truth, every action perturbed by Gaussian
  noise of std ``--action-noise`` (as the sensor training drives them); ``--episodes`` for the fit,
  a quarter as many on other seeds for validation;
* targets: the five hidden entries of the privileged observation (k, the two load scales, mu and
  mu1), each standardised;
* the frame stack: an MLP (512, 512) on each period's sensor observation (``--history`` periods;
  with ``--sensor-forces`` each period also holds its peak contact forces, as a drive with a force
  sensor would measure);
* the LSTM: one layer of ``--lstm`` units over the episode's sensor observations (the same frame
  stacks, so it sees all the MLP sees and remembers the rest of the episode), then a linear head,
  fitted on whole episodes;
* both ``--steps`` Adam steps at 1e-3, decaying linearly.

Printed: the validation error (mean squared, standardised) of each entry, over the periods from
``history`` on, and at the last ten periods. An entry neither reads is not in the slider's motion
under these drives, and memory will not find it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def episodes(n: int, periods: int, history: int, noise: float, seed: int, teacher, forces: bool = False):
    """Sensor observations (periods, n, d) and hidden entries (periods, n, 5) of ``n`` episodes."""
    from mdr_drive_agents.adapt import AdaptConfig, collect, sensor_envs
    from mdr_drive_agents.estimator import hidden_entries
    from mdr_drive_env.gym_envs.spaces import ObservationLayout, PrivilegedLayout

    config = AdaptConfig(history=history, periods=periods, load_step_share=0.0, load_step_periods=(1, 1),
                         sensor_forces=forces)
    envs, first = sensor_envs(config, n, seed)
    rng = np.random.default_rng(seed)
    full_dim = len(ObservationLayout.NAMES)  # the teacher's full observation: the privileged one without friction
    sensed, privileged, _ = collect(envs, first, lambda s, p: teacher(p[:, :full_dim]), noise, rng, friction=True)
    hidden = hidden_entries(PrivilegedLayout)
    return sensed.reshape(periods, n, -1), privileged[:, hidden].reshape(periods, n, -1)


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, int_range

    p = Parser(description=__doc__)
    p.add_argument("--episodes", type=int_range(4), default=2048, help="training episodes (-)")
    p.add_argument("--periods", type=int_range(2), default=40, help="periods per episode (-)")
    p.add_argument("--history", type=int_range(1), default=6, help="periods of the frame stack (-)")
    p.add_argument("--lstm", type=int_range(1), default=256, help="LSTM units (-)")
    p.add_argument("--steps", type=int_range(1), default=6000, help="Adam steps of each fit (-)")
    p.add_argument("--action-noise", type=float, default=0.15, help="std of the action noise (action units)")
    p.add_argument("--sensor-forces", action="store_true",
                   help="the sensor observation adds each period's peak contact forces (a force sensor)")
    p.add_argument("--seed", type=int, required=True, help="seed of the episodes and the fits (-)")
    p.add_argument("--teacher", type=folder_with("model.zip"), default="agents/pretrained/ppo_sensor/teacher",
                   help="full-observation policy that drives the episodes")
    args = p.parse_args(argv)
    if args.history >= args.periods:
        p.error(f"--history {args.history} must be below --periods {args.periods}")
    if not 0.0 <= args.action_noise <= 1.0:
        p.error(f"--action-noise {args.action_noise!r} is outside the allowed range [0, 1]")

    import torch

    from mdr_drive_agents.student import adam_fit
    from mdr_drive_agents.evaluate import Policy

    torch.set_num_threads(2)
    torch.manual_seed(args.seed)
    teacher = Policy(args.teacher)
    n_val = max(args.episodes // 4, 2)
    (xs, ys), (xv, yv) = (episodes(args.episodes, args.periods, args.history, args.action_noise, args.seed, teacher,
                                   args.sensor_forces),
                          episodes(n_val, args.periods, args.history, args.action_noise, args.seed + 7_000_001, teacher,
                                   args.sensor_forces))
    y_mean, y_std = ys.reshape(-1, 5).mean(0), ys.reshape(-1, 5).std(0) + 1e-12

    def standardiser(ref):
        """x -> x standardised with the statistics of ``ref`` (training data), as a float32 tensor."""
        flat = ref.reshape(-1, ref.shape[-1])
        mean, std = flat.mean(0), flat.std(0) + 1e-6
        return lambda x: torch.as_tensor((x - mean) / std, dtype=torch.float32)

    errors = {}
    # the frame stack: every period from `history` on is a sample
    start = args.history - 1
    standard = standardiser(xs[start:])
    x = standard(xs[start:].reshape(-1, xs.shape[-1]))
    y = torch.as_tensor(((ys[start:] - y_mean) / y_std).reshape(-1, 5), dtype=torch.float32)
    mlp = torch.nn.Sequential(torch.nn.Linear(x.shape[1], 512), torch.nn.ReLU(), torch.nn.Linear(512, 512),
                              torch.nn.ReLU(), torch.nn.Linear(512, 5))
    adam_fit(mlp.parameters(), lambda: (len(x), lambda idx: torch.mean((mlp(x[idx]) - y[idx]) ** 2)), args.steps,
             256, 1e-3, args.seed, "frame stack", progress=False)
    with torch.no_grad():
        guess = mlp(standard(xv[start:]))
    errors["frame-stacked MLP"] = (guess.numpy() - (yv[start:] - y_mean) / y_std) ** 2

    # the LSTM: whole episodes, one period per step
    standard = standardiser(xs)
    x = standard(xs).transpose(0, 1)  # (n, periods, d)
    y = torch.as_tensor((ys - y_mean) / y_std, dtype=torch.float32).transpose(0, 1)
    lstm = torch.nn.LSTM(x.shape[-1], args.lstm, batch_first=True)
    head = torch.nn.Linear(args.lstm, 5)

    def loss_of(idx):
        out, _ = lstm(x[idx])
        return torch.mean((head(out)[:, start:] - y[idx][:, start:]) ** 2)

    adam_fit([*lstm.parameters(), *head.parameters()], lambda: (len(x), loss_of), args.steps, 32, 1e-3,
             args.seed, "LSTM", progress=False)
    with torch.no_grad():
        out, _ = lstm(standard(xv).transpose(0, 1))
        guess = head(out).transpose(0, 1).numpy()
    errors["LSTM over the episode"] = (guess[start:] - (yv[start:] - y_mean) / y_std) ** 2

    names = ("k", "load / mu F_ref", "load / 10 N", "mu", "mu1")
    print(f"{args.episodes} training and {n_val} validation episodes of {args.periods} periods, seed {args.seed}"
          f"{', with a force sensor' if args.sensor_forces else ''}; "
          f"validation error (mean squared, standardised; 1 = no better than the mean) from period {args.history} on, "
          f"and over the last 10 periods")
    print("| estimator | " + " | ".join(names) + " | all | last 10 periods: " + " | ".join(names) + " |")
    print("|---" * (2 * len(names) + 2) + "|")
    for name, err in errors.items():
        every, last = err.mean(axis=(0, 1)), err[-10:].mean(axis=(0, 1))
        print(f"| {name} | " + " | ".join(f"{e:.3f}" for e in every) + f" | {every.mean():.3f} | "
              + " | ".join(f"{e:.3f}" for e in last) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
