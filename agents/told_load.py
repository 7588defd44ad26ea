"""What to tell a full-observation teacher about the load where friction is not the one it was trained at.

    python -m mdr_drive_agents.told_load --seed 1777 --n 32 --adaptation results/adaptation/seed1777_validation/adaptation.json

The shipped full-observation policy was trained at the paper's friction (mu = 0.3, mu1 = 0.1). Told
the true k and load at another friction it often plays a drive for the wrong regime: at mu = 0.225 and
a load of 0.086 mu F_ref (k = 0.419) it drives 3.9 mm/s where the same network, told a load of 0.15
of 0.3 F_ref, drives 21.1 (the validation draws of ``agents/configs/sensor.yaml``). A sensor policy
whose estimator estimates the true load inherits that loss. This module measures it: for each hidden
draw (k, cargo mass, mu, mu1), the teacher is played at that draw once per candidate load ratio in
``TOLD_RATIOS`` (told as a load at the teacher's own friction, both load entries consistent); the
**told load** is the candidate closest to the true load's ratio among those within ``tolerance`` of
the fastest (equal to the truth where the truth is as good).

A sensor estimator taught the told load instead of the truth (``agents/adapt.py`` at commit 6320145,
``estimator_target: told_load``) was not better (docs/adaptation.md, Limits), so it was retired; the
measurement stays, as the diagnosis of what bounds the sensor policy.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from mdr_drive_env.core.params import Contact
from mdr_drive_env.gym_envs.spaces import ActionMap, ObservationLayout

from .estimator import HIDDEN
from .evaluate import AVERAGE_PERIODS, EVAL_PERIODS, Policy, steady_velocity_of

#: Friction coefficient the full-observation teacher was trained at (the paper's, ``Contact``'s default).
TEACHER_FRICTION = Contact().friction_coefficient
#: Candidate load ratios told to the teacher (load / (TEACHER_FRICTION F_ref)): the generalist's training range.
TOLD_RATIOS = np.round(np.linspace(0.0, 0.55, 12), 6)
_FULL = ObservationLayout.structure


def told_entries(k: np.ndarray, ratio: np.ndarray, force_ref: np.ndarray) -> np.ndarray:
    """(n, 3) values of the full observation's ``estimator.HIDDEN`` entries (k, load_over_friction,
    load_over_10N) that tell the teacher a load of ``ratio`` TEACHER_FRICTION F_ref (N) at k (``force_ref``: F_ref, N)."""
    return np.stack([k, ratio, ratio * TEACHER_FRICTION * force_ref / 10.0], axis=1)


def told_velocities(teacher: Policy, draws: np.ndarray, ratios: np.ndarray = TOLD_RATIOS,
                    periods: int = EVAL_PERIODS, chunk: int = 16384) -> np.ndarray:
    """Steady velocities (m/s, mean of the last ``AVERAGE_PERIODS`` of ``periods``), (n, len(ratios)),
    of ``teacher`` at each hidden draw (rows of ``draws``: k, cargo mass kg, mu, mu1) told each ratio.

    The teacher sees what it sees inside the sensor policy (``estimator.SensorTeacher``): its own mean
    for the slider's motion and the contact forces, the true previous action and episode fraction,
    and the told k and load."""
    draws = np.asarray(draws, dtype=float).reshape(-1, 4)
    jobs = [(i, j) for i in range(len(draws)) for j in range(len(ratios))]
    out = np.empty(len(jobs))
    dyn = np.arange(_FULL["dynamics"].start, _FULL["dynamics"].stop)
    hidden = [_FULL[name].start for name in HIDDEN]
    for start in range(0, len(jobs), chunk):
        part = jobs[start:start + chunk]
        rows = draws[[i for i, _ in part]]
        ratio_told = ratios[[j for _, j in part]]
        venv = gym.make_vec("MDRDrive-v0", num_envs=len(part), vectorization_mode="vector_entry_point",
                            max_periods=periods, **teacher.play_kwargs)
        obs, _ = venv.reset(seed=0, options={"k": rows[:, 0], "cargo_mass": rows[:, 1],
                                             "friction_coefficient": rows[:, 2],
                                             "base_friction_coefficient": rows[:, 3]})
        told = told_entries(rows[:, 0], ratio_told, venv.unwrapped.force_ref).astype(np.float32)
        disp = []
        for _ in range(periods):
            full = np.array(obs, dtype=np.float32)
            full[:, dyn] = teacher.obs_rms.mean[dyn]
            full[:, hidden] = told
            action = np.asarray(teacher(full), dtype=np.float32).reshape(len(part), ActionMap.SIZE)
            obs, _, _, _, info = venv.step(action)
            disp.append(info["displacement"])
        out[start:start + len(part)] = steady_velocity_of(np.array(disp), AVERAGE_PERIODS)
        venv.close()
    return out.reshape(len(draws), len(ratios))


def told_ratio(velocities: np.ndarray, true_ratio: np.ndarray, ratios: np.ndarray = TOLD_RATIOS,
               tolerance: float = 0.03, slack: float = 1e-4) -> np.ndarray:
    """Per draw, the ratio to tell (module docstring): among ``ratios`` whose velocity is within
    ``tolerance`` (relative) or ``slack`` (m/s), whichever is larger, of the fastest, the one closest
    to ``true_ratio`` (the true load over TEACHER_FRICTION F_ref)."""
    velocities = np.atleast_2d(velocities)
    best = velocities.max(axis=1, keepdims=True)
    good = velocities >= best - np.maximum(tolerance * np.abs(best), slack)
    distance = np.where(good, np.abs(ratios[None, :] - np.asarray(true_ratio)[:, None]), np.inf)
    return ratios[np.argmin(distance, axis=1)]


def main(argv=None) -> int:
    """How much the teacher loses by being told the true load at other frictions: on ``--n`` draws
    of the sensor env's hidden parameters (``adaptation.draw_hidden``), its steady velocity told the
    truth (as the full-observation baseline is), told the label of :func:`told_ratio`, told the
    best of ``TOLD_RATIOS``, and told the label one step of ``TOLD_RATIOS`` off (the slower side); as
    fractions of the best drive of an adaptation run on the same draws."""
    import json
    from pathlib import Path

    from mdr_drive_env.cli_args import Parser, input_file

    from .adaptation import FRACTION_FLOOR, draw_hidden, hidden_point
    from .blind import MOVING_THRESHOLD
    from .evaluate import env_rollout

    ap = Parser(prog="python -m mdr_drive_agents.told_load", description=main.__doc__)
    ap.add_argument("--teacher", default="agents/pretrained/ppo_sensor/teacher",
                    help="full-observation Box policy folder (default: the sensor policy's teacher)")
    ap.add_argument("--seed", type=int, required=True, help="seed of the draws (-), as the adaptation run's")
    ap.add_argument("--n", type=int, default=32, help="draws (-), as the adaptation run's --blind")
    ap.add_argument("--adaptation", type=input_file, required=True,
                    help="adaptation.json of `python -m mdr_drive_agents.adaptation` on the same seed and n")
    a = ap.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    teacher = Policy(a.teacher)
    best = np.array(json.loads(Path(a.adaptation).read_text())["best_velocity_m_s"], dtype=float)
    points = draw_hidden(a.n, a.seed)
    if len(best) != len(points):
        ap.error(f"--adaptation has {len(best)} points, not --n {a.n}")
    draws = np.array([hidden_point(d) for d in points])
    v = told_velocities(teacher, draws)
    truth = np.array([np.mean(env_rollout(teacher, d["k"], d["cargo_mass"], EVAL_PERIODS, None,
                                          friction_coefficient=d["friction_coefficient"],
                                          base_friction_coefficient=d["base_friction_coefficient"])[0][-AVERAGE_PERIODS:])
                      for d in points])
    true_ratio = np.array([d["load_ratio"] * d["friction_coefficient"] / TEACHER_FRICTION for d in points])
    at = np.searchsorted(TOLD_RATIOS, told_ratio(v, true_ratio))
    label = v[np.arange(len(v)), at]
    rows = np.arange(len(v))
    off_by_one = np.minimum(v[rows, np.maximum(at - 1, 0)], v[rows, np.minimum(at + 1, len(TOLD_RATIOS) - 1)])
    scored = best >= MOVING_THRESHOLD
    print(f"{a.n} draws of seed {a.seed}, {int(scored.sum())} where the best drive moves >= 2 mm/s; "
          f"fraction of the best drive: mean / min / under {FRACTION_FLOOR:g}")
    for name, x in (("told the truth", truth), ("told the label", label), ("told the best ratio", v.max(axis=1)),
                    ("told the label one ratio off (the slower side)", off_by_one)):
        f = x[scored] / best[scored]
        print(f"  {name:47s} {f.mean():.3f} / {f.min():.3f} / {int((f < FRACTION_FLOOR).sum())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
