"""Speed and accuracy benchmark of the solvers (``mdr-drive bench``, ``scripts/bench_speed.py``).

Everything is measured in one run on one core (numba is single-threaded here), and reported as
medians over repeated timed blocks. Writes ``bench_speed.json`` and ``bench_speed.md``.
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .bench_accuracy import accuracy_report, accuracy_waveforms, grid_displacements, reference_displacements
from .core import DriveParams, DriveSimulator, Waveform, numerics_preset
from .core import kernel as K
from .core.waveform import knots_from_params

SPEED_KS = (0.0, 0.3, 0.6, 0.9)


def _median_rate(fn, count: int, repeats: int) -> float:
    """Median over ``repeats`` blocks of ``count / time(fn())``."""
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        rates.append(count / (time.perf_counter() - t0))
    return float(np.median(rates))


def kernel_rate(preset: str, k: float, waveforms: list, periods: int, repeats: int) -> float:
    """Periods per second of the compiled per-period kernel alone (knots built beforehand)."""
    sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=0.1), preset, max_depth=6e-6)
    knots = [knots_from_params(w.x.amplitude, w.x.rise_time, w.z.amplitude, w.z.rise_time, w.z_phase, w.period,
                               -1.0, -1.0) for w in waveforms]
    sim.step(waveforms[0])  # compile / load and get into contact
    out, trace = np.zeros(K.OUT_SIZE), np.zeros((0, 7))

    def block():
        for i in range(periods):
            sim.run_kernel(*knots[i % len(knots)], 0, trace, out)

    return _median_rate(block, periods, repeats)


def env_rate(steps: int, repeats: int, **kwargs) -> float:
    import gymnasium as gym

    env = gym.make("MDRDrive-v0", max_periods=10**9, **kwargs)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(256)]
    env.step(actions[0])

    def block():
        for i in range(steps):
            env.step(actions[i % 256])

    return _median_rate(block, steps, repeats)


def vector_rates(n: int, steps: int, repeats: int, thread_counts) -> dict:
    """Env-steps per second of the batched vector env with ``n`` drives at each thread count in
    ``thread_counts`` (None: the default), the counts' blocks interleaved so that the machine's
    drifts hit them alike."""
    import gymnasium as gym

    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (32, n, 5)).astype(np.float32)
    envs = {}
    for t in thread_counts:
        venv = gym.make_vec("MDRDrive-v0", num_envs=n, vectorization_mode="vector_entry_point", max_periods=10**9,
                            num_threads=t)
        venv.reset(seed=0)
        venv.step(actions[0])
        envs[t] = venv
    rates: dict = {t: [] for t in thread_counts}
    for _ in range(repeats):
        for t, venv in envs.items():
            t0 = time.perf_counter()
            for i in range(steps):
                venv.step(actions[i % 32])
            rates[t].append(steps * n / (time.perf_counter() - t0))
    return {t: float(np.median(r)) for t, r in rates.items()}


def first_call_seconds() -> dict:
    """Time of the first period in a fresh process: JIT compile (empty numba cache), then cache load."""
    import os
    import tempfile

    code = ("import time; t=time.perf_counter(); from mdr_drive_env.core import DriveSimulator, DriveParams, Waveform;"
            "s=DriveSimulator(DriveParams.paper(), 'fast'); t1=time.perf_counter(); s.step(Waveform.paper());"
            "print(t1-t, time.perf_counter()-t1)")
    res = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("compile", "cache_load"):
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
            imp, first = (float(v) for v in out.stdout.split())
            res[f"{label}_first_period_s"] = first
            res[f"{label}_import_s"] = imp
    return res


def run(out_dir: str | Path = "results/bench", quick: bool = False, reference_cache: str | Path | None = None,
        executor=None) -> dict:
    """Speed and accuracy of the solvers into ``out_dir``; ``executor`` (``mdr_drive_env.sweep``) runs
    the paper-preset reference of the accuracy grid when it is not cached (about 14 minutes on 2 cores)."""
    from tqdm import tqdm

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    reference_cache = Path(reference_cache or out_dir / "reference_paper.npz")
    reps = 3 if quick else 7
    _, random_wfs = accuracy_waveforms(20)
    paper = [Waveform.paper()]
    rnd = random_wfs[1:]
    res: dict = {"machine": {"python": platform.python_version(), "processor": platform.processor() or platform.machine()},
                 "first_call": first_call_seconds()}

    kernel = {}
    steps = [(preset, k, name, wfs) for preset in ("fast", "default", "paper") for k in SPEED_KS
             for name, wfs in (("paper waveform", paper), ("random waveforms", rnd))]
    for preset, k, name, wfs in tqdm(steps, desc="kernel speed"):
        periods = {"fast": 2000, "default": 20, "paper": 1}[preset] // (4 if quick else 1) or 1
        r = 2 if preset == "paper" else reps
        kernel[f"{preset}|{k:g}|{name}"] = kernel_rate(preset, k, wfs, periods, r)
    res["kernel_periods_per_s"] = kernel
    fast = [v for key, v in kernel.items() if key.startswith("fast|")]
    paper_rates = [v for key, v in kernel.items() if key.startswith("paper|")]
    res["fast_kernel_min_periods_per_s"] = float(min(fast))
    res["fast_kernel_median_periods_per_s"] = float(np.median(fast))
    res["speedup_fast_vs_paper_median"] = float(np.median(fast) / np.median(paper_rates))

    res["env_steps_per_s"] = env_rate(500 if quick else 2000, reps)
    res["env_steps_per_s_default_numerics"] = env_rate(50 if quick else 200, reps, numerics="default")
    env_steps = 1000 if quick else 8000  # env-steps per timed block
    res["vector_env_steps_per_s"] = {str(n): vector_rates(n, max(4, env_steps // n), reps, [None])[None]
                                     for n in tqdm((1, 8, 64), desc="vector env")}
    from .core import batch

    thread_counts = list(range(1, batch.default_threads() + 1))
    by_threads = vector_rates(64, max(4, env_steps // 64), reps, thread_counts)
    res["vector_env_64_steps_per_s_by_threads"] = {str(t): r for t, r in by_threads.items()}
    # the scaling curve: every thread count at every N, even below the drives a thread needs by default
    limit, batch.MIN_DRIVES_PER_THREAD = batch.MIN_DRIVES_PER_THREAD, 1
    try:
        res["vector_env_scaling"] = {str(n): {str(t): r for t, r in vector_rates(n, max(4, env_steps // n), reps,
                                                                                   thread_counts).items()}
                                     for n in tqdm((8, 16, 64, 256), desc="vector env scaling")}
    finally:
        batch.MIN_DRIVES_PER_THREAD = limit
    res["min_drives_per_thread"] = limit

    actions, _ = accuracy_waveforms()
    reference = reference_displacements(reference_cache, executor=executor)
    for preset in ("fast", "default"):
        t0 = time.perf_counter()
        cand = grid_displacements(numerics_preset(preset), actions, workers=1, desc=f"accuracy grid ({preset})")
        res[f"accuracy_{preset}"] = {**accuracy_report(cand, reference), "wall_s": time.perf_counter() - t0}

    (out_dir / "bench_speed.json").write_text(json.dumps(res, indent=2))
    (out_dir / "bench_speed.md").write_text(markdown(res))
    return res


def markdown(res: dict) -> str:
    lines = ["| solver | k | waveforms | periods/s (median) |", "|---|---|---|---|"]
    for key, v in res["kernel_periods_per_s"].items():
        preset, k, name = key.split("|")
        lines.append(f"| {preset} | {k} | {name} | {v:,.0f} |")
    lines += ["", f"* fast kernel: min {res['fast_kernel_min_periods_per_s']:,.0f}, median "
                  f"{res['fast_kernel_median_periods_per_s']:,.0f} periods/s; speed-up against the paper preset "
                  f"(medians, same run): {res['speedup_fast_vs_paper_median']:,.0f}x",
              f"* `env.step` via `gym.make(\"MDRDrive-v0\")` (default wrappers, fast numerics): "
              f"{res['env_steps_per_s']:,.0f} steps/s; with `numerics=\"default\"`: "
              f"{res['env_steps_per_s_default_numerics']:,.0f} steps/s",
              "* batched vector env (`gym.make_vec(..., vectorization_mode=\"vector_entry_point\")`, all cores), "
              "env-steps/s: " + ", ".join(f"N = {n}: {v:,.0f}" for n, v in res["vector_env_steps_per_s"].items()),
              "* batched vector env, N = 64, by thread count (`num_threads`), env-steps/s: "
              + ", ".join(f"{t} thread{'s' if t != '1' else ''}: {v:,.0f}"
                          for t, v in res["vector_env_64_steps_per_s_by_threads"].items()),
              f"* first period in a fresh process, not a per-step cost: JIT compile with an empty numba cache "
              f"{res['first_call']['compile_first_period_s']:.1f} s (import {res['first_call']['compile_import_s']:.1f} s); "
              f"from numba's cache {res['first_call']['cache_load_first_period_s']:.2f} s "
              f"(import {res['first_call']['cache_load_import_s']:.2f} s)", ""]
    scaling = res.get("vector_env_scaling")
    if scaling:
        counts = list(next(iter(scaling.values())))
        lines += ["Batched vector env, env-steps/s by drives N and threads (`num_threads`; every count forced, "
                  f"below the default's {res['min_drives_per_thread']} drives a thread too):", "",
                  "| N | " + " | ".join(f"{t} thread{'s' if t != '1' else ''}" for t in counts)
                  + f" | {counts[-1]} over 1 |", "|---|" + "---|" * (len(counts) + 1)]
        for n, row in scaling.items():
            lines.append(f"| {n} | " + " | ".join(f"{row[t]:,.0f}" for t in counts)
                         + f" | {row[counts[-1]] / row[counts[0]]:.2f} |")
        lines.append("")
    lines += ["| solver | max error (µm) | max error / tolerance | within tolerance | worst case |", "|---|---|---|---|---|"]
    for preset in ("fast", "default"):
        a = res[f"accuracy_{preset}"]
        w = a["worst_case"]
        lines.append(f"| {preset} | {a['max_abs_error_um']:.4f} | {a['max_error_over_tolerance']:.3f} | "
                     f"{a['fraction_within_tolerance'] * 100:.2f} % | k = {w['k']}, m = {w['cargo_mass']} kg, waveform "
                     f"{w['waveform']}, period {w['period']}: {w['error_um']:.4f} of {w['reference_um']:.3f} µm |")
    lines.append(f"\nTolerance per period: max(0.15 µm, 0.5 % of the paper preset's displacement); "
                 f"{res['accuracy_fast']['cases']} cases x {res['accuracy_fast']['periods']} periods.")
    return "\n".join(lines) + "\n"
