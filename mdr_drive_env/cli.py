"""``mdr-drive``: command-line interface. Every option is in SI units unless its help says otherwise."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import os
import sys
import time
from pathlib import Path

from . import __version__
from .cli_args import Parser, int_range, output_dir, output_file, positive_int
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
    numerics_preset,
)
from .core.simulator import check_numerics
from .core.params import VARIANTS
from .plotting import plot_run
from .sweep import add_executor_arguments
from .core.waveform import PAPER_X, PAPER_Z

#: One home for what a model option is called on the command line: dataclass field -> option.
FIELD_OPTIONS = {
    "Material.youngs_modulus": "--youngs-modulus",
    "Material.poisson_ratio": "--poisson-ratio",
    "Material.grading_exponent": "--k",
    "Material.reference_depth": "--reference-depth",
    "Material.h_normal_override": "--h-normal",
    "Material.h_tangential_override": "--h-tangential",
    "Contact.indenter_radius": "--indenter-radius",
    "Contact.friction_coefficient": "--mu",
    "Contact.base_friction_coefficient": "--mu1",
    "Drive.slider_mass": "--slider-mass",
    "Drive.cargo_mass": "--cargo-mass",
    "Drive.gravity": "--gravity",
    "Drive.load_force": "--load-force",
    "Numerics.time_step": "--dt",
    "Numerics.spring_spacing": "--dx",
}
#: The waveform's fields, per axis.
AXIS_OPTIONS = {"AxisWaveform.amplitude": "--{axis}-amplitude", "AxisWaveform.rise_time": "--{axis}-rise-time",
                "AxisWaveform.fall_time": "--{axis}-fall-time", "Waveform.z_phase": "--z-phase"}


def with_option_name(error: ValueError, options: dict[str, str]) -> ValueError:
    """``error`` with the command-line option of the field it names in front: ``--k: Material....``."""
    text = str(error)
    for field_name, option in options.items():
        if text.startswith(field_name + "="):
            return ValueError(f"{option}: {text}")
    return error


def add_model_arguments(p: argparse.ArgumentParser, numerics_default: str = "fast") -> None:
    """Options for the physical model (DriveParams), its variant and the numerics."""
    m = p.add_argument_group("material (both bodies, unless --rigid-indenter)")
    m.add_argument("--k", type=float, default=0.0, help="grading exponent k of E(z) = E0 (z/c0)^k, in [0, 1) (-)")
    m.add_argument("--youngs-modulus", type=float, default=2e11, help="E0 (Pa)")
    m.add_argument("--poisson-ratio", type=float, default=0.3, help="nu, in (-1, 0.5] (-)")
    m.add_argument("--reference-depth", type=float, default=1.0, help="c0 (m)")
    m.add_argument("--rigid-indenter", action="store_true", help="rigid indenter on the graded slider")
    m.add_argument("--h-normal", type=float, default=None,
                   help="replace the closed-form h_N(k, nu), > 0 (-); default: the closed form")
    m.add_argument("--h-tangential", type=float, default=None,
                   help="replace the closed-form h_T(k, nu), > 0 (-); default: the closed form")
    add_variant_argument(m)
    c = p.add_argument_group("contact")
    c.add_argument("--indenter-radius", type=float, default=2.5e-3, help="R of the paraboloid, > 0 (m)")
    c.add_argument("--mu", type=float, default=0.3, help="indenter-slider friction coefficient, > 0 (-)")
    c.add_argument("--mu1", type=float, default=0.1, help="slider-base friction coefficient, >= 0 (-)")
    d = p.add_argument_group("drive")
    d.add_argument("--slider-mass", type=float, default=0.05, help="slider mass M, > 0 (kg)")
    d.add_argument("--cargo-mass", type=float, default=None,
                   help="cargo mass m, >= 0; load F_m = m g (kg); default: 0 (no load)")
    d.add_argument("--load-force", type=float, default=None,
                   help="load F_m, >= 0, instead of --cargo-mass (N); default: m g")
    d.add_argument("--gravity", type=float, default=9.81, help="g (m/s^2)")
    d.add_argument("--cargo-inertia", action="store_true", help="the cargo moves with the slider (mass M + m)")
    n = p.add_argument_group("numerics")
    add_numerics_argument(n, numerics_default)
    n.add_argument("--dt", type=float, default=None,
                   help="replace the preset's time step (s); for --numerics fast: its longest step; "
                        "default: the preset's")
    n.add_argument("--dx", type=float, default=None,
                   help="replace the spring spacing of the grid presets paper and default (m); "
                        "default: the preset's")


def add_numerics_argument(p, default: str) -> None:
    """``--numerics``: one preset name means one solver everywhere (core.params.NUMERICS_PRESETS)."""
    p.add_argument("--numerics", default=default, choices=sorted(NUMERICS_PRESETS),
                   help="solver preset: fast = the node solver (48 nodes, steps <= 5e-6 s, 0.3 µm in x, "
                        "0.1 µm in z; most accurate and fastest, docs/performance.md); default = the paper's grid "
                        "scheme at dt 1e-6 s, dx 1e-7 m; paper = the grid scheme at the paper's dt 1e-7 s, "
                        f"dx 1e-8 m (default: {default})")


def add_variant_argument(p) -> None:
    """``--variant``: the model as specified, or the paper's code as hypothesised (h_N x 2)."""
    p.add_argument("--variant", default="as-specified", choices=VARIANTS,
                   help="model variant: as-specified = the model of docs/model.md; as-published = h_N doubled, "
                        "h_T as is (the hypothesis about the paper's own code, docs/paper_reproduction.md) "
                        "(default: as-specified)")


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
    """The model the options describe; a bad value raises ``ValueError`` naming the option."""
    if a.load_force is not None and a.cargo_mass is not None:
        raise ValueError("--load-force and --cargo-mass both set the load: give one of them")
    try:
        graded = Material(youngs_modulus=a.youngs_modulus, poisson_ratio=a.poisson_ratio, grading_exponent=a.k,
                          reference_depth=a.reference_depth, h_normal_override=a.h_normal,
                          h_tangential_override=a.h_tangential)
        return DriveParams(
            indenter=Material.rigid() if a.rigid_indenter else graded,
            slider=graded,
            contact=Contact(indenter_radius=a.indenter_radius, friction_coefficient=a.mu,
                            base_friction_coefficient=a.mu1),
            drive=Drive(slider_mass=a.slider_mass, cargo_mass=a.cargo_mass or 0.0, gravity=a.gravity,
                        load_force=a.load_force, cargo_inertia=a.cargo_inertia),
            variant=a.variant,
        )
    except ValueError as e:
        raise with_option_name(e, FIELD_OPTIONS) from None


def numerics_from_args(a: argparse.Namespace) -> Numerics:
    """The preset ``--numerics`` names, with ``--dt``/``--dx`` where they apply (else ``ValueError``)."""
    base = numerics_preset(a.numerics)
    changes = {}
    if a.dt is not None:
        changes["time_step"] = a.dt
    if a.dx is not None:
        if base.method != "grid":
            raise ValueError(f"--dx: --numerics {a.numerics} is the node solver, which has no spring spacing "
                             "(use --numerics default or paper for a grid of springs)")
        changes["spring_spacing"] = a.dx
    try:
        return dataclasses.replace(base, **changes)
    except ValueError as e:
        raise with_option_name(e, FIELD_OPTIONS) from None


def waveform_from_args(a: argparse.Namespace) -> Waveform:
    """The waveform the options describe; a bad value raises ``ValueError`` naming the option."""
    axes = {}
    for axis in ("x", "z"):
        try:
            axes[axis] = AxisWaveform(getattr(a, f"{axis}_amplitude"), getattr(a, f"{axis}_rise_time"),
                                      getattr(a, f"{axis}_fall_time"))
        except ValueError as e:
            raise with_option_name(e, {f: o.format(axis=axis) for f, o in AXIS_OPTIONS.items()}) from None
    try:
        return Waveform(x=axes["x"], z=axes["z"], z_phase=a.z_phase)
    except ValueError as e:
        raise with_option_name(e, AXIS_OPTIONS) from None


def describe_numerics(numerics: Numerics, name: str | None = None) -> str:
    """One line saying which solver and steps a run used, e.g. for table headers."""
    label = f"{name} numerics: " if name else ""
    if numerics.method == "nodes":
        return (f"{label}node solver, {numerics.nodes} nodes, time step <= {numerics.time_step:g} s "
                f"(<= {numerics.max_x_step:g} m of x, {numerics.max_z_step:g} m of z per step)")
    return f"{label}grid solver, time step dt = {numerics.time_step:g} s, spring spacing dx = {numerics.spring_spacing:g} m"


def _jsonable(obj):
    if dataclasses.is_dataclass(obj):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, float) and math.isinf(obj):
        return "inf"
    return obj


#: Most periods one ``simulate`` run may ask for (it streams its periods: memory does not grow with them).
MAX_PERIODS = 1_000_000
#: Most periods of a ``simulate --plot`` run (the plot keeps every period's trace).
MAX_PLOT_PERIODS = 10_000
#: Most trace rows a ``simulate --plot`` run may keep (7 numbers each: about 400 MB).
MAX_TRACE_ROWS = 7_000_000
#: Units of the per-period fields of ``simulate --json`` (core.PeriodResult).
PERIOD_UNITS = {"displacement": "m", "mean_velocity": "m/s", "peak_tangential_force": "N",
                "peak_normal_force": "N", "indenter_dissipation": "J", "base_dissipation": "J", "load_work": "J",
                "indenter_work_x": "J", "indenter_work_z": "J", "end_velocity": "m/s", "end_position": "m"}
PERIOD_FIELDS = tuple(PERIOD_UNITS)


def trace_rows(numerics: Numerics, period: float, periods: int, record_every: int) -> int:
    """An upper bound of the trace rows a run keeps: its time steps per period (the node solver's
    longest step, or the grid's step, plus the waveform's corners) over ``record_every``."""
    steps = int(math.ceil(period / numerics.time_step)) + 16
    return periods * (steps // max(record_every, 1) + 1)


class PeriodStream:
    """Where ``simulate`` writes each period as it is computed: a table row, or one element of the
    JSON object's ``periods`` list, so nothing but two numbers a period is kept."""

    def __init__(self, as_json: bool, header: str):
        self.as_json, self.count = as_json, 0
        if as_json:
            sys.stdout.write('{"periods": [')
        else:
            print(header)
            print(" period   displacement (µm)   mean velocity (mm/s)   peak F_x (N)   peak F_z (N)")

    def period(self, r) -> None:
        self.count += 1
        if self.as_json:
            sys.stdout.write(("," if self.count > 1 else "") + json.dumps({f: getattr(r, f) for f in PERIOD_FIELDS}))
        else:
            print(f"{self.count:7d} {r.displacement * 1e6:19.4f} {r.mean_velocity * 1e3:22.4f} "
                  f"{r.peak_tangential_force:14.4g} {r.peak_normal_force:14.4g}")

    def finish(self, rest: dict) -> None:
        if self.as_json:
            sys.stdout.write("], " + json.dumps(rest)[1:] + "\n")
        else:
            print(f"{self.count} periods in {rest['wall_time_s']:.2f} s" + (" (interrupted)" if rest["interrupted"] else ""))
        sys.stdout.flush()


def cmd_simulate(a: argparse.Namespace) -> int:
    from tqdm import tqdm

    params, numerics, waveform = params_from_args(a), numerics_from_args(a), waveform_from_args(a)
    if a.record_every and not a.plot:
        raise ValueError("--record-every sets the plot's trace: give --plot too")
    if a.plot and a.periods > MAX_PLOT_PERIODS:
        raise ValueError(f"--periods={a.periods} with --plot is outside the allowed range [1, {MAX_PLOT_PERIODS}] "
                         "(plot a shorter run, or drop --plot)")
    record = a.record_every or (max(1, int(round(1e-5 / numerics.time_step))) if a.plot else 0)
    if a.plot and trace_rows(numerics, waveform.period, a.periods, record) > MAX_TRACE_ROWS:
        raise ValueError(f"--periods={a.periods} --record-every {record} with --plot keeps up to "
                         f"{trace_rows(numerics, waveform.period, a.periods, record):,} trace rows, more than the "
                         f"{MAX_TRACE_ROWS:,} (about 400 MB) a plot may hold: plot fewer periods or record every more steps")
    sim = DriveSimulator(params, numerics, max_depth=max(waveform.max_depth, 1e-9))
    check_numerics(numerics, waveform)  # a bad time step fails here, before the run
    numerics_line = describe_numerics(numerics, a.numerics)
    stream = PeriodStream(a.json, f"k = {params.k:g}, load F_m = {params.drive.load:.4g} N, variant {params.variant}\n"
                                  f"{numerics_line}")
    velocities, displacements, kept, interrupted = [], [], [], False
    t0 = time.perf_counter()
    try:
        for _ in tqdm(range(a.periods), desc="periods", unit="period", file=sys.stderr, disable=a.periods < 500,
                      leave=False):
            r = sim.step(waveform, record)
            velocities.append(r.mean_velocity)
            displacements.append(r.displacement)
            stream.period(r)
            if a.plot:
                kept.append(r)
    except KeyboardInterrupt:
        interrupted = True
        print(f"mdr-drive simulate: interrupted after {len(velocities)} of {a.periods} periods; "
              "printing those", file=sys.stderr)
    wall = time.perf_counter() - t0
    stream.finish({
        "period_mean_velocity": velocities, "period_displacement": displacements,
        "units": {"period_mean_velocity": "m/s", "period_displacement": "m", "load_force": "N", "wall_time_s": "s",
                  "periods": PERIOD_UNITS, "params": "SI (m, s, kg, Pa, N)"},
        "periods_run": len(velocities), "interrupted": interrupted, "numerics_preset": a.numerics,
        "params": _jsonable(params), "numerics": _jsonable(numerics), "waveform": _jsonable(waveform),
        "load_force": params.drive.load, "wall_time_s": wall})
    if a.plot and kept:
        try:
            plot_run(kept, a.plot, f"k = {params.k:g}, load {params.drive.load:.4g} N, {params.variant}\n"
                                   f"{numerics_line}", mu=params.contact.friction_coefficient)
        except OSError as e:
            raise ValueError(f"--plot {a.plot}: cannot be written ({e.strerror or e})") from None
        if not a.json:
            print(f"plot: {a.plot}")
    if not velocities:
        return 130
    return 130 if interrupted else 0


def cmd_reproduce(a: argparse.Namespace) -> int:
    from .reproduce import reproduce

    from .sweep import executor_from

    summary = reproduce(a.out, numerics=a.numerics, periods=a.periods, quick=a.quick, variant=a.variant,
                        executor=executor_from(a), resume=a.resume)
    print(json.dumps(summary, indent=2))
    print(f"figures and CSVs in {a.out}/")
    return 0


def cmd_bench(a: argparse.Namespace) -> int:
    from .bench import run

    from .sweep import executor_from

    res = run(a.out, quick=a.quick, executor=executor_from(a))
    print((Path(a.out) / "bench_speed.md").read_text())
    return 0 if res["accuracy_fast"]["max_error_over_tolerance"] <= 1.0 else 1


#: The entry-point group through which installed packages add ``mdr-drive`` subcommands (the agents
#: package adds train, recipe, evaluate, benchmark, ...). Each entry point names a module with
#: ``HELP``, ``DESCRIPTION``, ``add_arguments(parser)`` and ``main(args) -> exit code``.
COMMAND_GROUP = "mdr_drive.commands"


def plugin_commands() -> list:
    """The entry points of :data:`COMMAND_GROUP`, in the order their package declares them."""
    from importlib.metadata import entry_points

    return list(entry_points(group=COMMAND_GROUP))


def _add_plugin_command(sub, entry_point) -> None:
    """The subcommand ``entry_point`` names; one that cannot be imported (an extra is missing) still
    shows in ``--help`` and says, in one line, what to install."""
    try:
        module = entry_point.load()
    except ImportError as e:
        p = sub.add_parser(entry_point.name, help="(needs the train extra)")
        p.set_defaults(func=functools.partial(_missing_extra, entry_point.name, str(e)))
        return
    p = sub.add_parser(entry_point.name, help=module.HELP, description=module.DESCRIPTION)
    module.add_arguments(p)
    p.set_defaults(func=module.main)


def _missing_extra(command: str, error: str, args: argparse.Namespace) -> int:
    print(f"mdr-drive {command} needs the train extra (pip install -e '.[train]'): {error}", file=sys.stderr)
    return 2


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="mdr-drive", description=__doc__)
    parser.add_argument("--version", action="version", version=f"mdr-drive {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)

    s = sub.add_parser("simulate", help="simulate the drive for N periods",
                       description="Simulate the drive with a fixed waveform; print per-period results "
                                   "(SI units in --json; µm, mm/s and N in the table). Every option defaults to "
                                   "the paper's drive and trapezoid waveform, with k = 0 (a homogeneous indenter) "
                                   "and no cargo (m = 0): name --k and --cargo-mass for another working point "
                                   "(MDRDrive-v0's own default is k = 0.2, m = 0.1 kg).")
    add_model_arguments(s)
    add_waveform_arguments(s)
    o = s.add_argument_group("output")
    o.add_argument("--periods", type=int_range(1, MAX_PERIODS), default=6,
                   help=f"drive periods to simulate, in [1, {MAX_PERIODS}]; each period is printed as it is "
                        "computed, long runs show a progress bar, Ctrl-C ends the output cleanly (-)")
    o.add_argument("--record-every", type=int_range(0), default=0,
                   help="with --plot: a trace row every N time steps; 0: one every 10 us (-)")
    o.add_argument("--plot", metavar="OUT.png", default=None, type=output_file(".png", ".pdf", ".svg"),
                   help="write X(t), x(t), z(t), F_x, F_z as a PNG (or .pdf, .svg); its folder is created")
    o.add_argument("--json", action="store_true", help="print one JSON object (per-period results in SI units)")
    s.set_defaults(func=cmd_simulate)

    r = sub.add_parser("reproduce", help="reproduce the paper's Figs. 3-5",
                       description="Write Figs. 3, 4, 5 and the h_N/h_T sensitivity plot as PNG + CSV. The "
                                   "paper's numerics by default, since this reproduces the paper's figures.")
    r.add_argument("--out", default="results/paper", type=output_dir, help="output folder (created if missing)")
    add_numerics_argument(r, "paper")
    add_variant_argument(r)
    r.add_argument("--periods", type=positive_int, default=10, help="periods shown in Figs. 3 and 4 (-)")
    add_executor_arguments(r)
    r.add_argument("--quick", action="store_true", help="a small subset of the cases (for CI)")
    r.set_defaults(func=cmd_reproduce)

    b = sub.add_parser("bench", help="speed and accuracy of the solvers",
                       description="Periods/s of the kernels, env and vector env; accuracy of the fast solver "
                                   "against the paper preset on the k x load x waveform grid.")
    b.add_argument("--out", default="results/bench", type=output_dir,
                   help="output folder (bench_speed.json, bench_speed.md)")
    b.add_argument("--quick", action="store_true", help="shorter timing blocks")
    add_executor_arguments(b, resume=False)  # the reference's finished cases are always kept until it is written
    b.set_defaults(func=cmd_bench)

    for entry_point in plugin_commands():  # the agents package's, where it is installed
        _add_plugin_command(sub, entry_point)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:  # the reader went away (``mdr-drive ... --json | head``): nothing left to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit's flush
        return 0
    except (ValueError, OSError) as e:  # bad values, and paths that went bad after the command line was read
        print(f"mdr-drive {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"mdr-drive {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
