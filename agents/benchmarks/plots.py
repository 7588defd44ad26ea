"""Figures (PNG) of the waveform benchmark (velocity vs k and vs load, critical load, waveforms, heatmap) and
of the blind benchmark (critical load vs k, fraction of the best drive)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mdr_drive_env.core.waveform import knots_from_params
from mdr_drive_env.files import nan_array, save_figure

from ..policy import policy_label
from ..protocol import ACTION_MAP, trapezoid_action


def _waveform(action):
    p = ACTION_MAP.to_params(action)
    tx, vx, tz, vz = knots_from_params(p.x_amplitude, p.x_rise_time, p.z_amplitude, p.z_rise_time, p.z_phase,
                                       p.period, -1.0, -1.0)
    return tx * 1e3, vx * 1e6, tz * 1e3, vz * 1e6


def policies_label(res: dict) -> str:
    """What the fixed grid's policy rows are: the one policy's name (``policy_label``), or the mean of several."""
    names = [policy_label(p) for p in res["policies"]]
    return names[0] if len(names) == 1 else f"policies (mean +- std of {len(names)})"


def plot_all(res: dict, ks, masses, out: Path) -> None:
    """The fixed grid's figures (``benchmarks.grid``) from its results (``benchmark.json`` loaded):
    velocity against k and against the load, the critical load against k, the policy minus the
    trapezoid as a heat map and the policy's last two waveforms at four points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    nk, nm = len(ks), len(masses)
    trap = nan_array(res["trapezoid"]).reshape(nk, nm) * 1e3  # NaN (null in the JSON): a runaway
    cma = nan_array(res["cma_es"]).reshape(nk, nm) * 1e3
    has_learned = bool(res["learned_mean"])
    lm = nan_array(res["learned_mean"]).reshape(nk, nm) * 1e3 if has_learned else None
    ls = nan_array(res["learned_std"]).reshape(nk, nm) * 1e3 if has_learned else None
    learned_name = policies_label(res) if has_learned else ""
    styles = [("trapezoid", "-", "o", 3), ("CMA-ES: best fixed waveform per point", "--", "s", 3)]
    if has_learned:
        styles.append((learned_name, ":", "^", 4))

    for name, axis_vals, other, pick, xlabel in (
            ("velocity_vs_k", ks, masses, lambda a, j: a[:, j], "k"),
            ("velocity_vs_load", masses, ks, lambda a, i: a[i, :], "cargo mass m (kg)")):
        fig, ax = plt.subplots(figsize=(8.6, 4.6))
        chosen = [i for i in range(len(other))][:: max(1, len(other) // 3)][:3]
        colour_handles = []
        for c, j in enumerate(chosen):
            col = f"C{c}"
            lab = f"m = {other[j]:g} kg" if name == "velocity_vs_k" else f"k = {other[j]:g}"
            ax.plot(axis_vals, pick(trap, j), "-o", color=col, ms=3)
            ax.plot(axis_vals, pick(cma, j), "--s", color=col, ms=3)
            if has_learned:
                ax.errorbar(axis_vals, pick(lm, j), yerr=pick(ls, j), fmt=":^", color=col, ms=4)
            colour_handles.append(Line2D([], [], color=col, lw=2, label=lab))
        ax.axhline(0, color="k", lw=0.6)
        top = max(np.nanmax(trap), np.nanmax(cma), np.nanmax(lm) if has_learned else 0.0)
        ax.set(xlabel=xlabel, ylabel="steady velocity (mm/s)", ylim=(-20, 1.1 * top),
               title="the fixed grid: steady velocity (mean of periods 21-30)\n"
                     "below -20 mm/s: dragged back; gaps: the load runs away with the slider")
        ax.title.set_fontsize(10)
        first = ax.legend(handles=[Line2D([], [], color="0.3", ls=ls_, marker=marker, ms=ms, label=lab)
                                   for lab, ls_, marker, ms in styles], fontsize=8, loc="upper left",
                          bbox_to_anchor=(1.01, 1.0))
        ax.add_artist(first)
        ax.legend(handles=colour_handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 0.6))
        ax.grid(alpha=0.3)
        fig.tight_layout(rect=(0.0, 0.0, 0.79, 1.0))  # the legends to the right of the axes
        save_figure(fig, out / f"{name}.png")
        plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, c in res["critical_load_kg"].items():
        style = "-o" if name in ("trapezoid", "cma-es") else ":^"
        label = {"trapezoid": "trapezoid", "cma-es": "CMA-ES: best fixed waveform per load"}.get(name)
        ax.plot(ks, [c[f"{k:g}"] for k in ks], style, ms=4, label=label or policy_label(name))
    ax.set(yscale="log", xlabel="k", ylabel="critical cargo mass (kg)",
           title=f"the fixed grid: critical load at {len(ks)} k (largest cargo still moved forward)")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "critical_load_vs_k.png")
    plt.close(fig)

    if has_learned:
        fig, ax = plt.subplots(figsize=(6, 4.5))
        diff = np.where((lm > 0) | (trap > 0), lm - trap, np.nan)  # blank where neither moves the load (or runs away)
        lim = max(1e-9, np.nanmax(np.abs(diff)) if np.isfinite(diff).any() else 1.0)
        ax.set_facecolor("0.85")
        im = ax.imshow(diff, cmap="RdBu", vmin=-lim, vmax=lim, origin="lower", aspect="auto")
        ax.set(xticks=range(nm), xticklabels=[f"{m:g}" for m in masses], yticks=range(nk),
               yticklabels=[f"{k:g}" for k in ks], xlabel="cargo mass m (kg)", ylabel="k",
               title=f"the fixed grid: {learned_name} minus trapezoid (mm/s)\ngrey: neither moves the load")
        ax.title.set_fontsize(9)
        for i in range(nk):
            for j in range(nm):
                dark = np.isfinite(diff[i, j]) and abs(diff[i, j]) > 0.6 * lim
                ax.text(j, i, "-" if np.isnan(diff[i, j]) else f"{diff[i, j]:.1f}", ha="center", va="center",
                        fontsize=7, color="w" if dark else "k")
        fig.colorbar(im)
        fig.tight_layout()
        save_figure(fig, out / "heatmap_learned_minus_trapezoid.png")
        plt.close(fig)

        first = res["policies"][0]
        acts = res["learned_last_two_actions"][first]
        wanted = [(0.0, 0.0), (0.1, 0.3), (0.2, 0.2), (0.4, 0.0)]  # fast mode, heavy load, near stall
        points = [tuple(p) for p in res["points"]]
        picks = [points.index(p) for p in wanted if p in points] or list(range(min(4, len(points))))
        fig, axes = plt.subplots(1, len(picks), figsize=(3.4 * len(picks), 3.4), squeeze=False)
        tt = [_waveform(trapezoid_action())] * 2
        name = policy_label(first)
        for ax, i in zip(axes[0], picks):
            k, m = res["points"][i]
            for two, color, label in ((tt, "0.6", "trapezoid"), ([_waveform(a) for a in acts[i]], "C3", name)):
                t_x = np.concatenate([two[0][0], two[1][0] + ACTION_MAP.period * 1e3])
                t_z = np.concatenate([two[0][2], two[1][2] + ACTION_MAP.period * 1e3])
                ax.plot(t_x, np.concatenate([two[0][1], two[1][1]]), color=color, label=f"{label} x")
                ax.plot(t_z, np.concatenate([two[0][3], two[1][3]]) * 5, color=color, ls="--", label=f"{label} z (x5)")
            ax.set(title=f"k = {k:g}, m = {m:g} kg", xlabel="t (ms)", ylabel="indenter position (µm)")
            ax.grid(alpha=0.3)
        fig.legend(*axes[0][0].get_legend_handles_labels(), loc="lower center", ncol=4, fontsize=8)
        fig.suptitle(f"the {name}'s waveforms in periods 29 and 30 against the trapezoid's", fontsize=10)
        fig.tight_layout(rect=(0.0, 0.08, 1.0, 1.0))  # the legend below the panels
        save_figure(fig, out / "learned_waveforms.png")
        plt.close(fig)


def reference_label(res: dict) -> str:
    """', strong reference' for a blind benchmark judged against the strong reference, else ''."""
    return ", strong reference" if res.get("search", {}).get("pooled_rounds") else ""


def blind_label(res: dict, i: int) -> str:
    """The name of a blind benchmark's policy ``i``: as the run recorded it, else from its folder
    (``policy_label``)."""
    labels = res.get("policy_labels")
    return labels[i] if labels else policy_label(res["policies"][i])


def plot_blind(res: dict, out: str | Path, moving_threshold: float) -> None:
    """The two PNG figures of a blind benchmark (``benchmarks.blind``) from its results (``blind.json``
    loaded, or ``blind.run``'s return value), fractions of the best drive where it moves at least
    ``moving_threshold`` (m/s); they redraw from a ``blind.json`` without simulating."""
    import matplotlib

    matplotlib.use("Agg")

    out = Path(out)
    names = [f"policy {i + 1}" for i in range(len(res["policies"]))]
    crit = res["critical_load_kg"]
    if crit["k"]:  # no scan (--scan-ks 0): no critical-load figure
        plot_blind_critical_loads(res, names, out)
    plot_fraction_of_best(res, names, out, moving_threshold)


def plot_blind_critical_loads(res: dict, names: list[str], out: Path) -> None:
    """A blind benchmark's critical loads against the scanned k (``critical_load_vs_k.png``)."""
    import matplotlib.pyplot as plt

    crit = res["critical_load_kg"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(crit["k"], crit["best cycle"], "-s", ms=3, color="k", label="best two-action cycle found")
    ax.plot(crit["k"], crit["trapezoid"], "-o", ms=3, color="0.5", label="trapezoid")
    for i, p in enumerate(res["policies"]):
        ax.plot(crit["k"], crit[p], ":^", ms=4, color=f"C{i}", label=f"{names[i]}: {blind_label(res, i)}")
    ax.set(yscale="log", xlabel="k", ylabel="critical cargo mass (kg)",
           title=f"critical load vs k (blind benchmark, seed {res['seed']}{reference_label(res)}, fast numerics)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "critical_load_vs_k.png")
    plt.close(fig)


def plot_fraction_of_best(res: dict, names: list[str], out: Path, moving_threshold: float) -> None:
    """A blind benchmark's velocities as fractions of the best drive at its points (``fraction_of_best.png``)."""
    import matplotlib.pyplot as plt

    best = nan_array([b["velocity"] for b in res["best"]])
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ks = np.array([k for k, _ in res["points"]])
    for i, p in enumerate(res["policies"]):
        v = nan_array(res["learned"][p])
        sel = best >= moving_threshold
        ax.plot(ks[sel], np.nan_to_num(v[sel], nan=0.0) / best[sel], "^", color=f"C{i}",
                label=f"{names[i]}: {blind_label(res, i)}")
    trap = nan_array(res["trapezoid"])
    sel = best >= moving_threshold
    ax.plot(ks[sel], np.nan_to_num(trap[sel], nan=0.0) / best[sel], "o", color="0.5", label="trapezoid")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set(xlabel="k", ylabel="velocity / best drive found",
           title=f"fraction of the best drive at the blind points (seed {res['seed']}{reference_label(res)}; "
                 "best >= 2 mm/s)")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, out / "fraction_of_best.png")
    plt.close(fig)

