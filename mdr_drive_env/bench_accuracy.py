"""Accuracy grid of the fast solver against the `paper` preset (issue: fast solver).

Cases: k in ACCURACY_KS x cargo mass in ACCURACY_MASSES x (the paper waveform + N random
waveforms from the env's action box), each run for ACCURACY_PERIODS periods with a fixed waveform.
The per-period slider displacements of the `paper` preset are cached in an .npz (they take about
half an hour of CPU), keyed by the waveforms they were computed for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .core import DriveParams, DriveSimulator, Waveform, numerics_preset
from .files import atomic_path
from .gym_envs.spaces import ActionMap
from .sweep import Executor, TaskStore

ACCURACY_KS = (0.0, 0.2, 0.3, 0.5, 0.9)
ACCURACY_MASSES = (0.0, 0.05, 0.1, 0.2, 0.4)
ACCURACY_PERIODS = 10
N_RANDOM_WAVEFORMS = 20
WAVEFORM_SEED = 2026
MAX_DEPTH = 6e-6  # the env's z_amplitude_max
#: Per-period displacement tolerance: the larger of 0.15 um and 0.5 % of the reference.
ABS_TOL = 0.15e-6
REL_TOL = 5e-3


def accuracy_waveforms(n_random: int = N_RANDOM_WAVEFORMS, seed: int = WAVEFORM_SEED) -> tuple[np.ndarray, list[Waveform]]:
    """The paper waveform plus ``n_random`` waveforms from uniform actions in the env's box."""
    amap = ActionMap()
    rng = np.random.default_rng(seed)
    actions = np.vstack([amap.to_action(Waveform.paper())[None].astype(np.float64),
                         rng.uniform(-1.0, 1.0, (n_random, ActionMap.SIZE))])
    return actions, [amap.to_waveform(a) for a in actions]


def _run(args) -> np.ndarray:
    k, m, action, numerics, periods = args
    wf = ActionMap().to_waveform(action)
    sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), numerics, max_depth=MAX_DEPTH)
    return np.array([r.displacement for r in sim.run(wf, periods)])


def grid_displacements(numerics, actions: np.ndarray, periods: int = ACCURACY_PERIODS, workers: int | None = None,
                       desc: str = "accuracy grid", progress: bool = True, executor: Executor | None = None,
                       store: TaskStore | None = None) -> np.ndarray:
    """Per-period displacements (m), shape (len(ks), len(masses), len(actions), periods); the cases
    run on ``executor`` (default: ``workers`` local processes), kept in ``store`` as they finish."""
    cases = [(k, m, a, numerics, periods) for k in ACCURACY_KS for m in ACCURACY_MASSES for a in actions]
    executor = executor or Executor(workers=workers, progress=progress)
    out = executor.map(_run, cases, desc, store=store)
    return np.array(out).reshape(len(ACCURACY_KS), len(ACCURACY_MASSES), len(actions), periods)


def reference_displacements(cache: str | Path, recompute: bool = False, workers: int | None = None,
                            executor: Executor | None = None) -> np.ndarray:
    """The `paper` preset's displacements on the accuracy grid, from ``cache`` or computed (slow; each
    finished case is kept beside the cache, so an interrupted computation continues where it stopped)."""
    actions, _ = accuracy_waveforms()
    cache = Path(cache)
    if cache.exists() and not recompute:
        data = np.load(cache)
        waveforms = np.array([list(ActionMap().to_params(a)) for a in accuracy_waveforms()[0]])
        if (np.array_equal(data["actions"], actions) and np.array_equal(data["waveforms"], waveforms) and tuple(data["ks"]) == ACCURACY_KS
                and tuple(data["masses"]) == ACCURACY_MASSES and data["displacement"].shape[-1] == ACCURACY_PERIODS):
            return data["displacement"]
    store = TaskStore(cache.parent / ".tasks" / cache.stem)
    disp = grid_displacements(numerics_preset("paper"), actions, workers=workers, desc="reference (paper preset)",
                              executor=executor, store=store)
    waveforms = np.array([list(ActionMap().to_params(a)) for a in accuracy_waveforms()[0]])
    with atomic_path(cache) as tmp:
        np.savez_compressed(tmp, displacement=disp, actions=actions, waveforms=waveforms, ks=np.array(ACCURACY_KS),
                            masses=np.array(ACCURACY_MASSES))
    store.clear()
    return disp


def accuracy_report(candidate: np.ndarray, reference: np.ndarray) -> dict:
    """Errors of ``candidate`` against ``reference`` under the per-period tolerance."""
    err = np.abs(candidate - reference)
    tol = np.maximum(ABS_TOL, REL_TOL * np.abs(reference))
    worst = np.unravel_index(np.argmax(err / tol), err.shape)
    return {
        "max_abs_error_um": float(err.max() * 1e6),
        "max_error_over_tolerance": float((err / tol).max()),
        "fraction_within_tolerance": float((err <= tol).mean()),
        "worst_case": {"k": ACCURACY_KS[worst[0]], "cargo_mass": ACCURACY_MASSES[worst[1]],
                       "waveform": int(worst[2]), "period": int(worst[3]) + 1,
                       "reference_um": float(reference[worst] * 1e6), "error_um": float(err[worst] * 1e6)},
        "cases": int(np.prod(reference.shape[:3])),
        "periods": int(reference.shape[-1]),
    }


__all__ = ["accuracy_waveforms", "grid_displacements", "reference_displacements", "accuracy_report"]
