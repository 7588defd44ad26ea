"""The teacher's settings: its grid and search budgets (``FieldConfig``), read from the recipe YAML's
``teacher`` section, and the friction the drives are searched at by default (``PAPER_FRICTION``).
The field they build is ``agents.drive_field.DriveField``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mdr_drive_env.core.params import check_int, check_range

#: The paper's friction coefficients (mu indenter-slider, mu1 slider-base), the env's defaults.
PAPER_FRICTION = (0.3, 0.1)


def check_search(stage: str, budget, sigma) -> None:
    """A teacher stage's CMA-ES settings: ``budget`` evaluations (an integer >= 1) and initial step
    ``sigma`` in (0, 1] (action units); ``ValueError`` naming "<stage> budget" or "<stage> sigma"."""
    check_int(f"{stage} budget", budget, 1)
    check_range(f"{stage} sigma", sigma, 0.0, 1.0, low_open=True)


@dataclass(frozen=True)
class FieldConfig:
    """The teacher's grid and search budgets.

    Attributes:
        k_values: grid values of the grading exponent k, spread evenly over ``k_range`` (-).
        k_range: (low, high) of k (-).
        load_fractions: grid values of the load, spread evenly from 0 to ``max_load_fraction`` times
            the trapezoid's critical load at each k (-).
        max_load_fraction: heaviest grid load / the trapezoid's critical load (-).
        fixed_budget: CMA-ES evaluations of the fixed-action search per point (-).
        cycle_budget: CMA-ES evaluations of the two-action search per start and point (-).
        sigma0: CMA-ES initial step size of both searches (action units).
        consolidate_tolerance: after the search, nodes take their neighbours' most shared drive if it
            loses at most this fraction of their velocity (``DriveField.consolidate``; 0: off) (-).
        polish: passes after the search, exchange and consolidation, each (budget, sigma): every node
            runs a CMA-ES search over two-action cycles from its own drive and from each of its four
            grid neighbours' drives, ``budget`` evaluations per start with initial step ``sigma``
            (action units), keeps a faster drive, and the nodes exchange again
            (``DriveField.polish``; empty: none) (-, action units).
        refine_k: after the polish passes, (budget, sigma) or (budget, sigma, k_max): a k line
            between every two (below k_max), each new node started from the best of the
            interpolation of its two k neighbours' drives and the drives of the six nodes around it,
            then polished from the three best of them
            (``DriveField.refine_k``; empty: none) (-, action units). The teacher's drive between two
            k lines is an interpolation, and where the best drive changes with k (push/clamp cycles
            past the trapezoid's critical load) it falls short of a search there.
        refine_load: after the k lines, (budget, sigma, low, high) or (budget, sigma, low, high, k_max):
            a load line between every two whose midpoint fraction lies in [low, high], on every k line
            (searched up to k_max, above it each new node a copy of a neighbour's drive), each new node started from the
            best of the interpolation of its lighter and heavier neighbours' drives and the six nodes
            around it, then polished from the three best (``DriveField.refine_load``; empty: none)
            (-, action units, -, -, -). Between load lines 0.12 apart the best drive can change (past
            about 0.6 of the trapezoid's critical load, where it slows steeply with the load).
        refine_steep: after them, (budget, sigma, low, high, drop) or empty: a load line at the
            midpoint of every cell whose midpoint fraction lies in [low, high] and across which the
            forward velocity falls by more than ``drop`` (m/s) on at least one k line, searched as
            ``refine_load``'s (``DriveField.refine_load`` with ``min_drop``) (-, action units, -, -, m/s).
            Where the best drive falls off an edge within one cell, the teacher between the two nodes
            plays one of their drives, and a search at the midpoint finds a faster one.
        polish_stall: last, (budget, sigma) or (budget, sigma, k_max) or empty: on every k line (up to
            k_max), the two nodes on either side of its stall (the heaviest that moves and the next
            heavier) play their own, their lighter and k neighbours' drives and the push/clamp cycle,
            then CMA-ES over two-action cycles runs from the three fastest (``budget`` evaluations
            each, step ``sigma``) and each keeps a faster drive (``DriveField.polish_stall``) (-,
            action units, -). The grid's searches there are weaker than the blind benchmark's
            critical-load bisection, and the teacher's critical load is the stall node's.
        polish_band: after it, (budget, sigma, k_low, k_high, low, high) or empty: every node with k in
            [k_low, k_high] and load fraction in [low, high] searched as ``polish_stall``'s, from its
            two fastest trials (``DriveField.polish_band``) (-, action units, -, -, -, -). Near the
            critical load at k = 0.18-0.24 the grid's drives were up to 17 % slower than the blind
            benchmark's per-point search (results/blind/teacher_band_decision).
        refine_band: last, (budget, sigma, k_low, k_high, low, high) or empty: a load line between
            every two whose midpoint fraction lies in [low, high], searched at the k lines in [k_low,
            k_high] from the best of the six nodes around each new node and every searched k line's
            nodes on its two load lines (``starts`` 2), elsewhere a copy of its faster neighbour's drive
            (``DriveField.refine_band``) (-, action units, -, -, -, -). Near the trapezoid's critical
            load at k = 0.18-0.22 the band-polished grid's drives were up to 20 % short of a per-point
            search between its load lines (results/blind/dense_band_decision/TEACHER_PROBE.md).
        friction: (mu, mu1), the indenter-slider and slider-base friction coefficients the drives are
            searched at (-); the grid's loads stay fractions of the trapezoid's critical load at the
            paper's friction (0.3, 0.1).
    """

    k_values: int = 13
    k_range: tuple[float, float] = (0.0, 0.6)
    load_fractions: int = 12
    max_load_fraction: float = 1.3
    fixed_budget: int = 300
    cycle_budget: int = 700
    sigma0: float = 0.25
    consolidate_tolerance: float = 0.0
    polish: tuple[tuple[int, float], ...] = ()
    refine_k: tuple = ()
    refine_load: tuple = ()
    refine_steep: tuple = ()
    polish_stall: tuple = ()
    polish_band: tuple = ()
    refine_band: tuple = ()
    friction: tuple[float, float] = PAPER_FRICTION

    def __post_init__(self) -> None:
        for name, low in (("k_values", 2), ("load_fractions", 2), ("fixed_budget", 1), ("cycle_budget", 1)):
            check_int(name, getattr(self, name), low)
        lo, hi = self.k_range
        if not 0.0 <= lo < hi <= 1.0:
            raise ValueError(f"k_range={self.k_range!r} must satisfy 0 <= low < high <= 1")
        check_range("max_load_fraction", self.max_load_fraction, 0.0, 5.0, low_open=True)
        check_range("consolidate_tolerance", self.consolidate_tolerance, 0.0, 1.0, high_open=True)
        check_range("sigma0", self.sigma0, 0.0, 1.0, low_open=True)
        for entry in self.polish:
            if len(entry) != 2:
                raise ValueError(f"polish={self.polish!r}: each pass is (budget, sigma)")
            check_search("polish", *entry)
        if self.refine_k:
            if len(self.refine_k) not in (2, 3):
                raise ValueError(f"refine_k={self.refine_k!r} must be (budget, sigma), (budget, sigma, k_max) or empty")
            check_search("refine_k", *self.refine_k[:2])
            if len(self.refine_k) == 3:
                check_range("refine_k k_max", self.refine_k[2], *self.k_range, low_open=True)
        if self.refine_load:
            if len(self.refine_load) not in (4, 5):
                raise ValueError(f"refine_load={self.refine_load!r} must be (budget, sigma, low, high), "
                                 "(budget, sigma, low, high, k_max) or empty")
            self._check_load_lines("refine_load", self.refine_load)
            if len(self.refine_load) == 5:
                check_range("refine_load k_max", self.refine_load[4], *self.k_range)
        if self.refine_steep:
            if len(self.refine_steep) != 5:
                raise ValueError(f"refine_steep={self.refine_steep!r} must be (budget, sigma, low, high, drop) or empty")
            self._check_load_lines("refine_steep", self.refine_steep)
            check_range("refine_steep drop", self.refine_steep[4], 0.0, 0.1, low_open=True)
        if self.polish_stall:
            if len(self.polish_stall) not in (2, 3):
                raise ValueError(f"polish_stall={self.polish_stall!r} must be (budget, sigma), (budget, sigma, k_max) "
                                 "or empty")
            check_search("polish_stall", *self.polish_stall[:2])
            if len(self.polish_stall) == 3:
                check_range("polish_stall k_max", self.polish_stall[2], *self.k_range)
        for stage in ("polish_band", "refine_band"):
            self._check_band(stage, getattr(self, stage))
        if len(self.friction) != 2:
            raise ValueError(f"friction={self.friction!r} must be (mu, mu1)")
        check_range("friction mu", self.friction[0], 0.0, 2.0, low_open=True)
        check_range("friction mu1", self.friction[1], 0.0, 2.0)

    def _check_band(self, stage: str, band: tuple) -> None:
        """A stage searched in a band of k and load, (budget, sigma, k_low, k_high, low, high) or empty."""
        if not band:
            return
        if len(band) != 6:
            raise ValueError(f"{stage}={band!r} must be (budget, sigma, k_low, k_high, low, high) or empty")
        check_search(stage, *band[:2])
        check_range(f"{stage} k_low", band[2], *self.k_range)
        check_range(f"{stage} k_high", band[3], band[2], self.k_range[1])
        check_range(f"{stage} low", band[4], 0.0, self.max_load_fraction)
        check_range(f"{stage} high", band[5], band[4], self.max_load_fraction)

    def _check_load_lines(self, stage: str, lines: tuple) -> None:
        """A stage that adds searched load lines, (budget, sigma, low, high, ...): its search and its
        band of load fractions, within [0, max_load_fraction]."""
        check_search(stage, *lines[:2])
        check_range(f"{stage} low", lines[2], 0.0, self.max_load_fraction)
        check_range(f"{stage} high", lines[3], lines[2], self.max_load_fraction)

    @property
    def ks(self) -> np.ndarray:
        return np.linspace(*self.k_range, self.k_values)

    @property
    def fractions(self) -> np.ndarray:
        return np.linspace(0.0, self.max_load_fraction, self.load_fractions)


__all__ = ["PAPER_FRICTION", "FieldConfig", "check_search"]
