"""``mdr-drive``: command-line interface. Every option is in SI units unless its help says otherwise."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import sys
import time

from . import __version__
from .core import (
    NUMERICS_PRESETS,
    AxisWaveform,
    Contact,
    Drive,
    DriveParams,
    DriveSimulator,
    Material,
    Numerics,
    Waveform,
    concat_traces,
    numerics_preset,
)
from .core import kernel as K
from .core.waveform import PAPER_X, PAPER_Z

_F = argparse.ArgumentDefaultsHelpFormatter


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is outside the allowed range [1, inf)")
    return value


def add_model_arguments(p: argparse.ArgumentParser) -> None:
    """Options for the physical model (DriveParams) and the numerics."""
    m = p.add_argument_group("material (both bodies, unless --rigid-indenter)")
    m.add_argument("--k", type=float, default=0.0, help="grading exponent k of E(z) = E0 (z/c0)^k, in [0, 1) (-)")
    m.add_argument("--youngs-modulus", type=float, default=2e11, help="E0 (Pa)")
    m.add_argument("--poisson-ratio", type=float, default=0.3, help="nu, in (-1, 0.5] (-)")
    m.add_argument("--reference-depth", type=float, default=1.0, help="c0 (m)")
    m.add_argument("--rigid-indenter", action="store_true", help="rigid indenter on the graded slider")
    m.add_argument("--h-normal", type=float, default=None, help="override h_N(k, nu) (-)")
    m.add_argument("--h-tangential", type=float, default=None, help="override h_T(k, nu) (-)")
    c = p.add_argument_group("contact")
    c.add_argument("--indenter-radius", type=float, default=2.5e-3, help="R of the paraboloid (m)")
    c.add_argument("--mu", type=float, default=0.3, help="indenter-slider friction coefficient (-)")
    c.add_argument("--mu1", type=float, default=0.1, help="slider-base friction coefficient (-)")
    d = p.add_argument_group("drive")
    d.add_argument("--slider-mass", type=float, default=0.05, help="slider mass M (kg)")
    d.add_argument("--cargo-mass", type=float, default=0.0, help="cargo mass m; load F_m = m g (kg)")
    d.add_argument("--load-force", type=float, default=None, help="load F_m, replaces m g (N)")
    d.add_argument("--gravity", type=float, default=9.81, help="g (m/s^2)")
    d.add_argument("--cargo-inertia", action="store_true", help="the cargo moves with the slider (mass M + m)")
    n = p.add_argument_group("numerics")
    n.add_argument("--numerics", default="default", choices=sorted(NUMERICS_PRESETS),
                   help="preset: paper = dt 1e-7 s, dx 1e-8 m; default = dt 1e-6 s, dx 1e-7 m; "
                        "fast = the node solver (docs/performance.md)")
    n.add_argument("--dt", type=float, default=None, help="override the preset's time step (s)")
    n.add_argument("--dx", type=float, default=None, help="override the preset's spring spacing (m)")


def add_waveform_arguments(p: argparse.ArgumentParser) -> None:
    """Options for the indenter waveform (defaults: the paper's Fig. 2)."""
    w = p.add_argument_group("waveform (asymmetric triangle per axis; defaults are the paper's)")
    w.add_argument("--x-amplitude", type=float, default=PAPER_X.amplitude, help="x amplitude (m)")
    w.add_argument("--x-rise-time", type=float, default=PAPER_X.rise_time, help="x rise time t1 (s)")
    w.add_argument("--x-fall-time", type=float, default=PAPER_X.fall_time, help="x fall time t2 (s)")
    w.add_argument("--z-amplitude", type=float, default=PAPER_Z.amplitude, help="z amplitude = max depth (m)")
    w.add_argument("--z-rise-time", type=float, default=PAPER_Z.rise_time, help="z rise time (s)")
    w.add_argument("--z-fall-time", type=float, default=PAPER_Z.fall_time, help="z fall time (s)")
    w.add_argument("--z-phase", type=float, default=0.0, help="z delay as a fraction of the period, in [0, 1) (-)")


def params_from_args(a: argparse.Namespace) -> DriveParams:
    graded = Material(youngs_modulus=a.youngs_modulus, poisson_ratio=a.poisson_ratio, grading_exponent=a.k,
                      reference_depth=a.reference_depth, h_normal_override=a.h_normal,
                      h_tangential_override=a.h_tangential)
    return DriveParams(
        indenter=Material.rigid() if a.rigid_indenter else graded,
        slider=graded,
        contact=Contact(indenter_radius=a.indenter_radius, friction_coefficient=a.mu, base_friction_coefficient=a.mu1),
        drive=Drive(slider_mass=a.slider_mass, cargo_mass=a.cargo_mass, gravity=a.gravity, load_force=a.load_force,
                    cargo_inertia=a.cargo_inertia),
    )


def numerics_from_args(a: argparse.Namespace) -> Numerics:
    base = numerics_preset(a.numerics)
    return Numerics(time_step=a.dt if a.dt is not None else base.time_step,
                    spring_spacing=a.dx if a.dx is not None else base.spring_spacing)


def waveform_from_args(a: argparse.Namespace) -> Waveform:
    return Waveform(x=AxisWaveform(a.x_amplitude, a.x_rise_time, a.x_fall_time),
                    z=AxisWaveform(a.z_amplitude, a.z_rise_time, a.z_fall_time), z_phase=a.z_phase)


def _jsonable(obj):
    if dataclasses.is_dataclass(obj):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, float) and math.isinf(obj):
        return "inf"
    return obj


def plot_run(results, path: str, title: str, mu: float = 0.3) -> None:
    """X(t), indenter x(t), z(t) and the contact forces of a run, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = concat_traces(results)
    t = tr[:, K.T_TIME] * 1e3
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a1.plot(t, tr[:, K.T_X] * 1e6, label="indenter x", lw=0.8)
    a1.plot(t, tr[:, K.T_Z] * 1e6 * 5, label="indenter z (x5)", lw=0.8)
    a1.plot(t, tr[:, K.T_SLIDER_X] * 1e6, label="slider X", lw=1.5)
    a1.set(ylabel="position (um)", title=title)
    a2.plot(t, tr[:, K.T_FX], label="F_x", lw=0.8)
    a2.plot(t, tr[:, K.T_FZ] * mu, label="mu F_z (Coulomb bound)", lw=0.8)
    a2.set(xlabel="t (ms)", ylabel="force (N)")
    for a in (a1, a2):
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def cmd_simulate(a: argparse.Namespace) -> int:
    params, numerics, waveform = params_from_args(a), numerics_from_args(a), waveform_from_args(a)
    sim = DriveSimulator(params, numerics, max_depth=max(waveform.max_depth, 1e-9))
    record = a.record_every or (max(1, int(round(1e-5 / numerics.time_step))) if a.plot else 0)
    t0 = time.perf_counter()
    results = sim.run(waveform, a.periods, record_every=record)
    wall = time.perf_counter() - t0
    if a.plot:
        plot_run(results, a.plot, f"k = {params.k:g}, m = {params.drive.cargo_mass:g} kg ({a.numerics} numerics)",
                 mu=params.contact.friction_coefficient)
    v = [r.mean_velocity for r in results]
    if a.json:
        fields = [f.name for f in dataclasses.fields(results[0]) if f.name != "trace"]
        print(json.dumps({
            "period_mean_velocity": v,
            "period_displacement": [r.displacement for r in results],
            "periods": [{f: getattr(r, f) for f in fields} for r in results],
            "params": _jsonable(params),
            "numerics": _jsonable(numerics),
            "waveform": _jsonable(waveform),
            "load_force": params.drive.load,
            "wall_time_s": wall,
        }))
    else:
        print(f"k = {params.k:g}, load F_m = {params.drive.load:.4g} N, {a.periods} periods "
              f"({numerics.time_step:g} s, {numerics.spring_spacing:g} m) in {wall:.2f} s")
        print(" period   displacement (um)   mean velocity (mm/s)   peak F_x (N)   peak F_z (N)")
        for i, r in enumerate(results, 1):
            print(f"{i:7d} {r.displacement * 1e6:19.4f} {r.mean_velocity * 1e3:22.4f} "
                  f"{r.peak_tangential_force:14.3f} {r.peak_normal_force:14.3f}")
        if a.plot:
            print(f"plot: {a.plot}")
    return 0


def cmd_reproduce(a: argparse.Namespace) -> int:
    from .reproduce import reproduce

    summary = reproduce(a.out, numerics=a.numerics, periods=a.periods, workers=a.workers, quick=a.quick)
    print(json.dumps(summary, indent=2))
    print(f"figures and CSVs in {a.out}/")
    return 0


def cmd_bench(a: argparse.Namespace) -> int:
    from .bench import run

    res = run(a.out, quick=a.quick)
    print((__import__("pathlib").Path(a.out) / "bench_speed.md").read_text())
    return 0 if res["accuracy_fast"]["max_error_over_tolerance"] <= 1.0 else 1


#: Subcommands implemented in agents/: (name, help, description).
AGENT_COMMANDS = (
    ("train", "train a waveform policy (needs the train extra)",
     "Train PPO or SAC on MDRDrive-v0 (agents/train.py); see docs/results.md."),
    ("evaluate", "a trained policy against the trapezoid at one point",
     "Steady velocity of a policy and of the paper's trapezoid (agents/evaluate.py)."),
    ("benchmark", "learned vs trapezoid vs CMA-ES over k and load",
     "The waveform benchmark (agents/benchmark.py); writes results/benchmark/."),
    ("demo", "the README's demo (make demo)",
     "Simulate the paper's drive, then run the shipped policy against the trapezoid."),
)


def _agents_arguments(p: argparse.ArgumentParser, module: str) -> None:
    try:
        mod = __import__(f"agents.{module}", fromlist=["add_arguments"])
    except ImportError as e:  # the train extra is missing
        p.set_defaults(_import_error=str(e))
        return
    mod.add_arguments(p)


def _agents_main(module: str, a: argparse.Namespace) -> int:
    if getattr(a, "_import_error", None):
        print(f"mdr-drive {module} needs the train extra (pip install -e '.[train]'): {a._import_error}",
              file=sys.stderr)
        return 2
    return __import__(f"agents.{module}", fromlist=["main"]).main(a)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mdr-drive", description=__doc__, formatter_class=_F)
    parser.add_argument("--version", action="version", version=f"mdr-drive {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", formatter_class=_F, help="simulate the drive for N periods",
                       description="Simulate the drive with a fixed waveform; print per-period results.")
    add_model_arguments(s)
    add_waveform_arguments(s)
    o = s.add_argument_group("output")
    o.add_argument("--periods", type=positive_int, default=6, help="drive periods to simulate (-)")
    o.add_argument("--record-every", type=int, default=0, help="trace row every N time steps (0: auto with --plot) (-)")
    o.add_argument("--plot", metavar="OUT.png", default=None, help="write X(t), x(t), z(t), F_x, F_z as a PNG")
    o.add_argument("--json", action="store_true", help="print one JSON object (per-period results, params)")
    s.set_defaults(func=cmd_simulate)

    r = sub.add_parser("reproduce", formatter_class=_F, help="reproduce the paper's Figs. 3-5",
                       description="Write Figs. 3, 4, 5 and the h_N/h_T sensitivity plot as PNG + CSV.")
    r.add_argument("--out", default="results/paper", help="output folder")
    r.add_argument("--numerics", default="paper", choices=sorted(NUMERICS_PRESETS), help="numerics preset")
    r.add_argument("--periods", type=positive_int, default=10, help="periods shown in Figs. 3 and 4 (-)")
    r.add_argument("--workers", type=int, default=None, help="processes (default: available cores)")
    r.add_argument("--quick", action="store_true", help="a small subset of the cases (for CI)")
    r.set_defaults(func=cmd_reproduce)

    b = sub.add_parser("bench", formatter_class=_F, help="speed and accuracy of the solvers",
                       description="Periods/s of the kernels, env and vector env; accuracy of the fast solver "
                                   "against the paper preset on the k x load x waveform grid.")
    b.add_argument("--out", default="results/bench", help="output folder (bench_speed.json, bench_speed.md)")
    b.add_argument("--quick", action="store_true", help="shorter timing blocks")
    b.set_defaults(func=cmd_bench)

    for name, help_text, description in AGENT_COMMANDS:  # implemented in agents/ (the train extra)
        a = sub.add_parser(name, formatter_class=_F, help=help_text, description=description)
        _agents_arguments(a, name)
        a.set_defaults(func=functools.partial(_agents_main, name))
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as e:
        print(f"mdr-drive: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

