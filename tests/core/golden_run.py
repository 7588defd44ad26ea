"""The golden-regression run: shared by test_golden.py and by `python -m tests.core.golden_run`, which
rewrites tests/data/golden_k02_m01.npz (do that only for an intended change of the physics, and
say why in the commit)."""


import numpy as np

from mdr_drive_env.core import AxisWaveform, DriveParams, DriveSimulator, Numerics, Waveform
from tests import DATA

GOLDEN = DATA / "golden_k02_m01.npz"
FIELDS = ("displacement", "mean_velocity", "peak_tangential_force", "peak_normal_force",
          "indenter_dissipation", "base_dissipation", "load_work", "indenter_work_x", "indenter_work_z")


def golden_run():
    """k = 0.2, m = 0.1 kg, dt = 1e-6 s, dx = 1e-7 m: 3 paper periods then 2 other waveforms."""
    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.1), Numerics(1e-6, 1e-7))
    other = Waveform(x=AxisWaveform(20e-6, 1.5e-3, 0.5e-3), z=AxisWaveform(5e-6, 1.0e-3, 1.0e-3), z_phase=0.3)
    results = [sim.step(wf, record_every=20) for wf in [Waveform.paper()] * 3 + [other, Waveform.paper()]]
    trace = np.concatenate([r.trace for r in results])
    periods = np.array([[getattr(r, f) for f in FIELDS] for r in results])
    return trace, periods


if __name__ == "__main__":
    trace, periods = golden_run()
    GOLDEN.parent.mkdir(exist_ok=True)
    np.savez_compressed(GOLDEN, trace=trace, periods=periods)
    print(f"wrote {GOLDEN}: trace {trace.shape}, periods {periods.shape}")
