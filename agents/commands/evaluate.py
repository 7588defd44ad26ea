"""``mdr-drive evaluate``: a policy against the paper's trapezoid at given points (steady
velocities) or k values (critical loads), printed as text or JSON, with a warning for points outside
the range the policy was trained for (its ``run.json``). The protocol itself (steady velocity,
critical load) is ``mdr_drive_agents.protocol``.

    mdr-drive evaluate --policy agents/pretrained/ppo_generalist --k 0.2 --cargo-mass 0.1 --json
    mdr-drive evaluate --policy agents/pretrained/ppo_generalist --k 0.1 0.3 --critical-load --json
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ..drive import PAPER_DRIVE, WHY_MU_EXCEEDS_MU1, DriveDescription
from ..policy import OBSERVATION_KEYS, load_policy, package_path
from ..protocol import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    TIME_QUANTUM,
    critical_loads,
    env_rollout,
    format_velocity,
    open_loop_displacements,
    play_drive,
    policy_rollout,
    policy_velocity,
    steady_velocity_of,
    trapezoid_action,
    trapezoid_critical_load,
)

#: The options (and env keywords) of the friction pair: indenter-slider mu, slider-base mu1.
FRICTION_OPTIONS = ("friction_coefficient", "base_friction_coefficient")

HELP = "a trained policy against the trapezoid at given points"
DESCRIPTION = ("Steady velocities (or critical loads) of a policy and of the paper's trapezoid at given points, by the "
               "evaluation protocol (30 periods, the mean of the last 10): text, or JSON in SI units. A policy plays "
               "on the drive it was built for (its run.json), and so does the trapezoid it is compared with, at the "
               "drive's nominal friction pair unless --friction-coefficient or --base-friction-coefficient names "
               "another (a sensor policy trained on drawn friction included). Points, load steps and friction "
               "outside what the policy was trained on are played, with a warning.")


def load_step_type(text: str) -> tuple[int, float]:
    """argparse type: ``PERIOD:MASS``, the period (>= 1) at which the cargo becomes MASS kg (>= 0)."""
    try:
        period, mass = text.split(":")
        period, mass = int(period), float(mass)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not PERIOD:MASS (e.g. 15:0.2)") from None
    if period < 1 or not (mass >= 0.0 and np.isfinite(mass)):
        raise argparse.ArgumentTypeError(f"{text!r}: the period must be >= 1 and the mass >= 0 kg")
    return period, mass


def policy_path(text: str) -> str:
    """argparse type: a trained policy's folder (with model.zip); ``agents/...`` names the package's own
    (``policy.package_path``), from any working directory."""
    from mdr_drive_env.cli_args import folder_with

    return str(folder_with("model.zip")(str(package_path(text))))


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli import add_variant_argument

    p.add_argument("--policy", required=True, type=policy_path,
                   help="policy folder (model.zip, vecnormalize.npz, run.json), read as data")
    p.add_argument("--trust-pickle", action="store_true",
                   help="read a folder that has only SB3's vecnormalize.pkl: a pickle runs code when read, so only "
                        "for a folder from a source you trust")
    p.add_argument("--k", type=float, nargs="+", required=True, metavar="K",
                   help="grading exponent(s) k, in [0, 1); several values pair with --cargo-mass (-)")
    p.add_argument("--cargo-mass", type=float, nargs="+", default=None, metavar="M",
                   help="cargo mass(es) m, >= 0, one per --k value (kg)")
    p.add_argument("--critical-load", action="store_true",
                   help="instead of velocities: per --k value, the critical load of the policy and of the "
                        "trapezoid (the largest cargo mass they still move forward, kg)")
    p.add_argument("--json", action="store_true",
                   help="print JSON: one object for one point (or k), a list for several; velocities in m/s, "
                        "null where the load runs away with the slider; critical loads in kg")
    from mdr_drive_env.cli_args import int_range

    p.add_argument("--friction-coefficient", type=float, default=None,
                   help="indenter-slider friction mu, > mu1 (-); default: the drive's nominal value (the paper "
                        "drive's 0.3; the middle of a trained range), whatever the policy was trained on")
    p.add_argument("--base-friction-coefficient", type=float, default=None,
                   help="slider-base friction mu1, >= 0 and < mu (-); default: the drive's nominal value (the "
                        "paper drive's 0.1; the middle of a trained range)")
    p.add_argument("--periods", type=int_range(AVERAGE_PERIODS, 100_000), default=EVAL_PERIODS,
                   help=f"periods per run; the steady velocity is the mean of the last {AVERAGE_PERIODS} (-)")
    p.add_argument("--load-step", type=load_step_type, default=None, metavar="PERIOD:MASS",
                   help="the cargo becomes MASS (kg) before period PERIOD (counted from 0) is simulated")
    add_variant_argument(p)
    from . import add_drive_argument

    add_drive_argument(p, "to check the policy was built for (it always plays on its own)")


def trained_range_warnings(run: dict, points, friction: dict | None = None,
                           drive: DriveDescription = PAPER_DRIVE) -> list[str]:
    """Warnings for (k, cargo mass kg) ``points`` outside the k and load ranges the policy was trained
    on (run.json), and for friction coefficients (``friction``: option name -> value) it was not
    trained with, on ``drive``. Its loads are fractions of mu F_ref (``load_ratio``), so the largest
    trained mass at a point is taken at the mu played there (``friction``, else the drive's nominal)."""
    env = run.get("env_kwargs", {})
    k_range = env.get("k")
    warnings = []
    defaults = dict(zip(FRICTION_OPTIONS, PAPER_DRIVE.nominal_friction))  # the env's
    for name, value in (friction or {}).items():
        trained = env.get(name, defaults[name])
        low, high = (trained, trained) if np.ndim(trained) == 0 else trained
        if not low <= value <= high:
            warnings.append(f"{name.replace('_', ' ')} {value:g} is outside the trained "
                            f"{'value' if low == high else 'range'} {low:g}" + ("" if low == high else f"-{high:g}"))
    if isinstance(k_range, (list, tuple)) and len(k_range) == 2:
        outside = sorted({k for k, _ in points if not k_range[0] <= k <= k_range[1]})
        if outside:
            warnings.append(f"k = {', '.join(f'{k:g}' for k in outside)} is outside the trained range "
                            f"[{k_range[0]:g}, {k_range[1]:g}]")
    ratio = env.get("load_ratio")
    if isinstance(ratio, (list, tuple)) and len(ratio) == 2:
        mu = (friction or {}).get("friction_coefficient", drive.nominal_friction[0])
        for k, m in points:
            hi = ratio[1] * drive.reference_force(k, mu) / drive.params(k, 0.0).drive.gravity
            if m > hi * (1 + 1e-9):
                warnings.append(f"m = {m:g} kg at k = {k:g} is above the trained loads (load ratio <= "
                                f"{ratio[1]:g} of mu F_ref at mu {mu:g}, i.e. m <= {hi:.4g} kg)")
    return warnings


def friction_played(args: argparse.Namespace, drive: DriveDescription) -> dict:
    """The friction pair a run plays (option name -> value): each coefficient as given, else the drive's
    nominal one (``DriveDescription.nominal_friction``). ``ValueError`` for a pair no drive moves
    under (mu <= mu1), as a drive file refuses it."""
    given = {name: getattr(args, name) for name in FRICTION_OPTIONS if getattr(args, name) is not None}
    friction = {**dict(zip(FRICTION_OPTIONS, drive.nominal_friction)), **given}
    mu, mu1 = (friction[name] for name in FRICTION_OPTIONS)
    if not (np.isfinite(mu) and np.isfinite(mu1) and mu1 >= 0.0):
        raise ValueError(f"--friction-coefficient {mu:g} and --base-friction-coefficient {mu1:g} must be finite, "
                         "mu1 >= 0")
    if mu <= mu1:
        raise ValueError(f"--friction-coefficient {mu:g} must exceed --base-friction-coefficient {mu1:g}: "
                         f"{WHY_MU_EXCEEDS_MU1}")
    return friction


def _velocity_record(k, m, drive: DriveDescription, learned, trapezoid, last_action,
                     time_quantum: float = TIME_QUANTUM) -> dict:
    """One point's JSON record; the last action's waveform as the policy's env quantises it (s)."""
    return {"k": k, "cargo_mass": m, "variant": drive.env_kwargs.get("variant", "as-specified"), "drive": drive.name,
            "learned_mean_velocity": None if np.isnan(learned) else float(learned),
            "trapezoid_mean_velocity": None if np.isnan(trapezoid) else float(trapezoid),
            "learned_runaway": bool(np.isnan(learned)), "trapezoid_runaway": bool(np.isnan(trapezoid)),
            "learned_waveform_last_period": drive.action_map(time_quantum).to_params(last_action)._asdict(),
            "protocol": f"mean over periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}, m/s"}


def _speed(v: float) -> str:
    """A steady velocity (m/s) for the text output: in mm/s, or "runaway" (no velocity, no unit)."""
    text = format_velocity(v, digits=3)
    return text if text == "runaway" else f"{text} mm/s"


def main(args: argparse.Namespace) -> int:
    import sys

    ks = list(args.k)
    if args.critical_load:
        if args.cargo_mass is not None:
            raise ValueError("--critical-load finds the load itself: give --k only, not --cargo-mass")
        points = [(k, 0.0) for k in ks]
    else:
        if args.cargo_mass is None:
            raise ValueError("--cargo-mass is required (one value per --k value), unless --critical-load")
        if len(args.cargo_mass) != len(ks):
            raise ValueError(f"--k and --cargo-mass pair up: got {len(ks)} and {len(args.cargo_mass)} values")
        points = list(zip(ks, args.cargo_mass))
    for k, m in points:  # bad values fail here, with the option's name, before the policy loads
        try:
            (args.drive or PAPER_DRIVE).params(k, m)
        except ValueError as e:
            from mdr_drive_env.cli import FIELD_OPTIONS, with_option_name

            raise with_option_name(e, FIELD_OPTIONS) from None
    policy = load_policy(args.policy, trust_pickle=args.trust_pickle)
    drive = play_drive([policy], args.drive)  # the drive it was built for; --drive must name the same
    if args.variant != "as-specified":
        drive = drive.with_settings(variant=args.variant)
    env_kwargs = policy.play_kwargs
    friction = friction_played(args, drive)  # as given, else the drive's nominal pair: never drawn
    explicit = any(getattr(args, name) is not None for name in FRICTION_OPTIONS)
    if args.load_step is not None and args.load_step[0] >= args.periods:
        raise ValueError(f"--load-step period {args.load_step[0]} is not before the last of --periods {args.periods}")
    stepped = [] if args.load_step is None else [(k, args.load_step[1]) for k, _ in points]
    for warning in trained_range_warnings(policy.run, ([] if args.critical_load else points) + stepped, friction,
                                          drive):
        print(f"mdr-drive evaluate: warning: {warning}", file=sys.stderr)
    pair = f"mu {friction['friction_coefficient']:g}, mu1 {friction['base_friction_coefficient']:g}"
    shaped = [key for key in env_kwargs if key in OBSERVATION_KEYS]  # a sensor or privileged observation
    single_env = bool(shaped or explicit or args.load_step or args.periods != EVAL_PERIODS)
    if args.critical_load and single_env:
        raise ValueError("--critical-load uses the fixed protocol: without --friction-coefficient, "
                         "--base-friction-coefficient, --load-step, --periods, and for full-observation policies")
    if args.critical_load:
        learned = critical_loads(ks, lambda pts: policy_velocity(policy, pts, drive=drive), drive)
        trap = trapezoid_critical_load(ks, drive)
        records = [{"k": k, "critical_load_learned": learned[k], "critical_load_trapezoid": float(t),
                    "variant": args.variant, "drive": drive.name, **friction} for k, t in zip(ks, trap)]
        text = [f"k = {r['k']:g}: critical load policy {r['critical_load_learned']:.4f} kg, "
                f"trapezoid {r['critical_load_trapezoid']:.4f} kg ({pair})" for r in records]
    else:
        if single_env:  # one single env per run: sensor policies, other frictions, load steps
            kw = {**env_kwargs, **friction}
            runs = [(env_rollout(policy, k, m, args.periods, args.load_step, drive=drive, **kw),
                     env_rollout(None, k, m, args.periods, args.load_step, drive=drive, **{
                         **{key: v for key, v in kw.items() if key not in OBSERVATION_KEYS}, "observation": "full"}))
                    for k, m in points]
            v_learned = np.array([r[0][0] for r in runs]).T  # (periods, n) m/s
            v_trap = np.array([r[1][0] for r in runs]).T
            acts = np.array([r[0][1] for r in runs]).transpose(1, 0, 2)
            learned = steady_velocity_of(v_learned * drive.period, runaway=[r[0][2] for r in runs], period=drive.period)
            trapezoid = steady_velocity_of(v_trap * drive.period, runaway=[r[1][2] for r in runs], period=drive.period)
        else:
            disp, acts, runaway = policy_rollout(policy, points, drive=drive)  # at the drive's nominal pair
            learned = steady_velocity_of(disp, runaway=runaway, period=drive.period)
            disp_trap, runaway_trap = open_loop_displacements(points, trapezoid_action(drive), drive=drive)
            trapezoid = steady_velocity_of(disp_trap, runaway=runaway_trap, period=drive.period)
            v_learned, v_trap = disp / drive.period, disp_trap / drive.period
        quantum = float(env_kwargs.get("time_quantum", TIME_QUANTUM))
        records = [_velocity_record(k, m, drive, lv, tv, acts[-1, i], quantum)
                   for i, ((k, m), lv, tv) in enumerate(zip(points, learned, trapezoid))]
        for i, r in enumerate(records):
            r["learned_period_velocity"] = v_learned[:, i].tolist()
            r["trapezoid_period_velocity"] = v_trap[:, i].tolist()
            r.update(periods=args.periods, load_step=args.load_step, **friction)
            r["protocol"] = f"mean over periods {args.periods - AVERAGE_PERIODS + 1}-{args.periods}, m/s"
        step = "" if args.load_step is None else f"; the cargo becomes {args.load_step[1]:g} kg before period " \
                                                   f"{args.load_step[0]}"
        text = [f"k = {k:g}, m = {m:g} kg: policy {_speed(lv)}, trapezoid {_speed(tv)} (mean of periods "
                f"{args.periods - AVERAGE_PERIODS + 1}-{args.periods}; {pair}{step}; fast numerics)"
                for (k, m), lv, tv in zip(points, learned, trapezoid)]
    if args.json:
        print(json.dumps(records[0] if len(records) == 1 else records))
    else:
        print("\n".join(text))
    return 0


__all__ = ["FRICTION_OPTIONS", "add_arguments", "friction_played", "load_step_type", "main", "policy_path",
           "trained_range_warnings"]
