"""The teacher's data: the points where the student is taught, and the episodes it is taught on.

The distillation (``mdr_drive_agents.student.distill``) fits the student to these. Each episode is a closed-loop run
of ``MDRDrive-v0`` at one (k, load) point, played by the teacher (its drive at that point, a one- or
two-action cycle: ``DriveField.best``) or by the student; every observation is labelled with the
teacher's drive there. Where the points come from:

* ``draw_points``: uniform over the training domain (k, and the load up to ``load_factor`` times the
  trapezoid's critical load);
* ``jump_points`` / ``jump_brackets``: bisection between neighbouring points whose teacher drives
  jump from one optimum to another, so the fit cannot put its blend of the two anywhere in the gap;
* ``stall_points``: loads just around the teacher's stall at random k, where the critical-load target is
  judged (the hole rounds' stall probes);
* ``around``: jittered copies of points where the student fell short of the teacher (the hole rounds).

``perturb_previous_actions`` adds samples whose previous action is off the cycle, labelled as the
cycle implies. ``config`` arguments are ``DistillConfig`` objects (any object with the attributes each
function reads).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from mdr_drive_env import ENV_ID  # importing the package registers the env

from mdr_drive_env.gym_envs.spaces import shift_phase_origin

from ..cycles import align_phase, cycle_action
from ..drive import PAPER_DRIVE, DriveDescription
from ..protocol import TIME_QUANTUM
from ..teacher import PAPER_FRICTION, DriveField


def clipped_k_range(field_: DriveField, k_range: tuple[float, float] | None = None) -> tuple[float, float]:
    """The field's k range, or ``k_range`` clipped to it; a ``ValueError`` if they do not overlap."""
    low, high = float(field_.ks[0]), float(field_.ks[-1])
    if k_range is None:
        return low, high
    if k_range[0] > high or k_range[1] < low:
        raise ValueError(f"k range {list(k_range)} lies outside the teacher's k range [{low:g}, {high:g}]")
    return max(low, k_range[0]), min(high, k_range[1])


def draw_points(field_: DriveField, n: int, rng: np.random.Generator, config,
                friction=None, k_range: tuple[float, float] | None = None) -> list:
    """``n`` (k, cargo mass kg) points: k uniform over the field's range (or ``k_range``, clipped
    to it), the load uniform from 0 to
    ``load_factor`` times the trapezoid's critical load (interpolated from the field's grid), a
    share without load. With ``friction`` ((mu low, high), (mu1 low, high)): (k, cargo mass kg, mu,
    mu1) points, mu and mu1 uniform, the load scaled by mu / 0.3 (the same load over mu F_ref)."""
    low, high = clipped_k_range(field_, k_range)
    ks = rng.uniform(low, high, n)
    crit = np.interp(ks, field_.ks, field_.trapezoid_critical)
    loads = rng.uniform(0.0, config.load_factor, n) * crit
    loads[rng.uniform(size=n) < config.no_load_share] = 0.0
    if friction is None:
        return [(float(k), float(m)) for k, m in zip(ks, loads)]
    mu, mu1 = rng.uniform(*friction[0], n), rng.uniform(*friction[1], n)
    return [(float(k), float(m * a / PAPER_FRICTION[0]), float(a), float(b)) for k, m, a, b in zip(ks, loads, mu, mu1)]


def stall_fractions(field_: DriveField) -> np.ndarray:
    """Per k line of the field, the load (as a fraction of the trapezoid's critical load) where its
    drives' velocity crosses zero, linear between the two :meth:`DriveField.stall_nodes` (their last
    fraction if the whole line moves, 0 if none of it does) (-)."""
    out = np.empty(len(field_.ks))
    for i, j in field_.stall_nodes()[::2]:
        v0, v1 = field_.velocities[i, j], field_.velocities[i, j + 1]
        f0, f1 = field_.fractions[j], field_.fractions[j + 1]
        if v0 <= 0.0:
            out[i] = 0.0
        elif v1 > 0.0:
            out[i] = f1
        else:
            out[i] = f0 + (f1 - f0) * v0 / (v0 - v1)
    return out


def stall_points(field_: DriveField, n: int, rng: np.random.Generator, band: tuple[float, float]) -> list:
    """``n`` (k, cargo mass kg) points: k uniform over the field's range, the load uniform in ``band``
    times the teacher's stall load there (:func:`stall_fractions`, interpolated in k)."""
    ks = rng.uniform(field_.ks[0], field_.ks[-1], n)
    stall = np.interp(ks, field_.ks, stall_fractions(field_) * field_.trapezoid_critical)
    loads = rng.uniform(*band, n) * stall
    return [(float(k), float(m)) for k, m in zip(ks, loads)]


def rollout(points, drives: np.ndarray, act=None, periods: int = 30, seed: int = 0, z_phase_origin: float = 0.0,
            time_quantum: float = TIME_QUANTUM, drive: DriveDescription = PAPER_DRIVE):
    """Play at each (k, load kg) point, or (k, load kg, mu, mu1) point in the privileged observation:
    the teacher's drive (``act`` None) or ``act(obs) -> actions``, in the action units of an env with
    ``z_phase_origin`` (``drives`` too) and ``time_quantum`` (s), on ``drive``. Returns the observations (periods *
    n, 14 or 15), the teacher's drive of each observation's episode (periods * n, 2, 5) and the
    displacements (periods, n) m."""
    n = len(points)
    options = {"k": [p[0] for p in points], "cargo_mass": [p[1] for p in points]}
    kwargs = {**drive.env_kwargs, "z_phase_origin": z_phase_origin, "time_quantum": time_quantum}
    if len(points[0]) == 4:
        kwargs["observation"] = "privileged"
        options.update(friction_coefficient=[p[2] for p in points], base_friction_coefficient=[p[3] for p in points])
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", max_periods=periods, **kwargs)
    prev_slice = venv.template.observation_structure["previous_action"]
    obs, _ = venv.reset(seed=seed, options=options)
    all_obs, disp = [], []
    for _ in range(periods):
        all_obs.append(obs.copy())
        action = cycle_action(drives, obs[:, prev_slice]) if act is None else act(obs)
        obs, _, _, _, info = venv.step(np.clip(np.asarray(action).reshape(n, 5), -1.0, 1.0).astype(np.float32))
        disp.append(info["displacement"])
    return np.concatenate(all_obs), np.tile(drives, (periods, 1, 1)), np.array(disp)


def perturb_previous_actions(obs: np.ndarray, drives: np.ndarray, rng: np.random.Generator, share: float,
                             prev_slice: slice) -> np.ndarray:
    """``obs`` with the previous action of a ``share`` of the samples replaced: half by one of the
    drive's own actions plus Gaussian noise (std 0.02-0.3), half uniform in the box. The label
    follows from the drive (``cycle_action``), so such samples are free, and they teach the student
    to come back to its cycle from wherever its last action went (a network fitted only on exact
    cycles maps a previous action between the two halfway between them, and the cycle decays)."""
    out = obs.copy()
    pick = np.flatnonzero(rng.uniform(size=len(obs)) < share)
    near = rng.uniform(size=len(pick)) < 0.5
    which = rng.integers(0, 2, len(pick))
    scale = rng.choice([0.02, 0.1, 0.3], len(pick))[:, None]
    noisy = drives[pick, which] + rng.normal(size=(len(pick), 5)) * scale
    out[pick, prev_slice] = np.clip(np.where(near[:, None], noisy, rng.uniform(-1.0, 1.0, (len(pick), 5))), -1.0, 1.0)
    return out


def teacher_drives(field_, points, config) -> tuple[np.ndarray, np.ndarray]:
    """The recipe's teacher at ``points``: drives (n, 2, 5) and velocities (n,) m/s from
    ``field_.best`` with ``config.teacher_radius`` (and ``teacher_load_radius``, if set); with
    ``config.action_codebook``, the grid's own drives only (no interpolation: every action is one of
    :func:`grid_actions` once quantum-centred); with ``config.teacher_load_band``, the pick that
    holds over that band of load (``LoadBand``)."""
    reach = {"radius": config.teacher_radius}
    if config.teacher_load_radius:
        reach["load_radius"] = config.teacher_load_radius
    if config.teacher_load_band:
        reach["load_band"] = config.load_band()
    if config.action_codebook:
        return field_.best(points, interpolation=False, **reach)
    return field_.best(points, **reach)


def grid_actions(field_) -> np.ndarray:
    """The distinct actions of the grid drives and point drives of ``field_`` (a ``DriveField``, or
    every field of a ``FrictionField``) at their time quanta's centres (``ActionMap.quantum_centre``),
    sorted: (N, 5), the codebook a student picks from."""
    fields = getattr(field_, "fields", [field_])
    actions = np.concatenate([a for f in fields for a in (f.drives.reshape(-1, 5), f.point_drives.reshape(-1, 5))])
    return np.unique(field_.drive.action_map().quantum_centre(actions), axis=0)


def labelled_episodes(field_: DriveField, points, act, config, seed: int, z_phase_origin: float = 0.0,
                      time_quantum: float = TIME_QUANTUM,
                      drives: np.ndarray | None = None):
    """Episodes of ``config.periods`` periods at ``points``, played by the teacher (``act`` None) or by
    ``act``: their observations and each one's teacher drive (``rollout``; the teacher's drive at each
    point from :func:`teacher_drives` unless ``drives`` (n, 2, 5) gives them), all in the action
    units of an env with ``z_phase_origin`` (the field's drives are in the default units, origin 0),
    played in an env with ``time_quantum`` (s). With ``config.quantum_centres`` the labels sit at the
    centres of the default quantum, whose waveforms every quantum dividing it plays alike."""
    if drives is None:
        drives, _ = teacher_drives(field_, points, config)
    if config.quantum_centres:
        drives = field_.drive.action_map().quantum_centre(drives)
    drives = shift_phase_origin(drives, 0.0, z_phase_origin)
    obs, sample_drives, _ = rollout(points, drives, act, config.periods, seed=seed, z_phase_origin=z_phase_origin,
                                    time_quantum=time_quantum, drive=field_.drive)
    return obs, sample_drives


def drive_difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The largest component difference (action units) between drives ``a`` and ``b`` (n, 2, 5), each
    pair compared in the cycle phase that brings them closest (``align_phase``)."""
    return np.abs(align_phase(b, a) - a).max(axis=(1, 2))


def jump_points(field_: DriveField, points, drives: np.ndarray, config) -> tuple[list, np.ndarray]:
    """The points and teacher drives :func:`jump_brackets` adds (its bisection midpoints)."""
    new_points, new_drives, _ = jump_brackets(field_, points, drives, config)
    return new_points, new_drives


def neighbour_coordinates(field_: DriveField, pts: np.ndarray, load_factor: float) -> np.ndarray:
    """Where ``jump_brackets`` finds neighbours: (k, load kg) points (n, 2) as k over the field's k
    range and the load over ``load_factor`` times the trapezoid's critical load; (k, load kg, mu, mu1)
    points (n, 4) of a ``FrictionField`` as k, the load at its first field's friction
    (``DriveField.field_load``, the field whose critical loads it keeps) over that critical load, and
    mu1 / mu over the fields' range of it.

    Points of different friction at the same (k, load) are then as far apart as what changes the
    drive: mu1 / mu and the load relative to mu, not the unscaled load (which alone would count
    neighbours of different friction as jumps). Returns (n, 2) or (n, 3) coordinates (-)."""
    crit = np.interp(pts[:, 0], field_.ks, field_.trapezoid_critical) * load_factor
    span = field_.ks[-1] - field_.ks[0]
    if pts.shape[1] == 2:
        return np.c_[pts[:, 0] / span, pts[:, 1] / np.maximum(crit, 1e-12)]
    loads = np.array([field_.fields[0].field_load(p) for p in pts])
    rhos = field_.rhos
    rho = pts[:, 3] / pts[:, 2]
    return np.c_[pts[:, 0] / span, loads / np.maximum(crit, 1e-12), (rho - rhos[0]) / max(rhos[-1] - rhos[0], 1e-12)]


def jump_brackets(field_: DriveField, points, drives: np.ndarray, config):
    """Points (and their teacher drives) that locate where the teacher's drive jumps, found by
    bisection between ``points`` and their ``config.jump_neighbours`` nearest neighbours (in
    ``neighbour_coordinates``: k, the load relative to the critical load, and mu1 / mu) whose
    drives differ (``drive_difference`` > ``config.jump_threshold``): every level adds the pairs'
    midpoints and keeps the halves whose ends still differ, ``config.jump_levels`` levels.

    The student is a smooth function of (k, load): across a jump it blends the two drives, and a
    blend of two optima is not one. Round 0's random points lie about 1.5 % of the domain apart, so
    the fit can put its blend anywhere in that gap; points on both sides of the jump, a few levels
    of bisection closer, narrow it.

    Returns the added points (list of (k, load kg) or (k, load kg, mu, mu1)), their drives (m, 2, 5) and the brackets the
    last level leaves: their ends (b, 2) and (b, 2) and the ends' drives (b, 2, 5) and (b, 2, 5)."""
    from scipy.spatial import cKDTree

    pts = np.array([tuple(p) for p in points], dtype=np.float64)
    coords = neighbour_coordinates(field_, pts, config.load_factor)
    _, idx = cKDTree(coords).query(coords, k=min(config.jump_neighbours + 1, len(pts)))
    pairs = np.unique(np.sort(np.c_[np.repeat(np.arange(len(pts)), idx.shape[1] - 1), idx[:, 1:].ravel()], axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    jumped = drive_difference(drives[pairs[:, 0]], drives[pairs[:, 1]]) > config.jump_threshold
    a, b = pts[pairs[jumped, 0]], pts[pairs[jumped, 1]]
    da, db = drives[pairs[jumped, 0]], drives[pairs[jumped, 1]]
    new_points, new_drives = [], []
    for _ in range(config.jump_levels):
        if not len(a):
            break
        mid = 0.5 * (a + b)
        mid_points = [tuple(map(float, m)) for m in mid]
        dm, _ = teacher_drives(field_, mid_points, config)
        new_points += mid_points
        new_drives.append(dm)
        left = drive_difference(da, dm) > config.jump_threshold
        right = drive_difference(dm, db) > config.jump_threshold
        a = np.concatenate([a[left], mid[right]])
        b = np.concatenate([mid[left], b[right]])
        da, db = np.concatenate([da[left], dm[right]]), np.concatenate([dm[left], db[right]])
    return new_points, np.concatenate(new_drives) if new_drives else np.zeros((0, 2, 5)), (a, b, da, db)


def around(points, n: int, rng: np.random.Generator, k_range: tuple[float, float]) -> list:
    """Each point and ``n`` jittered copies: k +- 0.01 (kept in ``k_range``), load +- 5 % (friction,
    of (k, load, mu, mu1) points, kept)."""
    out = []
    for k, m, *friction in points:
        out.append((k, m, *friction))
        for _ in range(n):
            out.append((float(np.clip(k + rng.uniform(-0.01, 0.01), *k_range)), float(m * rng.uniform(0.95, 1.05)),
                        *friction))
    return out


__all__ = ["around", "draw_points", "drive_difference", "jump_brackets", "jump_points", "labelled_episodes",
           "neighbour_coordinates",
           "grid_actions", "perturb_previous_actions", "rollout", "stall_fractions", "stall_points", "teacher_drives"]
