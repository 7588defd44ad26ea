"""Reproduction of the paper's Figs. 3-5, and the h_N/h_T sensitivity (docs/paper_reproduction.md).

Writes PNG figures and the CSV behind each under an output folder. Used by
``scripts/reproduce_paper.py`` and ``mdr-drive reproduce``.

Every <V> of Fig. 5 is reported twice, with the state it describes (core.analysis): the paper's
rule (skip 5 periods, average the 6th) at the chosen numerics, and the settled velocity (run until
periodic or a runaway is detected, at most 100 periods) with the fast solver (``SETTLED_NUMERICS``:
the paper's numerics would make the settled runs 10-20 times longer than the paper's). A runaway
point is marked as such in the CSV and the plots, never drawn as a velocity.
"""

from __future__ import annotations

import csv
import dataclasses
import shutil
import time
from pathlib import Path

import numpy as np

from .core import DriveParams, DriveSimulator, Waveform, concat_traces, steady_velocity
from .core import kernel as K
from .files import save_figure, write_csv, write_text
from .sweep import Executor, TaskStore, task_folder

FIG3_MASSES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
FIG4_KS = (0.0, 0.2, 0.3)
FIG5_MASSES = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5)
FIG5_KS = tuple(np.round(np.arange(0.0, 0.95, 0.05), 2))
FIG5_LEFT_KS = (0.0, 0.1, 0.2, 0.3, 0.5)
FIG5_LEFT_MASSES = tuple(np.round(np.arange(0.0, 1.05, 0.05), 2))
SENSITIVITY_SCALES = (0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0)
#: Numerics of the settled velocities (module docstring).
SETTLED_NUMERICS = "fast"
#: Columns of fig5.csv after (panel, k, cargo mass).
FIG5_COLUMNS = ["paper_rule_velocity_m_s", "paper_rule_state", "settled_velocity_m_s", "settled_state",
                "settled_periods"]


def _trace_case(args):
    params, periods, numerics, record_every = args
    sim = DriveSimulator(params, numerics)
    return concat_traces(sim.run(Waveform.paper(), periods, record_every=record_every))


def fig5_case(args) -> tuple:
    """``(paper-rule <V>, its state, settled <V>, its state, settled periods)`` of one model (m/s)."""
    params, numerics = args
    paper = steady_velocity(params, numerics=numerics, rule="paper")
    settled = steady_velocity(params, numerics=SETTLED_NUMERICS, rule="settled", max_periods=100)
    return paper.velocity, paper.state, settled.velocity, settled.state, settled.periods_run


def scaled_h(params: DriveParams, scale_n: float, scale_t: float) -> DriveParams:
    """``params`` with h_N and h_T of both bodies scaled (overrides on top of the variant's factor)."""
    mats = {}
    for name in ("indenter", "slider"):
        base = getattr(params, name)
        mats[name] = base if base.is_rigid else dataclasses.replace(
            base, h_normal_override=scale_n * base.h_normal, h_tangential_override=scale_t * base.h_tangential)
    return dataclasses.replace(params, **mats)


def velocity_cell(velocity: float, state: str) -> float | str:
    """A CSV cell: the velocity (m/s), or "" for a runaway (no velocity to report)."""
    return "" if state == "runaway" else velocity


def reproduce(out: str | Path = "results/paper", numerics: str = "paper", periods: int = 10,
              workers: int | None = None, quick: bool = False, variant: str = "as-specified",
              executor: Executor | None = None, resume: bool = False) -> dict:
    """Run every case, write ``fig3.png``, ``fig4.png``, ``fig5.png``, ``sensitivity.png`` + CSVs.

    Args:
        out: output folder.
        numerics: numerics preset (``paper`` is the paper's dt = 1e-7 s, dx = 1e-8 m).
        periods: drive periods shown in Figs. 3-4.
        workers: processes (default: the cores available), if no ``executor`` is given.
        quick: a CI-sized subset (fewer k and masses).
        variant: the model variant (``core.params.VARIANTS``).
        executor: runs the simulations (``mdr_drive_env.sweep``: local processes or Ray).
        resume: reuse the simulations an interrupted run into ``out`` finished (``out/.tasks``).
    Returns: a summary dict (also written as ``summary.json``).
    """
    import json

    def model(k: float, m: float) -> DriveParams:
        return DriveParams.paper(k=k, cargo_mass=m, variant=variant)

    out = Path(out)
    executor = executor or Executor(workers=workers)
    tasks = task_folder(out, resume)

    def _map(fn, cases, desc):
        return executor.map(fn, cases, desc, store=TaskStore(tasks / desc.replace(" ", "_").replace(".", "")))

    start = time.perf_counter()
    fig3_masses = FIG3_MASSES[::2] if quick else FIG3_MASSES
    fig5_ks = FIG5_KS[::6] if quick else FIG5_KS
    fig5_masses = FIG5_MASSES[::4] if quick else FIG5_MASSES
    left_ks = FIG5_LEFT_KS[::2] if quick else FIG5_LEFT_KS
    left_masses = FIG5_LEFT_MASSES[::5] if quick else FIG5_LEFT_MASSES
    scales = SENSITIVITY_SCALES[::3] if quick else SENSITIVITY_SCALES
    record_every = max(1, int(round(2e-5 / _dt(numerics))))  # a trace point every 20 us

    # Fig. 3: X(t), k = 0, m = 0 .. 1 kg
    traces3 = _map(_trace_case, [(model(0.0, m), periods, numerics, record_every) for m in fig3_masses], "Fig. 3")
    # Fig. 4: X(t), F_x(t), m = 0.1 kg, k = 0, 0.2, 0.3
    traces4 = _map(_trace_case, [(model(k, 0.1), periods, numerics, record_every) for k in FIG4_KS], "Fig. 4")
    # Fig. 5: <V> (6th period, and settled) vs k and m
    right_cases = [(k, m) for m in fig5_masses for k in fig5_ks]
    left_cases = [(k, m) for k in left_ks for m in left_masses]
    fig4_cases = [(k, 0.1) for k in FIG4_KS]
    v5 = _map(fig5_case, [(model(k, m), numerics) for k, m in right_cases + left_cases + fig4_cases], "Fig. 5")
    v_right, v_left = v5[: len(right_cases)], v5[len(right_cases):len(right_cases) + len(left_cases)]
    v_fig4 = v5[len(right_cases) + len(left_cases):]
    # sensitivity of <V> at k = 0.3, m = 0.1 kg to h_N, h_T
    sens_cases = [(s, s) for s in scales] + [(s, 1.0) for s in scales] + [(1.0, s) for s in scales]
    v_sens = _map(fig5_case, [(scaled_h(model(0.3, 0.1), sn, st), numerics) for sn, st in sens_cases], "sensitivity")

    # --- CSVs ---
    t3 = traces3[0][:, K.T_TIME]
    write_csv(out / "fig3.csv", ["t_s"] + [f"X_m_cargo_{m:g}kg" for m in fig3_masses],
              np.column_stack([t3] + [tr[:, K.T_SLIDER_X] for tr in traces3]))
    write_csv(out / "fig4.csv", ["t_s"] + [f"{q}_k_{k:g}" for k in FIG4_KS for q in ("X_m", "Fx_N")],
              np.column_stack([traces4[0][:, K.T_TIME]] + [tr[:, c] for tr in traces4
                                                          for c in (K.T_SLIDER_X, K.T_FX)]))

    def fig5_row(panel, k, m, r):
        return (panel, k, m, velocity_cell(r[0], r[1]), r[1], velocity_cell(r[2], r[3]), r[3], r[4])

    write_csv(out / "fig5.csv", ["panel", "k", "cargo_mass_kg", *FIG5_COLUMNS],
              [fig5_row("right", k, m, r) for (k, m), r in zip(right_cases, v_right)]
              + [fig5_row("left", k, m, r) for (k, m), r in zip(left_cases, v_left)])
    write_csv(out / "sensitivity.csv", ["h_N_scale", "h_T_scale", *FIG5_COLUMNS],
              [(sn, st, velocity_cell(r[0], r[1]), r[1], velocity_cell(r[2], r[3]), r[3], r[4])
               for (sn, st), r in zip(sens_cases, v_sens)])

    plot_figures(out, numerics, variant)
    summary = {
        "numerics": numerics,
        "settled_numerics": SETTLED_NUMERICS,
        "variant": variant,
        "periods": periods,
        "quick": quick,
        "wall_time_s": round(time.perf_counter() - start, 1),
        "fig4_mean_velocity_m_s": {f"{k:g}": {"paper_rule": velocity_cell(r[0], r[1]), "paper_rule_state": r[1],
                                              "settled": velocity_cell(r[2], r[3]), "settled_state": r[3]}
                                   for (k, _), r in zip(fig4_cases, v_fig4)},
        "fig4_peak_tangential_force_N": {f"{k:g}": float(np.abs(tr[:, K.T_FX]).max())
                                         for k, tr in zip(FIG4_KS, traces4)},
        "fig3_final_position_m": {f"{m:g}": float(tr[-1, K.T_SLIDER_X]) for m, tr in zip(fig3_masses, traces3)},
    }
    if executor.is_ray:
        summary["executor"] = f"ray ({executor.ray_address})"
    write_text(out / "summary.json", json.dumps(summary, indent=2))
    shutil.rmtree(tasks, ignore_errors=True)  # every output is written: the per-task results are spent
    return summary


def _dt(numerics: str) -> float:
    from .core import numerics_preset

    return numerics_preset(numerics).time_step


def _read_csv(path: Path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def _cell(text: str) -> float:
    """A velocity cell of fig5.csv (m/s) as a float; NaN for a runaway (empty cell)."""
    return float(text) if text else float("nan")


def _plot_states(ax, strip, xs, vs, states, color, label, row):
    """One curve of Fig. 5: a line through the points with a velocity, filled markers where settled,
    hollow where still settling; where the load runs away there is no velocity, so those points are
    an x in row ``row`` of the ``strip`` axes under the plot (None: no strip), not on the velocity axis."""
    xs, vs, states = np.asarray(xs), np.asarray(vs) * 1e3, np.asarray(states)
    ax.plot(xs, vs, "-", color=color, lw=1, label=label)
    for state, style in (("settled", dict(marker="o", ls="none", ms=3, color=color)),
                         ("settling", dict(marker="o", ls="none", ms=5, mfc="none", color=color))):
        sel = states == state
        ax.plot(xs[sel], vs[sel], **style)
    run = states == "runaway"
    if strip is None:
        return
    strip.plot(xs[run], np.full(run.sum(), row), "x", color=color, ms=4)


def _runaway_strip(ax, rows: int):
    """An axes under ``ax`` (sharing its x) for the points where the load runs away, a row per curve."""
    from mpl_toolkits.axes_grid1 import make_axes_locatable

    strip = make_axes_locatable(ax).append_axes("bottom", size="24%", pad=0.08, sharex=ax)
    strip.set(ylim=(-0.8, rows - 0.2), yticks=[])
    strip.set_ylabel("runaway", fontsize=7, rotation=0, ha="right", va="center")
    strip.grid(alpha=0.3, axis="x")
    ax.tick_params(labelbottom=False)
    return strip


def plot_figures(out: str | Path, numerics: str = "paper", variant: str = "as-specified") -> None:
    """Draw fig3-5 and the sensitivity plot from the CSVs in ``out`` (no simulation)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    tag = f"{numerics} numerics, {variant}"
    head, rows = _read_csv(out / "fig3.csv")
    a = np.array(rows, dtype=float)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for c, name in enumerate(head[1:], 1):
        ax.plot(a[:, 0] * 1e3, a[:, c] * 1e6, label=f"m = {name.split('_')[-1].replace('kg', '')} kg")
    ax.set(xlabel="t (ms)", ylabel="X (µm)", title=f"Fig. 3: slider position, k = 0\n({tag})")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "fig3.png")
    plt.close(fig)

    head, rows = _read_csv(out / "fig4.csv")
    a = np.array(rows, dtype=float)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for c in range(1, len(head), 2):
        k = head[c].split("_")[-1]
        a1.plot(a[:, 0] * 1e3, a[:, c] * 1e6, label=f"k = {k}")
        a2.plot(a[:, 0] * 1e3, a[:, c + 1], label=f"k = {k}", lw=0.8)
    a1.set(xlabel="t (ms)", ylabel="X (µm)", title=f"Fig. 4 left: slider position, m = 0.1 kg ({tag})")
    a2.set(xlabel="t (ms)", ylabel="F_x (N)", title="Fig. 4 right: tangential force, m = 0.1 kg")
    for ax in (a1, a2):
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "fig4.png")
    plt.close(fig)

    head, rows = _read_csv(out / "fig5.csv")
    col = {name: i for i, name in enumerate(head)}
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5))
    rules = (("paper_rule", f"<V> of the 6th period (the paper's rule, {numerics} numerics)"),
             ("settled", f"settled <V> ({SETTLED_NUMERICS} numerics, up to 100 periods)"))
    for row, (rule, rule_title) in enumerate(rules):
        v_col, s_col = col[f"{rule}_velocity_m_s"], col[f"{rule}_state"]
        for c, (panel, key, other, xlabel, fmt) in enumerate((
                ("left", 2, 1, "cargo mass m (kg)", "k = {:g}"), ("right", 1, 2, "k", "m = {:g} kg"))):
            ax = axes[row, c]
            sel = [r for r in rows if r[0] == panel]
            curves = sorted({float(r[other]) for r in sel})
            strip = _runaway_strip(ax, len(curves))
            for n, curve in enumerate(curves):
                pts = sorted((float(r[key]), _cell(r[v_col]), r[s_col]) for r in sel if float(r[other]) == curve)
                xs, vs, states = zip(*pts)
                _plot_states(ax, strip, xs, vs, states, f"C{n % 10}", fmt.format(curve), n)
            strip.set_xlabel(xlabel)
            ax.set(ylabel="<V> (mm/s)", title=f"Fig. 5 {panel}: {rule_title}" if c == 0 else f"Fig. 5 {panel}")
            ax.axhline(0, color="k", lw=0.6)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=6, ncol=2)
            ax.title.set_fontsize(9)
    fig.suptitle(f"{tag}. Filled: settled; hollow: still settling; x in the strip under a panel: the load runs "
                 "away (no velocity)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, out / "fig5.png")
    plt.close(fig)

    head, rows = _read_csv(out / "sensitivity.csv")
    col = {name: i for i, name in enumerate(head)}
    r = [(float(x[0]), float(x[1]), _cell(x[col["paper_rule_velocity_m_s"]]), x[col["paper_rule_state"]])
         for x in rows]
    fig, ax = plt.subplots(figsize=(6, 4.6))
    strip = _runaway_strip(ax, 3) if any(state == "runaway" for *_, state in r) else None
    for n, (label, mask, x_of) in enumerate((
            ("h_N and h_T scaled", lambda sn, st: sn == st, lambda sn, st: sn),
            ("h_N scaled", lambda sn, st: st == 1.0, lambda sn, st: sn),
            ("h_T scaled", lambda sn, st: sn == 1.0, lambda sn, st: st))):
        pts = sorted((x_of(sn, st), v, state) for sn, st, v, state in r if mask(sn, st))
        xs, vs, states = zip(*pts)
        _plot_states(ax, strip, xs, vs, states, f"C{n}", label, n)
    ax.axhline(0, color="k", lw=0.6)
    (strip or ax).set(xscale="log", xlabel="scale factor on h")
    ax.set(xscale="log", ylabel="<V> (mm/s), 6th period",
           title=f"Sensitivity of <V> to h_N, h_T (k = 0.3, m = 0.1 kg)\n({tag})")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "sensitivity.png")
    plt.close(fig)
