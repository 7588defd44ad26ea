"""The learning targets and the statistics that judge a drive against them (velocities in m/s; NaN
is a runaway): where it is below the paper's trapezoid, its fraction of the best drive a search
finds, and its critical load against the trapezoid's and the best two-action cycle's. The blind
benchmark, the dense check and the sensor policy's report all count with these.
"""

from __future__ import annotations

import numpy as np

from ..protocol import BELOW_TOLERANCE, MOVING_THRESHOLD
from .score import aggregate, normalized_scores

#: The targets: the fraction of the best drive at every scored point and on average, and the
#: critical load over the best two-action cycle's at every scanned k (-).
FRACTION_TARGET = 0.85
MEAN_FRACTION_TARGET = 0.95
CRITICAL_LOAD_TARGET = 0.97


def below_trapezoid(trap: np.ndarray, learned: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a drive is below the trapezoid: slower by more than ``BELOW_TOLERANCE`` where either
    moves; with its velocity minus the trapezoid's (m/s; a runaway, NaN, as -inf) and where either
    moves. Returns (below, gap, moving)."""
    moving = (trap > 0) | (learned > 0)
    with np.errstate(invalid="ignore"):  # both runaway: -inf - -inf, and neither moves there
        gap = np.where(np.isnan(learned), -np.inf, learned) - np.where(np.isnan(trap), -np.inf, trap)
    return moving & (gap < -BELOW_TOLERANCE), gap, moving


def velocity_statistics(trap: np.ndarray, best: np.ndarray, learned: np.ndarray) -> dict:
    """Points below the trapezoid (where either moves, ``below_trapezoid``), the fraction of the
    best drive (where it moves at least ``MOVING_THRESHOLD``) and the normalised score (``score``:
    IQM and mean with bootstrap intervals over the points) of one drive's steady velocities (m/s;
    NaN is a runaway)."""
    below, gap, moving = below_trapezoid(trap, learned)
    comparable = moving & np.isfinite(gap)
    scored = best >= MOVING_THRESHOLD
    fraction = np.where(np.isnan(learned), 0.0, learned)[scored] / best[scored]
    return {
        "points_below_trapezoid": int(below.sum()),
        "worst_difference_to_trapezoid_mm_s": float(gap[comparable].min() * 1e3) if comparable.any() else None,
        "points_runaway_where_trapezoid_moves": int((np.isnan(learned) & (trap > 0)).sum()),
        "points_scored": int(scored.sum()),
        "fraction_of_best_mean": float(fraction.mean()) if fraction.size else None,
        "fraction_of_best_min": float(fraction.min()) if fraction.size else None,
        "points_under_fraction_target": int((fraction < FRACTION_TARGET).sum()),
        "normalized_score": aggregate([normalized_scores(trap, best, learned)]),
    }


def statistics(trap: np.ndarray, best: np.ndarray, learned: np.ndarray, crit: dict, ks) -> dict:
    """The blind statistics of one policy (velocities in m/s; NaN is a runaway)."""
    return {**velocity_statistics(trap, best, learned), **critical_load_statistics(crit, ks)}


def critical_load_statistics(crit: dict, ks) -> dict:
    """The critical-load statistics of one policy: ``crit`` holds the critical loads (kg) of the
    "policy", the "trapezoid" and the "best cycle" at each k of ``ks``; their ratios (None where
    the reference carries nothing), the smallest to the best cycle's and the k values at the target."""
    ratio_trap = [crit["policy"][i] / crit["trapezoid"][i] if crit["trapezoid"][i] > 0 else None
                  for i in range(len(ks))]
    ratio_cycle = [crit["policy"][i] / crit["best cycle"][i] if crit["best cycle"][i] > 0 else None
                   for i in range(len(ks))]
    finite = [r for r in ratio_cycle if r is not None]
    return {
        "critical_load_over_trapezoid": ratio_trap,
        "critical_load_over_best_cycle": ratio_cycle,
        "critical_load_over_best_cycle_min": min(finite) if finite else None,
        "k_values_at_critical_load_target": sum(r >= CRITICAL_LOAD_TARGET for r in finite),
    }


def missed_targets(stats: dict) -> list[str]:
    """The targets one policy's blind statistics (``statistics``) miss, by name;
    empty when it meets every one: no point below the trapezoid (by more than ``BELOW_TOLERANCE``),
    the fraction of the best drive at least ``MEAN_FRACTION_TARGET`` on average and
    ``FRACTION_TARGET`` at every scored point, the critical load at least ``CRITICAL_LOAD_TARGET``
    of the best cycle's at every scanned k. A statistic with nothing to judge (None: no point where
    the best drive moves, no k where the best cycle carries a load) misses nothing."""
    def at_least(value, target):
        return value is None or value >= target

    checks = {
        "below the trapezoid": stats["points_below_trapezoid"] == 0,
        "fraction of the best: mean": at_least(stats["fraction_of_best_mean"], MEAN_FRACTION_TARGET),
        "fraction of the best: minimum": at_least(stats["fraction_of_best_min"], FRACTION_TARGET),
        "critical load": at_least(stats["critical_load_over_best_cycle_min"], CRITICAL_LOAD_TARGET),
    }
    return [name for name, met in checks.items() if not met]


__all__ = ["BELOW_TOLERANCE", "CRITICAL_LOAD_TARGET", "FRACTION_TARGET", "MEAN_FRACTION_TARGET", "MOVING_THRESHOLD",
           "below_trapezoid", "critical_load_statistics", "missed_targets", "statistics", "velocity_statistics"]
