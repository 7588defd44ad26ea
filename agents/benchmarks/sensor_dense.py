"""Where a sensor policy is below the trapezoid or unstable, on a dense grid of its hidden values.

    mdr-drive dense --policy agents/pretrained/ppo_sensor --ks 31 --loads 31 --out results/adaptation/dense

The adaptation report draws a few dozen hidden values; a closed-loop policy that reads its drive from
the slider's motion can lose itself at a few of them (the estimate sends it to a drive whose motion
confirms the wrong estimate: velocities that swing from period to period and average little). This
check needs no search, so it covers the sensor env's ranges densely (the policy's own, on the drive it
was built for): ``--ks`` values of k evenly spaced over its k range (0-0.6 on the paper's drive) times
``--loads`` loads evenly spaced over its load range (0 to 0.4 of mu F_ref), at each corner and the
middle of the friction ranges (mu in {0.2, 0.3, 0.4} times mu1 in {0.07, 0.1, 0.13} on the paper's
drive), each played closed loop in the policy's own env (30 periods, mean of 21-30) beside the
trapezoid.

Counts the points where the policy is slower than the trapezoid by more than 0.05 mm/s (where
either moves; ``targets.below_trapezoid``) and the points where its period velocity swings
(``SWING``: over periods 21-30 the largest minus the smallest period's mean velocity exceeds
``SWING_MM_S`` and the policy is below the trapezoid's own velocity there), and, apart, the points
where neither moves forward and the policy slides back faster than the trapezoid by more than 0.05
mm/s (a runaway load it does not brake). Writes ``sensor_dense.json``, ``sensor_dense.md`` and
``below.csv``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mdr_drive_env.files import json_safe, write_csv, write_text

from ..drive import PAPER_DRIVE, DriveDescription
from ..policy import load_policy
from ..protocol import (AVERAGE_PERIODS, BELOW_TOLERANCE, EVAL_PERIODS, SENSOR_ID, drive_of, open_loop_displacements,
                        steady_velocity_of, trapezoid_action)
from .targets import below_trapezoid
#: A swing: the largest minus the smallest period velocity over the averaged periods (mm/s).
SWING_MM_S = 10.0
#: Envs stepped together (bounds memory).
CHUNK = 512


def is_sensor_run(run: dict) -> bool:
    """Whether the policy of run record ``run`` (its run.json) drives ``MDRDriveSensor-v0``."""
    return run.get("env_id") == SENSOR_ID


def frictions(drive: DriveDescription = PAPER_DRIVE) -> list[tuple[float, float]]:
    """The friction pairs of the grid: the corners and the middle of ``drive``'s sensor ranges
    (``DriveDescription.sensor_env_kwargs``), mu-major."""
    ranges = drive.sensor_env_kwargs()
    three = [[lo, round((lo + hi) / 2.0, 12), hi] for lo, hi in (ranges["friction_coefficient"],
                                                                  ranges["base_friction_coefficient"])]
    return [(mu, mu1) for mu in three[0] for mu1 in three[1]]


def grid(n_k: int, n_loads: int, drive: DriveDescription = PAPER_DRIVE) -> list[dict]:
    """The hidden values of the check on ``drive``'s sensor ranges: k, load over mu F_ref, mu, mu1
    (k-major, then load, friction)."""
    ranges, pairs = drive.sensor_env_kwargs(), frictions(drive)
    ks = np.linspace(*ranges["k"], n_k)
    ratios = np.linspace(*ranges["load_ratio"], n_loads)
    return [{"k": float(k), "load_ratio": float(r), "friction_coefficient": mu, "base_friction_coefficient": mu1}
            for k in ks for r in ratios for mu, mu1 in pairs]


def rollouts(policy, points: list[dict], periods: int = EVAL_PERIODS,
             progress: bool = True) -> tuple[np.ndarray, list[float]]:
    """The policy's period velocities (periods, n) m/s at ``points``, closed loop in its own env, the
    envs of a chunk stepped together (one batched ``act`` per period), and each point's cargo mass
    (kg: its load over mu F_ref as the env sets it)."""
    from tqdm import tqdm

    out, masses = [], []
    for start in tqdm(range(0, len(points), CHUNK), desc="sensor dense check", unit="chunk", disable=not progress):
        chunk = points[start:start + CHUNK]
        box = {"action_codebook": None} if policy.codebook is not None else {}  # it plays its table's rows as Box actions
        envs = [policy.make_env(max_periods=periods, **box, **p) for p in chunk]
        first = [env.reset(seed=0) for env in envs]
        obs = np.array([o for o, _ in first])
        masses += [float(info["cargo_mass"]) for _, info in first]
        policy.reset()
        v = []
        for _ in range(periods):
            action = np.asarray(policy.act(obs), dtype=np.float32).reshape(len(envs), -1)
            steps = [env.step(a) for env, a in zip(envs, action)]
            obs = np.array([s[0] for s in steps])
            v.append([s[4]["mean_velocity"] for s in steps])
        out.append(np.array(v))
    return np.concatenate(out, axis=1), masses


def run(policy_path: str, n_k: int, n_loads: int, out: str | Path, command: str, progress: bool = True) -> str:
    """The check (module docstring) into ``out``; returns ``sensor_dense.md``'s text."""
    out = Path(out)
    policy = load_policy(policy_path)
    if not is_sensor_run(policy.run):
        raise ValueError(f"{policy_path} is not a sensor policy (its env is {policy.run.get('env_id')!r}); "
                         "mdr-drive dense checks it on the blind benchmark's grid instead")
    drive = drive_of(policy)
    points = grid(n_k, n_loads, drive)
    v, masses = rollouts(policy, points, progress=progress)
    hidden = [(p["k"], m, p["friction_coefficient"], p["base_friction_coefficient"]) for p, m in zip(points, masses)]
    disp, _ = open_loop_displacements(hidden, trapezoid_action(drive), drive=drive)
    trap = steady_velocity_of(disp, period=drive.period)
    learned = v[-AVERAGE_PERIODS:].mean(axis=0)
    below, gap, moving = below_trapezoid(trap, learned)
    swing = (v[-AVERAGE_PERIODS:].max(axis=0) - v[-AVERAGE_PERIODS:].min(axis=0)) * 1e3
    unstable = (swing > SWING_MM_S) & (learned < trap)
    back_faster = ~moving & (gap < -BELOW_TOLERANCE)  # neither moves forward: below_trapezoid does not count these
    res = json_safe({"policy": str(policy_path), "command": command, "drive": None if drive.is_paper else drive.to_record(),
                     "points": points, "cargo_mass_kg": masses,
                     "policy_m_s": np.round(learned, 8), "trapezoid_m_s": np.round(trap, 8),
                     "swing_mm_s": np.round(swing, 4)})
    rows = [(p["k"], p["load_ratio"], p["friction_coefficient"], p["base_friction_coefficient"], trap[i], learned[i],
             swing[i]) for i, p in enumerate(points) if below[i] or unstable[i]]
    write_csv(out / "below.csv", ["k", "load_over_mu_f_ref", "mu", "mu1", "trapezoid_m_s", "policy_m_s", "swing_mm_s"],
              rows)
    finite = gap[below & np.isfinite(gap)]
    ranges = drive.sensor_env_kwargs()
    k_range, load_range = ranges["k"], ranges["load_ratio"]
    on = "" if drive.is_paper else f" on drive {drive.name}"
    lines = [f"Dense check of the sensor policy `{policy_path}`{on}: {n_k} k values in [{k_range[0]:g}, {k_range[1]:g}] x "
             f"{n_loads} loads from {load_range[0]:g} to {load_range[1]:g} of mu F_ref x {len(points) // (n_k * n_loads)} friction "
             f"pairs ({len(points)} points); closed loop in its own "
             f"env, mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}.", f"Command: `{command}`", "",
             f"* points below the trapezoid by more than {BELOW_TOLERANCE * 1e3:g} mm/s (where either moves): **{int(below.sum())}** "
             f"({100.0 * below.mean():.2f} % of the grid); worst "
             + (f"{finite.min() * 1e3:.2f} mm/s" if finite.size else "none"),
             f"* points where its period velocity swings by more than {SWING_MM_S:g} mm/s over periods "
             f"{EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS} and it is slower than the trapezoid: "
             f"**{int(unstable.sum())}**",
             f"* points where neither moves forward and it slides back faster than the trapezoid by more than "
             f"{BELOW_TOLERANCE * 1e3:g} mm/s: **{int(back_faster.sum())}**; worst "
             + (f"{gap[back_faster].min() * 1e3:.2f} mm/s" if back_faster.any() else "none"), ""]
    if rows:
        lines += ["| k | load / (mu F_ref) | mu | mu1 | trapezoid (mm/s) | policy (mm/s) | swing (mm/s) |",
                  "|---|---|---|---|---|---|---|"]
        for r in sorted(rows, key=lambda r: r[5] - r[4])[:15]:
            lines.append(f"| {r[0]:.3f} | {r[1]:.3f} | {r[2]:g} | {r[3]:g} | {r[4] * 1e3:.2f} | {r[5] * 1e3:.2f} | "
                         f"{r[6]:.1f} |")
    text = "\n".join(lines) + "\n"
    write_text(out / "sensor_dense.md", text)
    write_text(out / "sensor_dense.json", json.dumps(res))  # last: its presence marks a finished check
    return text


__all__ = ["CHUNK", "SWING_MM_S", "frictions", "grid", "is_sensor_run", "rollouts", "run"]
