"""``make demo`` / ``mdr-drive demo``: the paper's drive, the shipped policy against the trapezoid,
then the sensor policy through a load step."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform

from ..policy import PRETRAINED, SENSOR_PRETRAINED, load_policy, policy_label
from ..protocol import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    csv_velocity,
    env_rollout,
    format_velocity,
    open_loop_velocity,
    policy_rollout,
    steady_velocity_of,
    trapezoid_action,
)

HELP = "the README's demo (make demo)"
DESCRIPTION = ("Simulate the paper's drive, then run the shipped policy against the trapezoid over a grid of k and "
               "loads, then the sensor policy (told neither k nor the load) through a cargo picked up and set down; "
               "prints the tables and writes plots to --out.")

DEMO_KS = (0.0, 0.1, 0.2, 0.3)
DEMO_MASSES = (0.0, 0.1, 0.2, 0.4)
#: The load steps of part 3: k, and (cargo mass before, period of the step, cargo mass after) (kg).
STEP_K = 0.2
LOAD_STEPS = ((0.02, 15, 0.12), (0.12, 15, 0.02))
STEP_PERIODS = 30
#: Loads of the demo's plot (kg): fine enough to show where each drive stalls.
PLOT_MASSES = tuple(np.round(np.linspace(0.0, 0.8, 41), 3))


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mdr_drive_env.cli_args import output_dir

    from .evaluate import policy_path

    p.add_argument("--out", default="results/demo", type=output_dir, help="output folder")
    p.add_argument("--policy", default=str(PRETRAINED), type=policy_path,
                   help="policy folder (default: the shipped one, agents/pretrained/ppo_generalist)")
    p.add_argument("--sensor-policy", default=str(SENSOR_PRETRAINED), type=policy_path,
                   help="sensor policy folder for part 3 (default: agents/pretrained/ppo_sensor)")


def main(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")

    from mdr_drive_env.core import steady_velocity
    from mdr_drive_env.files import write_csv
    from mdr_drive_env.plotting import plot_run

    out = Path(args.out)
    t0 = time.perf_counter()
    params = DriveParams.paper(k=0.2, cargo_mass=0.1)
    sim = DriveSimulator(params, "fast")
    results = sim.run(Waveform.paper(), 10, record_every=2)
    plot_run(results, str(out / "paper_drive_k0.2_m0.1.png"), "paper waveform, k = 0.2, m = 0.1 kg (fast numerics)")
    settled = steady_velocity(params)
    print(f"1. the paper's drive, k = 0.2, m = 0.1 kg (fast numerics): <V> of the 6th period "
          f"{results[5].mean_velocity * 1e3:.3f} mm/s (the paper's rule; still settling), "
          f"{settled.velocity * 1e3:.3f} mm/s once {settled.state} (period {settled.periods_run}); "
          f"plot {out / 'paper_drive_k0.2_m0.1.png'}")

    policy = load_policy(args.policy)
    name = policy_label(args.policy)
    table_points = [(k, m) for k in DEMO_KS for m in DEMO_MASSES]
    plot_points = [(k, m) for k in DEMO_KS for m in PLOT_MASSES]
    points = table_points + plot_points
    with tqdm(total=2, desc=f"2. {name} vs trapezoid", unit="method") as bar:
        trap = open_loop_velocity(points, trapezoid_action(), mark_runaway=True)
        bar.update()
        disp, _, runaway = policy_rollout(policy, points)
        learned = steady_velocity_of(disp, runaway=runaway)
        bar.update()
    n_table = len(table_points)
    print(f"\nsteady velocity (mm/s, fast numerics, mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}): "
          f"{name} / paper trapezoid ('runaway': the load accelerates the slider backwards without bound)")
    print("   k  " + "".join(f"{f'm = {m:g} kg':>20}" for m in DEMO_MASSES))
    n = len(DEMO_MASSES)
    for i, k in enumerate(DEMO_KS):
        print(f"{k:5.2f} " + "".join(f"{format_velocity(learned[i * n + j], 10)} /{format_velocity(trap[i * n + j], 8)}"
                                     for j in range(n)))

    lp, tp = learned[n_table:].reshape(len(DEMO_KS), -1) * 1e3, trap[n_table:].reshape(len(DEMO_KS), -1) * 1e3
    plot_policy_vs_trapezoid(np.array(PLOT_MASSES), lp, tp, name, out / "policy_vs_trapezoid.png")
    write_csv(out / "policy_vs_trapezoid.csv", ["k", "cargo_mass_kg", "learned_m_s", "trapezoid_m_s"],
              [(k, m, csv_velocity(float(v)), csv_velocity(float(t)))
               for (k, m), v, t in zip(plot_points, learned[n_table:], trap[n_table:])])
    load_steps(load_policy(args.sensor_policy), policy, out)
    print(f"\nplots and CSV in {out}/ ; done in {time.perf_counter() - t0:.1f} s")
    return 0


def plot_policy_vs_trapezoid(masses: np.ndarray, lp: np.ndarray, tp: np.ndarray, name: str, path: Path) -> None:
    """Steady velocity (mm/s) over the load of the policy (``lp``) and the trapezoid (``tp``), one row
    per k of ``DEMO_KS``; where the load runs away with the slider (NaN) there is no velocity, so
    those loads are marked in a strip of their own under the plot, not on the velocity axis."""
    import matplotlib.pyplot as plt

    from mdr_drive_env.files import save_figure

    fig, (ax, strip) = plt.subplots(2, 1, figsize=(8, 7.2), sharex=True, gridspec_kw={"height_ratios": [3, 1.4]})
    labels = []
    for i, k in enumerate(DEMO_KS):
        ax.plot(masses, tp[i], "-", color=f"C{i}", lw=1.5, label=f"trapezoid, k = {k:g}")
        ax.plot(masses, lp[i], ":", color=f"C{i}", lw=2, label=f"{name}, k = {k:g}")
        for row, (curve, marker) in enumerate(((tp[i], "x"), (lp[i], "+"))):
            gone = np.isnan(curve)
            y = 2 * i + row
            strip.plot(masses[gone], np.full(gone.sum(), y), marker, color=f"C{i}", ms=5)
            labels.append(f"{'trapezoid' if row == 0 else 'policy'}, k = {k:g}")
    ax.axhline(0, color="k", lw=0.6)
    ax.set(ylabel="steady velocity (mm/s)",
           title=f"{name} vs the paper's trapezoid (mean of periods 21-30); below 0: the load drags the slider back")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=8, ncol=2)
    ax.grid(alpha=0.3)
    strip.set(yticks=range(len(labels)), xlabel="cargo mass m (kg)", ylim=(-0.7, len(labels) - 0.3))
    strip.set_yticklabels(labels, fontsize=8)
    strip.set_title("loads where the load runs away with the slider (no steady velocity)", fontsize=9)
    strip.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def load_steps(sensor, full, out: Path) -> None:
    """Part 3: the sensor policy (told neither k nor the load) through ``LOAD_STEPS`` at ``STEP_K``,
    against the full-observation policy and the trapezoid; prints the means, writes load_step.png."""
    import matplotlib.pyplot as plt

    from mdr_drive_env.files import save_figure

    drives = (("sensor policy", sensor), ("full-observation policy", full), ("trapezoid", None))
    print(f"\n3. a drive that does not know its load: k = {STEP_K:g}, the cargo changes after period "
          f"{LOAD_STEPS[0][1]}; mean velocity (mm/s) of periods 1-{LOAD_STEPS[0][1]} -> "
          f"{LOAD_STEPS[0][1] + 6}-{STEP_PERIODS}")
    fig, axes = plt.subplots(1, len(LOAD_STEPS), figsize=(11, 3.8), sharey=True)
    for ax, (before, period, after) in zip(axes, LOAD_STEPS):
        line = []
        for name, policy in drives:  # each policy in the env its run.json names (env_rollout)
            v, _, _ = env_rollout(policy, STEP_K, before, STEP_PERIODS, (period, after))
            line.append(f"{name} {v[:period].mean() * 1e3:.1f} -> {v[period + 5:].mean() * 1e3:.1f}")
            ax.plot(np.arange(1, STEP_PERIODS + 1), v * 1e3, lw=1.8 if policy is sensor else 1.0, label=name)
        print(f"   {before * 1e3:.0f} g -> {after * 1e3:.0f} g: " + ", ".join(line))
        ax.axvline(period + 0.5, color="k", ls=":", lw=0.8)
        ax.set(title=f"k = {STEP_K:g}: cargo {before * 1e3:.0f} g -> {after * 1e3:.0f} g after period {period}",
               xlabel="period")
        ax.title.set_fontsize(9)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mean velocity per period (mm/s)")
    axes[0].legend(fontsize=8)
    fig.suptitle("a load picked up and set down: the sensor policy is told neither k nor the load "
                 "(mu 0.3, mu1 0.1)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out / "load_step.png")
    plt.close(fig)
