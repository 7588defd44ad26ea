#!/usr/bin/env python
"""Where one ``env.step`` of MDRDrive-v0 spends its time (docs/performance.md).

    python scripts/profile_step.py [--steps 3000]

Times, as medians of 7 blocks on one core: ``env.step`` through ``gym.make`` (default wrappers:
TimeLimit, OrderEnforcing, PassiveEnvChecker), the unwrapped ``step``, and its parts (the action map,
the waveform's knots, the compiled kernel, the observation, the info dict); then the functions
that take the most time under cProfile (which inflates Python calls, so read it for ranking only).
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402

import mdr_drive_env  # noqa: E402, F401
from mdr_drive_env.core import kernel as K  # noqa: E402
from mdr_drive_env.core.waveform import knots_from_params  # noqa: E402


def per_call_us(fn, calls: int, repeats: int = 7) -> float:
    """Median over ``repeats`` blocks of the time per call (us)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        times.append((time.perf_counter() - t0) / calls * 1e6)
    return float(np.median(times))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=3000, help="calls per timed block (-)")
    a = ap.parse_args(argv)
    env = gym.make("MDRDrive-v0", max_periods=10**9)
    env.reset(seed=0)
    u = env.unwrapped
    actions = np.random.default_rng(0).uniform(-1, 1, (256, 5)).astype(np.float32)
    i = [0]

    def wrapped():
        i[0] += 1
        env.step(actions[i[0] % 256])

    def unwrapped():
        i[0] += 1
        u.step(actions[i[0] % 256])

    wp = u.action_map.to_params(actions[1])
    knots = knots_from_params(wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase, wp.period,
                              1e-6, -1.0)
    trace, out = np.zeros((0, 7)), np.zeros(K.OUT_SIZE)
    result = u.sim.step_params(wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase, wp.period)
    wrapped()  # compiled, in contact
    rows = [
        ("env.step via gym.make (default wrappers)", per_call_us(wrapped, a.steps)),
        ("env.unwrapped.step", per_call_us(unwrapped, a.steps)),
        ("  action map (ActionMap.to_params)", per_call_us(lambda: u.action_map.to_params(actions[1]), a.steps)),
        ("  waveform knots (compiled)", per_call_us(lambda: knots_from_params(
            wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase, wp.period, 1e-6, -1.0),
            a.steps)),
        ("  kernel: one period (compiled call)", per_call_us(lambda: u.sim.run_kernel(*knots, 0, trace, out), a.steps)),
        ("  simulator step around the kernel (DriveSimulator.step_params)", per_call_us(
            lambda: u.sim.step_params(wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase,
                                      wp.period), a.steps)),
        ("  observation", per_call_us(lambda: u._observation(result), a.steps)),
        ("  info dict", per_call_us(lambda: u._info(result, wp, 0.1), a.steps)),
    ]
    print("| part | us per call (median of 7 blocks) |\n|---|---|")
    for name, us in rows:
        print(f"| {name} | {us:.1f} |")
    wrappers = rows[0][1] - rows[1][1]
    print(f"\nsteps/s via gym.make: {1e6 / rows[0][1]:,.0f}; the default wrappers cost {wrappers:.1f} us per step; "
          f"the kernel is {rows[4][1] / rows[0][1] * 100:.0f} % of a step")
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(a.steps):
        wrapped()
    prof.disable()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(10)
    print("\ncProfile, by own time (inflates Python calls: a ranking, not a timing):")
    print("\n".join(line for line in text.getvalue().splitlines() if line.strip())[:3000])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
