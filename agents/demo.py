"""``make demo`` / ``mdr-drive demo``: the paper's drive, then the shipped policy against the trapezoid."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform

from .evaluate import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    Policy,
    open_loop_velocity,
    policy_rollout,
    steady_velocity_of,
    trapezoid_action,
)

PRETRAINED = Path(__file__).parent / "pretrained" / "ppo_generalist"
DEMO_KS = (0.0, 0.1, 0.2, 0.3)
DEMO_MASSES = (0.0, 0.1, 0.2, 0.4)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="results/demo", help="output folder")
    p.add_argument("--policy", default=str(PRETRAINED), help="policy folder (default: the shipped one)")


def main(args: argparse.Namespace) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mdr_drive_env.cli import plot_run

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.1), "fast")
    results = sim.run(Waveform.paper(), 10, record_every=2)
    plot_run(results, str(out / "paper_drive_k0.2_m0.1.png"), "paper waveform, k = 0.2, m = 0.1 kg (fast solver)")
    print(f"1. the paper's drive, k = 0.2, m = 0.1 kg: <V> of the 6th period "
          f"{results[5].mean_velocity * 1e3:.3f} mm/s; plot {out / 'paper_drive_k0.2_m0.1.png'}")

    policy = Policy(args.policy)
    points = [(k, m) for k in DEMO_KS for m in DEMO_MASSES]
    with tqdm(total=2, desc="2. shipped policy vs trapezoid", unit="method") as bar:
        trap = open_loop_velocity(points, trapezoid_action())
        bar.update()
        disp, acts = policy_rollout(policy, points)
        learned = steady_velocity_of(disp)
        bar.update()
    print(f"\nsteady velocity (mm/s, mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}): "
          f"learned policy / paper trapezoid")
    print("   k  " + "".join(f"{f'm = {m:g} kg':>20}" for m in DEMO_MASSES))
    n = len(DEMO_MASSES)
    for i, k in enumerate(DEMO_KS):
        print(f"{k:5.2f} " + "".join(f"{learned[i * n + j] * 1e3:10.2f} /{trap[i * n + j] * 1e3:8.2f}"
                                     for j in range(n)))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for i, k in enumerate(DEMO_KS):
        ax.plot(DEMO_MASSES, trap[i * n:(i + 1) * n] * 1e3, "-o", color=f"C{i}", ms=3, label=f"trapezoid, k = {k:g}")
        ax.plot(DEMO_MASSES, learned[i * n:(i + 1) * n] * 1e3, ":^", color=f"C{i}", ms=4, label=f"learned, k = {k:g}")
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xlabel="cargo mass m (kg)", ylabel="steady velocity (mm/s)", ylim=(-20, 22),
           title="shipped PPO policy vs the paper's trapezoid")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "policy_vs_trapezoid.png", dpi=120)
    plt.close(fig)
    np.savetxt(out / "policy_vs_trapezoid.csv", np.column_stack([np.array(points), learned, trap]), delimiter=",",
               header="k,cargo_mass_kg,learned_m_s,trapezoid_m_s", comments="")
    print(f"\nplots and CSV in {out}/ ; done in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":  # python -m agents.demo ... is mdr-drive demo ...
    import sys

    from mdr_drive_env.cli import main as cli_main

    raise SystemExit(cli_main(["demo", *sys.argv[1:]]))
