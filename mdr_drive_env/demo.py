"""``make demo``: the paper's drive over a few grading exponents and loads, with a plot."""

from __future__ import annotations

import time
from pathlib import Path

from tqdm import tqdm

from .core import DriveParams, DriveSimulator, Waveform, steady_velocity

DEMO_KS = (0.0, 0.2, 0.3, 0.5)
DEMO_MASSES = (0.0, 0.05, 0.1, 0.2)


def demo(out: str | Path = "results/demo") -> int:
    from .cli import plot_run

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.1), "default")
    results = sim.run(Waveform.paper(), 10, record_every=10)
    plot_run(results, str(out / "paper_drive_k0.2_m0.1.png"), "paper waveform, k = 0.2, m = 0.1 kg")
    print(f"JIT compile + 10 periods: {time.perf_counter() - t0:.2f} s; plot: {out / 'paper_drive_k0.2_m0.1.png'}")

    grid = [(k, m) for k in DEMO_KS for m in DEMO_MASSES]
    v = {}
    for k, m in tqdm(grid, desc="steady velocity (paper rule, default numerics)", unit="point"):
        v[k, m] = steady_velocity(DriveParams.paper(k=k, cargo_mass=m), numerics="default").velocity
    print("\nmean slider velocity of the 6th period <V> (mm/s), paper waveform, default numerics")
    print("   k  " + "".join(f"  m = {m:<5g} kg" for m in DEMO_MASSES))
    for k in DEMO_KS:
        print(f"{k:5.2f} " + "".join(f"{v[k, m] * 1e3:13.3f}" for m in DEMO_MASSES))
    print(f"\ndone in {time.perf_counter() - t0:.1f} s")
    return 0
