"""Reproduction of the paper's Figs. 3-5, and the h_N/h_T sensitivity of physics.md section 5.

Writes PNG figures and the CSV behind each under an output folder. Used by
``scripts/reproduce_paper.py`` and ``mdr-drive reproduce``.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .core import DriveParams, DriveSimulator, Material, Waveform, concat_traces, steady_velocity
from .core import kernel as K

FIG3_MASSES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
FIG4_KS = (0.0, 0.2, 0.3)
FIG5_MASSES = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5)
FIG5_KS = tuple(np.round(np.arange(0.0, 0.95, 0.05), 2))
FIG5_LEFT_KS = (0.0, 0.1, 0.2, 0.3, 0.5)
FIG5_LEFT_MASSES = tuple(np.round(np.arange(0.0, 1.05, 0.05), 2))
SENSITIVITY_SCALES = (0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0)


def _trace_case(args):
    k, m, periods, numerics, record_every = args
    sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), numerics)
    return concat_traces(sim.run(Waveform.paper(), periods, record_every=record_every))


def _velocity_case(args):
    params, numerics = args
    return steady_velocity(params, numerics=numerics, rule="paper").velocity


def _scaled_h(k: float, m: float, scale_n: float, scale_t: float) -> DriveParams:
    base = Material(grading_exponent=k)
    mat = dataclasses.replace(base, h_normal_override=scale_n * base.h_normal,
                              h_tangential_override=scale_t * base.h_tangential)
    return dataclasses.replace(DriveParams.paper(k=k, cargo_mass=m), indenter=mat, slider=mat)


def _map(fn, cases, desc, workers):
    if workers <= 1:
        return [fn(c) for c in tqdm(cases, desc=desc, unit="run")]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(tqdm(pool.map(fn, cases), total=len(cases), desc=desc, unit="run"))


def _write_csv(path: Path, header: list[str], rows) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def reproduce(out: str | Path = "results/paper", numerics: str = "paper", periods: int = 10,
              workers: int | None = None, quick: bool = False) -> dict:
    """Run every case, write ``fig3.png``, ``fig4.png``, ``fig5.png``, ``sensitivity.png`` + CSVs.

    Args:
        out: output folder.
        numerics: numerics preset (``paper`` is the paper's dt = 1e-7 s, dx = 1e-8 m).
        periods: drive periods shown in Figs. 3-4.
        workers: processes (default: the cores available).
        quick: a CI-sized subset (fewer k and masses).
    Returns: a summary dict (also written as ``summary.json``).
    """
    import json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    workers = workers or len(os.sched_getaffinity(0))
    start = time.perf_counter()
    fig3_masses = FIG3_MASSES[::2] if quick else FIG3_MASSES
    fig5_ks = FIG5_KS[::6] if quick else FIG5_KS
    fig5_masses = FIG5_MASSES[::4] if quick else FIG5_MASSES
    left_ks = FIG5_LEFT_KS[::2] if quick else FIG5_LEFT_KS
    left_masses = FIG5_LEFT_MASSES[::5] if quick else FIG5_LEFT_MASSES
    scales = SENSITIVITY_SCALES[::3] if quick else SENSITIVITY_SCALES
    record_every = max(1, int(round(2e-5 / _dt(numerics))))  # a trace point every 20 us

    # Fig. 3: X(t), k = 0, m = 0 .. 1 kg
    traces3 = _map(_trace_case, [(0.0, m, periods, numerics, record_every) for m in fig3_masses], "Fig. 3", workers)
    # Fig. 4: X(t), F_x(t), m = 0.1 kg, k = 0, 0.2, 0.3
    traces4 = _map(_trace_case, [(k, 0.1, periods, numerics, record_every) for k in FIG4_KS], "Fig. 4", workers)
    # Fig. 5: <V> (6th period) vs k and m
    right_cases = [(k, m) for m in fig5_masses for k in fig5_ks]
    left_cases = [(k, m) for k in left_ks for m in left_masses]
    v5 = _map(_velocity_case, [(DriveParams.paper(k=k, cargo_mass=m), numerics) for k, m in right_cases + left_cases],
              "Fig. 5", workers)
    v_right, v_left = v5[: len(right_cases)], v5[len(right_cases):]
    # sensitivity of <V> at k = 0.3, m = 0.1 kg to h_N, h_T
    sens_cases = [(s, s) for s in scales] + [(s, 1.0) for s in scales] + [(1.0, s) for s in scales]
    v_sens = _map(_velocity_case, [(_scaled_h(0.3, 0.1, sn, st), numerics) for sn, st in sens_cases],
                  "sensitivity", workers)

    # --- CSVs ---
    t3 = traces3[0][:, K.T_TIME]
    _write_csv(out / "fig3.csv", ["t_s"] + [f"X_m_cargo_{m:g}kg" for m in fig3_masses],
               np.column_stack([t3] + [tr[:, K.T_SLIDER_X] for tr in traces3]))
    _write_csv(out / "fig4.csv", ["t_s"] + [f"{q}_k_{k:g}" for k in FIG4_KS for q in ("X_m", "Fx_N")],
               np.column_stack([traces4[0][:, K.T_TIME]] + [tr[:, c] for tr in traces4
                                                           for c in (K.T_SLIDER_X, K.T_FX)]))
    _write_csv(out / "fig5.csv", ["panel", "k", "cargo_mass_kg", "mean_velocity_m_s"],
               [("right", k, m, v) for (k, m), v in zip(right_cases, v_right)]
               + [("left", k, m, v) for (k, m), v in zip(left_cases, v_left)])
    _write_csv(out / "sensitivity.csv", ["h_N_scale", "h_T_scale", "mean_velocity_m_s"],
               [(sn, st, v) for (sn, st), v in zip(sens_cases, v_sens)])

    plot_figures(out, numerics)
    vr = np.array(v_right).reshape(len(fig5_masses), len(fig5_ks))
    fig4_velocities = {}  # <V> of the Fig. 4 cases (m = 0.1 kg), from the Fig. 5 grid when it has them
    if 0.1 in fig5_masses:
        row = vr[list(fig5_masses).index(0.1)]
        fig4_velocities = {f"{k:g}": float(v) for k, v in zip(fig5_ks, row) if k in FIG4_KS}

    summary = {
        "numerics": numerics,
        "periods": periods,
        "quick": quick,
        "wall_time_s": round(time.perf_counter() - start, 1),
        "fig4_mean_velocity_6th_period_m_s": fig4_velocities,
        "fig3_final_position_m": {f"{m:g}": float(tr[-1, K.T_SLIDER_X]) for m, tr in zip(fig3_masses, traces3)},
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def _dt(numerics: str) -> float:
    from .core import numerics_preset

    return numerics_preset(numerics).time_step


def _read_csv(path: Path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def plot_figures(out: str | Path, numerics: str = "paper") -> None:
    """Draw fig3-5 and the sensitivity plot from the CSVs in ``out`` (no simulation)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    head, rows = _read_csv(out / "fig3.csv")
    a = np.array(rows, dtype=float)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for c, name in enumerate(head[1:], 1):
        ax.plot(a[:, 0] * 1e3, a[:, c] * 1e6, label=f"m = {name.split('_')[-1].replace('kg', '')} kg")
    ax.set(xlabel="t (ms)", ylabel="X (um)", title=f"Fig. 3: slider position, k = 0 ({numerics} numerics)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "fig3.png", dpi=120)
    plt.close(fig)

    head, rows = _read_csv(out / "fig4.csv")
    a = np.array(rows, dtype=float)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for c in range(1, len(head), 2):
        k = head[c].split("_")[-1]
        a1.plot(a[:, 0] * 1e3, a[:, c] * 1e6, label=f"k = {k}")
        a2.plot(a[:, 0] * 1e3, a[:, c + 1], label=f"k = {k}", lw=0.8)
    a1.set(xlabel="t (ms)", ylabel="X (um)", title="Fig. 4 left: slider position, m = 0.1 kg")
    a2.set(xlabel="t (ms)", ylabel="F_x (N)", title="Fig. 4 right: tangential force, m = 0.1 kg")
    for ax in (a1, a2):
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "fig4.png", dpi=120)
    plt.close(fig)

    _, rows = _read_csv(out / "fig5.csv")
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    for col, (panel, key, other, xlabel, fmt) in enumerate((
            ("left", 2, 1, "cargo mass m (kg)", "k = {:g}"), ("right", 1, 2, "k", "m = {:g} kg"))):
        sel = [r for r in rows if r[0] == panel]
        for curve in sorted({float(r[other]) for r in sel}):
            pts = sorted((float(r[key]), float(r[3])) for r in sel if float(r[other]) == curve)
            xs, vs = zip(*pts)
            for row in (0, 1):
                axes[row, col].plot(xs, np.array(vs) * 1e3, "o-", ms=3, label=fmt.format(curve))
        axes[0, col].set(title=f"Fig. 5 {panel}: <V> (6th period) vs {'m' if panel == 'left' else 'k'}")
        axes[1, col].set(ylim=(-20, 20), title="zoom on |<V>| < 20 mm/s (the driving range)")
        for row in (0, 1):
            axes[row, col].set(xlabel=xlabel, ylabel="<V> (mm/s)")
            axes[row, col].axhline(0, color="k", lw=0.6)
            axes[row, col].grid(alpha=0.3)
        axes[0, col].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "fig5.png", dpi=120)
    plt.close(fig)

    _, rows = _read_csv(out / "sensitivity.csv")
    r = np.array(rows, dtype=float)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for mask, label in ((r[:, 0] == r[:, 1], "h_N and h_T scaled"), (r[:, 1] == 1.0, "h_N scaled"),
                        (r[:, 0] == 1.0, "h_T scaled")):
        pts = r[mask]
        pts = pts[np.argsort(pts[:, 0] if label != "h_T scaled" else pts[:, 1])]
        ax.plot(pts[:, 0] if label != "h_T scaled" else pts[:, 1], pts[:, 2] * 1e3, "o-", label=label,
                ms=7 if label.startswith("h_N and") else 4)
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xscale="log", xlabel="scale factor on h", ylabel="<V> (mm/s)",
           title="Sensitivity of <V> to h_N, h_T (k = 0.3, m = 0.1 kg)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "sensitivity.png", dpi=120)
    plt.close(fig)
