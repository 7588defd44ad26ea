"""The evaluation protocol: how every drive, open loop or closed loop, is judged.

One protocol for every method: a fresh drive runs ``EVAL_PERIODS`` periods, and the steady velocity
is the mean slider velocity over the last ``AVERAGE_PERIODS`` (after the transient; a mean over
several periods also averages states that alternate between two period velocities). A drive whose
load runs away with the slider (``mdr_drive_env.core.analysis.is_runaway``) has no steady velocity:
with ``mark_runaway=True`` its velocity is NaN, printed as "runaway" in tables.

The critical load of a drive at k is the largest cargo mass before its steady velocity first
drops to <= 0 (or runs away), on a fine load grid (``critical_loads``). The paper's trapezoid is
the reference every result is compared with (``trapezoid_action``, ``trapezoid_critical_load``).

Every function judges on one drive (``drive``, a :class:`~mdr_drive_agents.drive.DriveDescription`;
default the paper's): its physics, its period and its strokes. A closed-loop policy plays on its
own drive, the keywords its run.json records (``drive_of``).

A closed-loop drive is any ``act(observations) -> Box actions`` callable, or an object with such an
``act`` method (a loaded policy, ``mdr_drive_agents.policy.Policy``); one with a ``play_kwargs``
attribute plays in an env built with those keywords (its observation layout, time quantum, z phase
origin).
"""

from __future__ import annotations


import gymnasium as gym
import numpy as np

import mdr_drive_env  # noqa: F401  registers MDRDrive-v0
from mdr_drive_env.core import DriveParams
from mdr_drive_env.core import kernel as K
from mdr_drive_env.core.analysis import is_runaway
from mdr_drive_env.core.batch import BatchedDriveSimulator
from mdr_drive_env.gym_envs.spaces import ActionMap, shift_phase_origin

from .drive import DRIVE_KEYS, PAPER_DRIVE, DriveDescription

EVAL_PERIODS = 30
AVERAGE_PERIODS = 10
#: A drive is "below the trapezoid" when slower by more than this (m/s) where either moves.
BELOW_TOLERANCE = 0.05e-3
#: A drive's fraction of the best drive counts only where the best drive moves at least this fast (m/s).
MOVING_THRESHOLD = 2e-3
#: The env of a drive that does not know its k, load and friction (hidden, drawn per episode).
SENSOR_ID = "MDRDriveSensor-v0"
#: The paper drive's action map (the env's default).
ACTION_MAP = ActionMap()
#: The env's default time quantum of rises and the z phase (s): the action units every search and
#: teacher uses unless told otherwise.
TIME_QUANTUM = ACTION_MAP.time_quantum
#: Fine load grid of the critical-load scan: loads per pass (two passes, ``critical_loads``).
CRITICAL_GRID = 64


def steady_velocity_of(displacements: np.ndarray, average: int = AVERAGE_PERIODS, runaway=None,
                       period: float = ACTION_MAP.period) -> np.ndarray:
    """Steady velocity (m/s): mean of the last ``average`` rows of per-period displacements (m) / T
    (``period``, s; the drive's); NaN where ``runaway`` (a bool per point) is True."""
    v = np.asarray(displacements)[-average:].mean(axis=0) / period
    return v if runaway is None else np.where(runaway, np.nan, v)


def runaway_of(displacements: np.ndarray, peak_normal_force: np.ndarray, params: list[DriveParams],
               drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """Per point, whether the load ran away with the slider (core.analysis.is_runaway) in a run on
    ``drive`` with per-period ``displacements`` (periods, n) (m) and the last period's
    ``peak_normal_force`` (n,) (N)."""
    margin = np.array([(p.contact.friction_coefficient + p.contact.base_friction_coefficient) * fz - p.drive.load
                       for p, fz in zip(params, peak_normal_force)])
    return is_runaway(np.asarray(displacements) / drive.period, drive.indenter_min_velocity, margin)


def format_velocity(v: float, width: int = 0, digits: int = 2) -> str:
    """A velocity (m/s) in mm/s for a table, or "runaway" for NaN or None (no steady velocity)."""
    return f"{'runaway' if v is None or np.isnan(v) else f'{v * 1e3:.{digits}f}':>{width}}"


def csv_velocity(v):
    """A velocity (m/s) as a CSV cell: the number, or "runaway" for NaN or None (no steady velocity)."""
    return "runaway" if v is None or (isinstance(v, float) and np.isnan(v)) else v


def trapezoid_action(drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """The env action of the baseline: the paper's waveform (Fig. 2) on the paper's drive, its shape
    at the drive's period and full strokes on another (``DriveDescription.trapezoid_action``)."""
    return drive.trapezoid_action()


def point_params(point, drive: DriveDescription = PAPER_DRIVE) -> DriveParams:
    """The drive's model at ``point``: (k, cargo mass kg), or (k, cargo mass, mu, mu1) with those
    friction coefficients (indenter-slider, slider-base)."""
    return drive.params(point[0], point[1], tuple(point[2:4]) if len(point) == 4 else None)


def drive_of(policy, drive: DriveDescription = PAPER_DRIVE) -> DriveDescription:
    """The drive a closed-loop policy plays on: the one it was built for, the drive keywords of its
    ``play_kwargs`` (its run.json; none: the paper's drive), under ``drive``'s model ``variant``
    unless it names its own. ``drive`` itself if that is the same drive; else named and ranged as the
    description its run.json keeps (``drive``), if any."""
    own = {k: v for k, v in play_kwargs_of(policy).items() if k in DRIVE_KEYS}
    if "variant" not in own and "variant" in drive.env_kwargs:
        own["variant"] = drive.env_kwargs["variant"]
    built_for = DriveDescription(tuple(own.items()))
    if built_for.settings == drive.settings:
        return drive
    described = (getattr(policy, "run", None) or {}).get("drive")  # its description: name and ranges
    if described:
        return DriveDescription.from_record({**described, **own})
    return built_for if own else PAPER_DRIVE


def play_drive(policies, drive: DriveDescription | None = None) -> DriveDescription:
    """The one drive ``policies`` were built for (:func:`drive_of` each; the paper's for none; a sensor
    policy's, whose friction pair is drawn, is the same stage as a told policy's at its nominal pair:
    ``DriveDescription.stage_settings``), or ``drive`` if given (a ``--drive``), which must be theirs.
    Raises ``ValueError`` if they were built for different drives, or for another than ``drive``."""
    base = PAPER_DRIVE if drive is None else drive
    drives = [drive_of(p, base) for p in policies]
    if len({d.stage_settings for d in drives}) > 1:  # a sensor policy and a told one of the same stage go together
        raise ValueError("the policies were built for different drives: benchmark them apart")
    if not drives:
        return base
    if drive is not None and drives[0].stage_settings != drive.stage_settings:
        which = "the policy was" if len(drives) == 1 else "the policies were"
        raise ValueError(f"{which} built for another drive ({dict(drives[0].settings) or 'the paper drive'}) than "
                         f"{drive.name}: leave out --drive to judge on the drive it was built for")
    return drives[0]


# ---------------------------------------------------------------------------------------- open loop
def open_loop_velocity(points, actions, periods: int = EVAL_PERIODS, average: int = AVERAGE_PERIODS,
                       mark_runaway: bool = False, drive: DriveDescription = PAPER_DRIVE,
                       time_quantum: float = TIME_QUANTUM) -> np.ndarray:
    """Steady velocity (m/s) of open-loop drives, one per (k, cargo mass) point, batched in one call per period.

    ``actions`` is one action (5,), one per point (n, 5), or a cycle of p actions per point
    (n, p, 5) played in turn (period t uses action t mod p), e.g. p = 2 alternates two waveforms.
    ``mark_runaway``: NaN where the load runs away with the slider (for tables); without it the
    mean is returned there too (a large negative number, as optimisers want). ``time_quantum`` (s):
    the actions' rises and z phase are quantised to it (``drive.action_map``).
    """
    disp, runaway = open_loop_displacements(points, actions, periods, drive, time_quantum)
    return steady_velocity_of(disp, average, runaway if mark_runaway else None, drive.period)


def open_loop_displacements(points, actions, periods: int = EVAL_PERIODS, drive: DriveDescription = PAPER_DRIVE,
                            time_quantum: float = TIME_QUANTUM):
    """Per-period displacements (periods, n) (m) of open-loop drives (see :func:`open_loop_velocity`;
    ``points`` as :func:`point_params` takes them) and whether each ran away (n,).

    Drives that play the same waveforms at the same point once quantised to ``time_quantum`` (the
    teacher's candidates, ``DriveField.best``, share nodes' drives) are simulated once and their
    results copied: each drive of the batch runs on its own, so the results are those of simulating
    every one."""
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim < 3:
        actions = np.atleast_2d(actions)[:, None, :]
    if len(actions) == 1 and len(points) > 1:
        actions = np.repeat(actions, len(points), axis=0)
    action_map = drive.action_map(time_quantum)
    cycle = np.array([[[p.x_amplitude, p.x_rise_time, p.z_amplitude, p.z_rise_time, p.z_phase]
                       for p in (action_map.to_params(a) for a in actions[:, j])]
                      for j in range(actions.shape[1])]).reshape(actions.shape[1], len(points), 5)
    point_keys = [tuple(map(float, point)) for point in points]
    drive_of, unique = {}, []  # drive_of: each drive's row among the simulated ones
    inverse = np.empty(len(points), dtype=np.int64)
    for i, point_key in enumerate(point_keys):
        key = (point_key, cycle[:, i].tobytes())
        if key not in drive_of:
            drive_of[key] = len(unique)
            unique.append(i)
        inverse[i] = drive_of[key]
    sim = BatchedDriveSimulator(len(unique), drive.numerics, max_depth=drive.z_amplitude_max)
    params, first_of = [], {}  # the model is built once per distinct point (searches play many drives at one)
    for row, i in enumerate(unique):
        key = point_keys[i]
        if key in first_of:
            sim.copy_params(row, first_of[key])
        else:
            first_of[key] = row
            sim.set_params(row, point_params(points[i], drive))
        params.append(sim.params[row])
    rows = np.array(unique)
    disp = np.array([sim.step(cycle[t % len(cycle)][rows], action_map.period)[:, K.O_DISPLACEMENT].copy()
                     for t in range(periods)])
    runaway = runaway_of(disp, sim.out[:, K.O_PEAK_FZ], params, drive)
    return np.ascontiguousarray(disp[:, inverse]), runaway[inverse]  # C order: means over periods as before


# -------------------------------------------------------------------------------------- closed loop
def play_kwargs_of(policy) -> dict:
    """The env keywords a closed-loop drive plays in (its ``play_kwargs``; none for a plain callable)."""
    return dict(getattr(policy, "play_kwargs", None) or {})


def actions_of(policy):
    """A closed-loop drive as ``obs (n, d) -> Box actions``: its ``act`` method, or the drive itself;
    a drive with a ``reset`` method (a recurrent policy's memory) is reset first: a new episode."""
    if hasattr(policy, "reset"):
        policy.reset()
    return policy.act if hasattr(policy, "act") else policy


def policy_rollout(policy, points, periods: int = EVAL_PERIODS, drive: DriveDescription = PAPER_DRIVE):
    """Run ``policy`` (``act(obs) -> Box actions``) closed loop at each (k, cargo mass) point (at the
    drive's nominal friction, ``DriveDescription.nominal_friction``) or (k, cargo mass, mu, mu1) point,
    in the batched env it expects (:func:`play_kwargs_of`, on its own drive: :func:`drive_of`); returns
    (displacements (periods, n) m, actions (periods, n, 5) in the default action units (``ACTION_MAP``,
    whatever the policy's ``z_phase_origin``), runaway (n,) bool)."""
    n = len(points)
    play, act, drive = play_kwargs_of(policy), actions_of(policy), drive_of(policy, drive)
    options = {"k": [p[0] for p in points], "cargo_mass": [p[1] for p in points]}
    mu, mu1 = drive.nominal_friction  # a (k, cargo mass) point plays the drive's nominal pair, never a drawn one
    options.update(friction_coefficient=[p[2] if len(p) == 4 else mu for p in points],
                   base_friction_coefficient=[p[3] if len(p) == 4 else mu1 for p in points])
    if play.get("observation") == "sensor":  # the batched vector env has the full observation only: one env each
        envs = [gym.make("MDRDrive-v0", max_periods=periods, **{**drive.env_kwargs, **play}) for _ in points]
        obs = np.array([env.reset(seed=0, options={key: v[i] for key, v in options.items()})[0]
                        for i, env in enumerate(envs)])
        venv = None
    else:
        venv = gym.make_vec("MDRDrive-v0", num_envs=n, vectorization_mode="vector_entry_point", max_periods=periods,
                            **{**drive.env_kwargs, **play})
        obs, _ = venv.reset(seed=0, options=options)
    disp, acts = [], []
    for _ in range(periods):
        a = np.asarray(act(obs), dtype=np.float32).reshape(n, ActionMap.SIZE)
        if venv is None:
            steps = [env.step(action) for env, action in zip(envs, a)]
            obs = np.array([step[0] for step in steps])
            info = {key: np.array([step[4][key] for step in steps]) for key in ("displacement", "peak_normal_force")}
        else:
            obs, _, _, _, info = venv.step(a)
        disp.append(info["displacement"])
        acts.append(a)
    params = [point_params(p, drive) for p in points]
    acts = shift_phase_origin(np.array(acts), play.get("z_phase_origin", 0.0), ACTION_MAP.z_phase_origin)
    return np.array(disp), acts.astype(np.float32), runaway_of(np.array(disp), info["peak_normal_force"], params,
                                                               drive)


def policy_velocity(policy, points, periods: int = EVAL_PERIODS, average: int = AVERAGE_PERIODS,
                    mark_runaway: bool = False, drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """Steady velocity (m/s) of a closed-loop policy at each point (NaN where runaway, with ``mark_runaway``)."""
    disp, _, runaway = policy_rollout(policy, points, periods, drive)
    return steady_velocity_of(disp, average, runaway if mark_runaway else None, drive_of(policy, drive).period)


def rollout_env(policy, k: float, cargo_mass: float, periods: int, load_step=None, seed: int = 0,
                drive: DriveDescription = PAPER_DRIVE, **env_kwargs):
    """``MDRDrive-v0`` at (k, cargo mass kg) on ``drive`` as ``policy`` plays in it (its ``play_kwargs``
    under ``env_kwargs``), reset with ``seed`` and the optional ``load_step`` (period, cargo mass kg):
    (env, first observation). ``drive`` as given: :func:`env_rollout` passes the policy's own. At a
    point the friction pair is the drive's nominal one (``DriveDescription.nominal_friction``) unless
    ``env_kwargs`` names it, never drawn from a range the policy was trained on."""
    nominal = dict(zip(("friction_coefficient", "base_friction_coefficient"), drive.nominal_friction))
    env = gym.make("MDRDrive-v0", k=k, cargo_mass=cargo_mass, max_periods=periods,
                   **{**drive.env_kwargs, **play_kwargs_of(policy), **nominal, **env_kwargs})
    obs, _ = env.reset(seed=seed, options={"load_step": load_step} if load_step else None)
    return env, obs


def env_rollout(policy, k: float, cargo_mass: float, periods: int = EVAL_PERIODS, load_step=None,
                seed: int = 0, drive: DriveDescription = PAPER_DRIVE, **env_kwargs):
    """One run of the single env ``MDRDrive-v0`` at (k, cargo mass) on ``drive`` (a policy: on its
    own, :func:`drive_of`): closed loop with ``policy`` (``act(obs) -> Box actions``), or the
    trapezoid every period if ``policy`` is None. ``load_step``: (period, cargo mass in kg); a policy
    plays in the env it expects (:func:`play_kwargs_of`, under ``env_kwargs``). Returns (per-period mean velocities (periods,) m/s,
    actions (periods, 5) in the default action units (``ACTION_MAP``, whatever ``z_phase_origin``
    the env has), whether the load ran away)."""
    drive = drive if policy is None else drive_of(policy, drive)
    env, obs = rollout_env(policy, k, cargo_mass, periods, load_step, seed, drive, **env_kwargs)
    trapezoid = env.unwrapped.trapezoid_action()
    act = None if policy is None else actions_of(policy)
    velocities, actions = [], []
    for _ in range(periods):
        a = trapezoid if act is None else np.asarray(act(obs[None]), dtype=np.float32).reshape(ActionMap.SIZE)
        obs, _, _, _, info = env.step(a)
        velocities.append(info["mean_velocity"])
        actions.append(a)
    v = np.array(velocities)
    runaway = runaway_of(v[:, None] * drive.period, [info["peak_normal_force"]], [env.unwrapped.params], drive)
    actions = shift_phase_origin(np.array(actions), env.unwrapped.action_map.z_phase_origin, ACTION_MAP.z_phase_origin)
    return v, actions.astype(np.float32), bool(runaway[0])


def play_time_quantum(policies) -> float:
    """The time quantum (s) that ``policies`` act at (their ``play_kwargs``' ``time_quantum``, default
    ``TIME_QUANTUM``): a search that references them runs at it. Raises ``ValueError`` if they differ."""
    quanta = {float(play_kwargs_of(p).get("time_quantum", TIME_QUANTUM)) for p in policies}
    if len(quanta) > 1:
        raise ValueError(f"the policies act at different time quanta {sorted(quanta)} s: benchmark them apart")
    return quanta.pop() if quanta else TIME_QUANTUM


# ----------------------------------------------------------------------------------- critical load
def first_stall(masses: np.ndarray, velocity: np.ndarray) -> float:
    """Largest mass of the grid before the velocity first drops to <= 0 (0 if it never moves)."""
    bad = np.flatnonzero(~(np.asarray(velocity) > 0.0))  # NaN (a runaway) stalls too
    if bad.size == 0:
        return float(masses[-1])
    return float(masses[bad[0] - 1]) if bad[0] > 0 else 0.0


def upper_mass(k: float, drive: DriveDescription = PAPER_DRIVE) -> float:
    """A load (kg) above every method's critical load at k on ``drive``: 0.8 of mu F_ref / g (the
    paper drive's trapezoid stalls at 0.18-0.33 of it)."""
    env = gym.make("MDRDrive-v0", k=k, load_ratio=0.8, **drive.env_kwargs).unwrapped
    env.reset(seed=0)
    return env.cargo_mass


def critical_loads(ks, velocity_fn, drive: DriveDescription = PAPER_DRIVE) -> dict[float, float]:
    """Critical load (kg) per k from ``velocity_fn(points) -> velocities`` on a fine load grid (two
    passes of ``CRITICAL_GRID`` loads up to :func:`upper_mass`): the largest load before the
    velocity first drops to <= 0 (or runs away)."""
    out = {}
    for k in ks:
        hi = upper_mass(k, drive)
        masses = np.linspace(0.0, hi, CRITICAL_GRID)
        m1 = first_stall(masses, velocity_fn([(k, m) for m in masses]))
        step = masses[1]
        fine = np.linspace(m1, min(m1 + step, hi), CRITICAL_GRID)  # refine between the last mover and the stall
        out[k] = first_stall(fine, velocity_fn([(k, m) for m in fine])) if m1 < hi else hi
    return out


def trapezoid_critical_load(ks, drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """The trapezoid's critical load (kg) at each k on ``drive`` (:func:`critical_loads`)."""
    crit = critical_loads(sorted(set(ks)), lambda pts: open_loop_velocity(pts, trapezoid_action(drive), drive=drive),
                          drive)
    return np.array([crit[k] for k in ks])


# ------------------------------------------------------------------------------- hidden parameters
def draw_hidden(n: int, seed: int, step_period: int | None = None, drive: DriveDescription = PAPER_DRIVE) -> list[dict]:
    """``n`` draws of the hidden parameters of ``MDRDriveSensor-v0`` on ``drive`` (its own sampling over
    ``DriveDescription.sensor_env_kwargs``' ranges, the first reset seeded ``seed``): k, cargo_mass (kg),
    friction_coefficient, base_friction_coefficient, load_ratio (load / (mu F_ref)) and, with
    ``step_period``, step_cargo_mass (kg): the cargo of a load step before that period."""
    env = gym.make(SENSOR_ID, **drive.sensor_env_kwargs(), max_periods=max(EVAL_PERIODS, (step_period or 0) + 1),
                   load_step_period=None if step_period is None else (step_period, step_period))
    draws = []
    for i in range(n):
        _, info = env.reset(seed=seed if i == 0 else None)
        u = env.unwrapped
        d = {key: float(info[key]) for key in ("k", "cargo_mass", "friction_coefficient", "base_friction_coefficient")}
        d["load_ratio"] = info["load_force"] / (d["friction_coefficient"] * u.force_ref)
        if step_period is not None:
            d["step_cargo_mass"] = float(u.load_step[1])
        draws.append(d)
    return draws


def hidden_point(d: dict) -> tuple[float, float, float, float]:
    """A draw of :func:`draw_hidden` (or a report's ``points`` entry) as a (k, cargo mass kg, mu, mu1)
    point, as :func:`open_loop_velocity` takes it."""
    return d["k"], d["cargo_mass"], d["friction_coefficient"], d["base_friction_coefficient"]


__all__ = ["ACTION_MAP", "AVERAGE_PERIODS", "BELOW_TOLERANCE", "actions_of", "CRITICAL_GRID", "EVAL_PERIODS", "TIME_QUANTUM",
           "critical_loads", "csv_velocity", "MOVING_THRESHOLD", "draw_hidden", "drive_of", "hidden_point", "SENSOR_ID", "play_drive", "env_rollout", "rollout_env", "first_stall", "format_velocity", "open_loop_displacements",
           "open_loop_velocity", "play_kwargs_of", "play_time_quantum", "point_params", "policy_rollout",
           "policy_velocity", "runaway_of", "steady_velocity_of", "trapezoid_action", "trapezoid_critical_load",
           "upper_mass"]
