"""Where a policy is below the trapezoid, on a dense grid of the blind benchmark's whole domain.

    mdr-drive dense --policy agents/pretrained/ppo_generalist --ks 121 --loads 200 \
        --out results/dense        # 24,200 points, about a minute on 2 cores

The blind benchmark draws a few dozen random points; a policy that fails in narrow bands of load
(a fitted copy of a teacher whose drive jumps between optima does) passes such a draw most of the
time and fails a larger one. This check needs no search, so it can cover the domain densely: ``--ks``
values of k evenly spaced over [0, 0.6] times ``--loads`` loads evenly spaced from 0 to 1.25 times
the trapezoid's critical load at each k (the blind benchmark's domain, ``benchmarks.blind``), each
played closed loop by the evaluation protocol (30 periods, mean of 21-30) beside the trapezoid.
Counts the blind benchmark's statistic: points where the policy is slower than the trapezoid by
more than 0.05 mm/s (where either moves; a runaway counts as slowest). The grid is fixed, not drawn:
it is a measurement, not a seed to tune on.

Writes to ``--out`` (refused if it holds a ``dense.json`` unless ``--force``): ``dense.json`` (the
grid, every velocity to 1e-5 mm/s), ``dense.md`` (counts, the share of the domain, the worst
points and how many k values have one), ``below.csv`` (every point below) and ``below_trapezoid.png``
(where they lie, over load / the trapezoid's critical load).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mdr_drive_env.files import json_safe, nan_array, save_figure, write_csv, write_text

from ..policy import load_policy
from ..protocol import open_loop_velocity, policy_velocity, trapezoid_action, trapezoid_critical_load
from .blind import K_RANGE, LOAD_FACTOR
from .targets import below_trapezoid

#: Points per batched rollout (bounds memory; each chunk is one vector env).
CHUNK = 4096


def dense_grid(n_k: int, n_loads: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """k values (n_k,), the trapezoid's critical load (kg) at each, and load fractions (n_loads,) of
    it spanning the blind benchmark's domain."""
    ks = np.linspace(*K_RANGE, n_k)
    return ks, np.asarray(trapezoid_critical_load(list(map(float, ks)))), np.linspace(0.0, LOAD_FACTOR, n_loads)


def velocities(policy_path: str, points: list, progress: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The policy's and the trapezoid's steady velocities (m/s; NaN: runaway) at ``points``, in
    chunks of ``CHUNK`` (a progress bar over them)."""
    from tqdm import tqdm

    policy = load_policy(policy_path)
    learned, trap = [], []
    for start in tqdm(range(0, len(points), CHUNK), desc="dense check", unit="chunk", disable=not progress):
        chunk = points[start:start + CHUNK]
        learned.append(policy_velocity(policy, chunk, mark_runaway=True))
        trap.append(open_loop_velocity(chunk, trapezoid_action(), mark_runaway=True))
    return np.concatenate(learned), np.concatenate(trap)


def checked(res: dict) -> dict:
    """``dense.json``'s content as arrays over its grid, flattened k-major: ``k`` and ``fraction``
    (load / the trapezoid's critical load) of each point, the policy's and the trapezoid's velocities
    (m/s, NaN for a runaway), and ``below``, ``gap`` (``targets.below_trapezoid``)."""
    ks, fr = np.array(res["k"]), np.array(res["load_fraction"])
    learned, trap = (nan_array(res[key]) for key in ("policy_m_s", "trapezoid_m_s"))
    below, gap, _ = below_trapezoid(trap, learned)
    return {"k": np.repeat(ks, len(fr)), "fraction": np.tile(fr, len(ks)), "policy": learned, "trapezoid": trap,
            "below": below, "gap": gap}


def worst_text(below: np.ndarray, gap: np.ndarray) -> str:
    """The deepest point below the trapezoid, in words (a runaway, then the deepest finite one)."""
    if not below.any():
        return "none below"
    finite = gap[below & np.isfinite(gap)]
    deepest = f"{finite.min() * 1e3:.2f} mm/s" if finite.size else "none"
    return deepest if finite.size == below.sum() else \
        f"a runaway (the load runs away with the slider); worst without: {deepest}"


def report(res: dict, worst: int = 15) -> str:
    """``dense.md`` from ``dense.json``'s content."""
    ks, fr, crit = np.array(res["k"]), np.array(res["load_fraction"]), np.array(res["trapezoid_critical_kg"])
    c = checked(res)
    kk, ff, learned, trap, below, gap = (c[key] for key in ("k", "fraction", "policy", "trapezoid", "below", "gap"))
    n_k, n_l = len(ks), len(fr)
    lines = [f"Dense check of `{res['policy']}`: {n_k} k values in [{ks[0]:g}, {ks[-1]:g}] x {n_l} loads from 0 to "
             f"{fr[-1]:g} x the trapezoid's critical load ({n_k * n_l} points); closed loop, mean of periods 21-30.",
             f"Command: `{res['command']}`", "",
             f"* points below the trapezoid by more than 0.05 mm/s (where either moves): **{int(below.sum())}** "
             f"({100.0 * below.mean():.2f} % of the grid)",
             f"* of them more than 1 mm/s below: {int((below & (gap < -1e-3)).sum())}; runaway: "
             f"{int((below & np.isnan(learned)).sum())}",
             f"* k values with at least one: {len(set(kk[below].round(6)))} of {n_k}",
             f"* worst: {worst_text(below, gap)}", ""]
    if below.any():
        lines += [f"The {min(worst, int(below.sum()))} deepest (mm/s):", "",
                  "| k | load (kg) | load / trapezoid's critical | trapezoid | policy |", "|---|---|---|---|---|"]
        for i in np.argsort(np.where(below, gap, np.inf))[:min(worst, int(below.sum()))]:
            m = ff[i] * crit[i // n_l]
            lines.append(f"| {kk[i]:.4g} | {m:.5g} | {ff[i]:.4f} | {trap[i] * 1e3:.2f} | "
                         + ("runaway" if np.isnan(learned[i]) else f"{learned[i] * 1e3:.2f}") + " |")
    return "\n".join(lines) + "\n"


def plot(res: dict, path: Path) -> None:
    """``below_trapezoid.png`` from ``dense.json``'s content: the points below the trapezoid over k and
    load / the trapezoid's critical load, coloured by how far below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    c = checked(res)
    kk, ff, below, gap = c["k"], c["fraction"], c["below"], c["gap"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    depth = np.clip(-np.where(np.isfinite(gap), gap, -0.1) * 1e3, 0.05, 100.0)[below]
    sc = ax.scatter(kk[below], ff[below], c=np.log10(depth), s=10, cmap="viridis_r")
    fig.colorbar(sc, ax=ax, label="log10(trapezoid - policy, mm/s)")
    ax.set(xlim=(kk[0] - 0.01, kk[-1] + 0.01), ylim=(0, ff[-1]), xlabel="k", ylabel="load / trapezoid's critical load",
           title=f"where the policy is below the trapezoid: {int(below.sum())} of {below.size} grid points")
    ax.title.set_fontsize(9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def run(policy_path: str, n_k: int, n_loads: int, out: str | Path, command: str, progress: bool = True) -> str:
    """The dense check of the policy in ``policy_path`` on ``n_k`` x ``n_loads`` points into ``out``
    (module docstring); returns ``dense.md``'s text."""
    out = Path(out)
    ks, crit, fractions = dense_grid(n_k, n_loads)
    points = [(float(k), float(f * c)) for k, c in zip(ks, crit) for f in fractions]
    learned, trap = velocities(policy_path, points, progress=progress)
    res = json_safe({"policy": str(policy_path), "command": command, "k": ks, "load_fraction": fractions,
                     "trapezoid_critical_kg": crit, "policy_m_s": np.round(learned, 8),  # 1e-5 mm/s
                     "trapezoid_m_s": np.round(trap, 8)})
    c = checked(res)  # the velocities as saved, as dense.md and the plot count them
    write_csv(out / "below.csv", ["k", "cargo_mass_kg", "load_over_trapezoid_critical", "trapezoid_m_s", "policy_m_s"],
              [(points[i][0], points[i][1], c["fraction"][i], c["trapezoid"][i], c["policy"][i])
               for i in np.flatnonzero(c["below"])])
    text = report(res)
    write_text(out / "dense.md", text)
    plot(res, out / "below_trapezoid.png")
    write_text(out / "dense.json", json.dumps(res))  # last: its presence marks a finished check
    return text


__all__ = ["CHUNK", "checked", "dense_grid", "plot", "report", "run", "velocities", "worst_text"]
