"""The normalised score of a drive, and its aggregates with bootstrap intervals.

Per point, ``(V - V_trapezoid) / (V_best - V_trapezoid)``: 0 is the paper's trapezoid, 1 the best
drive a stated search finds (the blind benchmark's), above 1 a drive faster than that. A point is
scored only where the best drive beats the trapezoid by at least ``SCORE_MIN_GAP`` (elsewhere the
ratio is noise over a small denominator). A runaway (NaN: the load runs away with the slider) counts
as velocity 0, as in the fraction of the best drive.

The aggregates are those of rliable (Agarwal et al., 2021, "Deep RL at the edge of the statistical
precipice"): the interquartile mean (IQM, the mean of the middle 50 % of the scores) and the mean,
each with a 95 % percentile interval from a stratified bootstrap: every stratum (a blind seed's
points, or one point's training runs) is resampled with replacement on its own and the statistic
taken over them all.

    scores = normalized_scores(trap, best, learned)            # m/s arrays of one blind benchmark
    aggregate([scores])                                       # one seed: the points resampled
    aggregate([scores_seed1, scores_seed2, ...])              # a record: each seed's points apart
"""

from __future__ import annotations

import numpy as np

#: A point is scored where the best drive beats the trapezoid by at least this (m/s).
SCORE_MIN_GAP = 2e-3
#: Bootstrap resamples and the interval's coverage.
BOOTSTRAP_REPS = 10_000
CONFIDENCE = 0.95


def normalized_scores(trap, best, learned) -> np.ndarray:
    """Per point ``(V - V_trapezoid) / (V_best - V_trapezoid)`` of steady velocities (m/s; NaN is a
    runaway and counts as 0); NaN where the best drive beats the trapezoid by less than
    ``SCORE_MIN_GAP``."""
    trap, best, learned = (np.nan_to_num(np.asarray(a, dtype=float), nan=0.0) for a in (trap, best, learned))
    if not trap.shape == best.shape == learned.shape:
        raise ValueError(f"trap, best and learned differ in shape: {trap.shape}, {best.shape}, {learned.shape}")
    gap = best - trap
    scored = gap >= SCORE_MIN_GAP
    return np.where(scored, (learned - trap) / np.where(scored, gap, 1.0), np.nan)


def iqm(scores) -> float:
    """The interquartile mean: the mean of the middle 50 % of ``scores`` (rliable's, i.e.
    ``scipy.stats.trim_mean(scores, 0.25)``)."""
    x = np.sort(np.asarray(scores, dtype=float).ravel())
    if x.size == 0:
        raise ValueError("no scores to average")
    cut = int(0.25 * x.size)
    return float(x[cut:x.size - cut].mean())


def aggregate(strata, reps: int = BOOTSTRAP_REPS, seed: int = 0) -> dict:
    """IQM and mean of the scores of all ``strata`` (arrays; NaN, an unscored point, dropped), each
    as ``[estimate, low, high]`` with a ``CONFIDENCE`` stratified-bootstrap percentile interval
    (``reps`` resamples drawn with ``seed``: the same strata give the same interval), and the
    number of scores. ``None`` values when nothing is scored."""
    groups = [np.asarray(s, dtype=float).ravel() for s in strata]
    groups = [g[np.isfinite(g)] for g in groups]
    groups = [g for g in groups if g.size]
    n = sum(g.size for g in groups)
    if not n:
        return {"iqm": None, "mean": None, "scores": 0}
    rng = np.random.default_rng(seed)
    cut = int(0.25 * n)
    boot = {"iqm": [], "mean": []}
    for start in range(0, reps, 1000):  # in blocks: memory stays at 1,000 resamples
        size = min(1000, reps - start)
        samples = np.sort(np.concatenate([g[rng.integers(0, g.size, (size, g.size))] for g in groups], axis=1), axis=1)
        boot["iqm"].append(samples[:, cut:n - cut].mean(axis=1))
        boot["mean"].append(samples.mean(axis=1))
    boot = {name: np.concatenate(values) for name, values in boot.items()}
    every = np.concatenate(groups)
    point = {"iqm": iqm(every), "mean": float(every.mean())}
    tail = 100 * (1 - CONFIDENCE) / 2
    return {**{name: [point[name], *(float(q) for q in np.percentile(boot[name], [tail, 100 - tail]))]
               for name in point}, "scores": int(n)}


def format_aggregate(agg: dict) -> str:
    """``IQM 0.93 [0.91, 0.95], mean 0.94 [0.92, 0.96] (120 points)`` or ``-`` when nothing is scored."""
    if not agg or agg.get("iqm") is None:
        return "-"
    cells = [f"{name} {v:.3f} [{lo:.3f}, {hi:.3f}]" for name, (v, lo, hi) in (("IQM", agg["iqm"]), ("mean", agg["mean"]))]
    return f"{', '.join(cells)} ({agg['scores']:,} points)"


__all__ = ["BOOTSTRAP_REPS", "CONFIDENCE", "SCORE_MIN_GAP", "aggregate", "format_aggregate", "iqm",
           "normalized_scores"]
