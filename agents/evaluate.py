"""Steady-state velocity of waveform policies and fixed waveforms (``mdr-drive evaluate``).

One protocol for every method: a fresh drive runs ``EVAL_PERIODS`` periods, and the steady
velocity is the mean slider velocity over the last ``AVERAGE_PERIODS`` (after the transient; a
mean over several periods also averages states that alternate between two period velocities). A drive whose load runs away
with the slider (``mdr_drive_env.core.analysis.is_runaway``) has no steady velocity: with
``mark_runaway=True`` its velocity is NaN, printed as "runaway" in tables.

    mdr-drive evaluate --policy agents/pretrained/ppo_generalist --k 0.2 --cargo-mass 0.1 --json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import gymnasium as gym
import numpy as np

import mdr_drive_env  # noqa: F401  registers MDRDrive-v0
from mdr_drive_env.core import DriveParams, Waveform
from mdr_drive_env.core import kernel as K
from mdr_drive_env.core.analysis import is_runaway
from mdr_drive_env.core.batch import BatchedDriveSimulator
from mdr_drive_env.gym_envs.spaces import ActionMap

EVAL_PERIODS = 30
AVERAGE_PERIODS = 10
ACTION_MAP = ActionMap()


#: The fastest backward x stroke any action can make (m/s): full amplitude over the shortest fall.
INDENTER_MIN_VELOCITY = -ACTION_MAP.x_amplitude_max / ((1.0 - ACTION_MAP.max_rise_fraction) * ACTION_MAP.period)


def steady_velocity_of(displacements: np.ndarray, average: int = AVERAGE_PERIODS, runaway=None) -> np.ndarray:
    """Steady velocity (m/s): mean of the last ``average`` rows of per-period displacements (m) / T;
    NaN where ``runaway`` (a bool per point) is True."""
    v = np.asarray(displacements)[-average:].mean(axis=0) / ACTION_MAP.period
    return v if runaway is None else np.where(runaway, np.nan, v)


def runaway_of(displacements: np.ndarray, peak_normal_force: np.ndarray, params: list[DriveParams]) -> np.ndarray:
    """Per point, whether the load ran away with the slider (core.analysis.is_runaway) in a run with
    per-period ``displacements`` (periods, n) (m) and the last period's ``peak_normal_force`` (n,) (N)."""
    margin = np.array([(p.contact.friction_coefficient + p.contact.base_friction_coefficient) * fz - p.drive.load
                       for p, fz in zip(params, peak_normal_force)])
    return is_runaway(np.asarray(displacements) / ACTION_MAP.period, INDENTER_MIN_VELOCITY, margin)


def format_velocity(v: float, width: int = 0, digits: int = 2) -> str:
    """A velocity (m/s) in mm/s for a table, or "runaway" for NaN (no steady velocity)."""
    return f"{'runaway' if np.isnan(v) else f'{v * 1e3:.{digits}f}':>{width}}"


def trapezoid_action() -> np.ndarray:
    """The env action of the paper's waveform (Fig. 2)."""
    return ACTION_MAP.to_action(Waveform.paper())


def open_loop_velocity(points, actions, periods: int = EVAL_PERIODS, average: int = AVERAGE_PERIODS,
                       mark_runaway: bool = False, variant: str = "as-specified") -> np.ndarray:
    """Steady velocity (m/s) of open-loop drives, one per (k, cargo mass) point, batched in one call per period.

    ``actions`` is one action (5,), one per point (n, 5), or a cycle of p actions per point
    (n, p, 5) played in turn (period t uses action t mod p), e.g. p = 2 alternates two waveforms.
    ``mark_runaway``: NaN where the load runs away with the slider (for tables); without it the
    mean is returned there too (a large negative number, as optimisers want).
    """
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim < 3:
        actions = np.atleast_2d(actions)[:, None, :]
    if len(actions) == 1 and len(points) > 1:
        actions = np.repeat(actions, len(points), axis=0)
    sim = BatchedDriveSimulator(len(points))
    params = [DriveParams.paper(k=k, cargo_mass=m, variant=variant) for k, m in points]
    for i, p in enumerate(params):
        sim.set_params(i, p)
    cycle = [np.array([[p.x_amplitude, p.x_rise_time, p.z_amplitude, p.z_rise_time, p.z_phase]
                       for p in (ACTION_MAP.to_params(a) for a in actions[:, j])]) for j in range(actions.shape[1])]
    disp = np.array([sim.step(cycle[t % len(cycle)], ACTION_MAP.period)[:, K.O_DISPLACEMENT].copy()
                     for t in range(periods)])
    runaway = runaway_of(disp, sim.out[:, K.O_PEAK_FZ], params) if mark_runaway else None
    return steady_velocity_of(disp, average, runaway)


class Policy:
    """A trained SB3 policy with its VecNormalize statistics, as ``obs -> action`` (deterministic)."""

    def __init__(self, path: str | Path):
        import pickle

        from stable_baselines3 import PPO, SAC

        path = Path(path)
        run = json.loads((path / "run.json").read_text()) if (path / "run.json").exists() else {}
        algo = {"ppo": PPO, "sac": SAC}[run.get("algo", "ppo")]
        self.model = algo.load(path / "model.zip", device="cpu")
        self.obs_rms = None
        if (path / "vecnormalize.pkl").exists():
            with open(path / "vecnormalize.pkl", "rb") as f:
                vn = pickle.load(f)
            self.obs_rms, self.clip_obs, self.epsilon = vn.obs_rms, vn.clip_obs, vn.epsilon
        self.run = run
        self.lookup = None  # a residual policy on the teacher's lookup (agents/residual.py)
        if run.get("hyperparameters", {}).get("residual_scale"):
            from .residual import LOOKUP_FILE, TeacherLookup

            self.lookup = TeacherLookup.load(path / LOOKUP_FILE)
            self.residual_scale = float(run["hyperparameters"]["residual_scale"])

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        if self.lookup is not None:
            from .residual import augment, env_action

            obs, base, weight = augment(np.atleast_2d(obs), self.lookup)
            return env_action(base, self._act(obs), self.residual_scale * weight)
        return self._act(obs)

    def _act(self, obs: np.ndarray) -> np.ndarray:
        if self.obs_rms is not None:
            obs = np.clip((obs - self.obs_rms.mean) / np.sqrt(self.obs_rms.var + self.epsilon),
                          -self.clip_obs, self.clip_obs).astype(np.float32)
        action, _ = self.model.predict(obs, deterministic=True)
        return action


def load_policy(path: str | Path):
    """``obs -> action`` from a path: a trained policy's folder (``Policy``), or a CMA-ES teacher's
    ``.npz`` (``python -m agents.teacher``), played as its lookup (``agents.residual.TeacherLookup``)."""
    if str(path).endswith(".npz"):
        from .residual import TeacherLookup

        return TeacherLookup.from_teacher(dict(np.load(path)))
    return Policy(path)


def policy_rollout(policy, points, periods: int = EVAL_PERIODS, variant: str = "as-specified"):
    """Run ``policy`` closed loop at each (k, cargo mass) point; returns (displacements (periods, n) m,
    actions (periods, n, 5), runaway (n,) bool)."""
    n = len(points)
    venv = gym.make_vec("MDRDrive-v0", num_envs=n, vectorization_mode="vector_entry_point", max_periods=periods,
                        variant=variant)
    obs, _ = venv.reset(seed=0, options={"k": [p[0] for p in points], "cargo_mass": [p[1] for p in points]})
    disp, acts = [], []
    for _ in range(periods):
        a = np.asarray(policy(obs), dtype=np.float32).reshape(n, ActionMap.SIZE)
        obs, _, _, _, info = venv.step(a)
        disp.append(info["displacement"])
        acts.append(a)
    params = [DriveParams.paper(k=k, cargo_mass=m, variant=variant) for k, m in points]
    return np.array(disp), np.array(acts), runaway_of(np.array(disp), info["peak_normal_force"], params)


def policy_velocity(policy, points, periods: int = EVAL_PERIODS, average: int = AVERAGE_PERIODS,
                    mark_runaway: bool = False) -> np.ndarray:
    """Steady velocity (m/s) of a closed-loop policy at each point (NaN where runaway, with ``mark_runaway``)."""
    disp, _, runaway = policy_rollout(policy, points, periods)
    return steady_velocity_of(disp, average, runaway if mark_runaway else None)


def policy_path(text: str) -> str:
    """argparse type: a trained policy's folder (with model.zip), or a CMA-ES teacher's .npz file."""
    from mdr_drive_env.cli_args import folder_with, input_file

    return input_file(text) if text.endswith(".npz") else folder_with("model.zip")(text)


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import folder_with

    p.add_argument("--policy", required=True, type=folder_with("model.zip"),
                   help="folder with model.zip and vecnormalize.pkl")
    p.add_argument("--k", type=float, required=True, help="grading exponent k (-)")
    p.add_argument("--cargo-mass", type=float, required=True, help="cargo mass m (kg)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (velocities in m/s; null where the load runs away)")
    from mdr_drive_env.cli import add_variant_argument

    add_variant_argument(p)


def main(args: argparse.Namespace) -> int:
    DriveParams.paper(k=args.k, cargo_mass=args.cargo_mass)  # a bad value fails here, before the policy loads
    policy = Policy(args.policy)
    point = [(args.k, args.cargo_mass)]
    disp, acts, runaway = policy_rollout(policy, point, variant=args.variant)
    learned = float(steady_velocity_of(disp, runaway=runaway)[0])
    trapezoid = float(open_loop_velocity(point, trapezoid_action(), mark_runaway=True, variant=args.variant)[0])
    last = ACTION_MAP.to_params(acts[-1, 0])._asdict()
    res = {"k": args.k, "cargo_mass": args.cargo_mass, "variant": args.variant,
           "learned_mean_velocity": None if np.isnan(learned) else learned,
           "trapezoid_mean_velocity": None if np.isnan(trapezoid) else trapezoid,
           "learned_runaway": bool(np.isnan(learned)), "trapezoid_runaway": bool(np.isnan(trapezoid)),
           "learned_waveform_last_period": last,
           "protocol": f"mean over periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}, m/s"}
    if args.json:
        print(json.dumps(res))
    else:
        print(f"k = {args.k:g}, m = {args.cargo_mass:g} kg: learned {format_velocity(learned, digits=3)} mm/s, "
              f"trapezoid {format_velocity(trapezoid, digits=3)} mm/s")
        print("learned waveform (last period):", {k: f"{v:.4g}" for k, v in last.items()})
    return 0


if __name__ == "__main__":  # python -m agents.evaluate ... is mdr-drive evaluate ...
    import sys

    from mdr_drive_env.cli import main as cli_main

    raise SystemExit(cli_main(["evaluate", *sys.argv[1:]]))
