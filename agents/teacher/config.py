"""The teacher's settings: its grid and search budgets (``FieldConfig``) and its stages, each a small
typed dataclass read from the recipe YAML's ``teacher`` section, e.g.

    polish_stall: {budget: 1500, sigma: 0.3, k_max: 0.15}

The field they build is ``mdr_drive_agents.teacher.field.DriveField``; the stages' work is in
``mdr_drive_agents.teacher.refine``. Budgets are CMA-ES evaluations per start and node (-), ``sigma``
its initial step size (action units), load bounds fractions of the trapezoid's critical load at
each k (-).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mdr_drive_env.core.params import check_bool, check_int, check_range

from ..drive import MIN_SEARCH_STEPS

#: The paper's friction coefficients (mu indenter-slider, mu1 slider-base), the env's defaults.
PAPER_FRICTION = (0.3, 0.1)


def check_search(stage: str, budget, sigma) -> None:
    """A stage's CMA-ES settings: ``budget`` evaluations (an integer >= 1) and initial step ``sigma`` in
    (0, 1] (action units); ``ValueError`` naming "<stage> budget" or "<stage> sigma"."""
    check_int(f"{stage} budget", budget, 1)
    check_range(f"{stage} sigma", sigma, 0.0, 1.0, low_open=True)


def _float(value) -> float | None:
    return None if value is None else float(value)


@dataclass(frozen=True)
class PolishPass:
    """One polish pass: every node runs CMA-ES over two-action cycles from its own drive and from each
    of its four grid neighbours' drives, keeps a faster drive, and the nodes exchange again
    (``DriveField.polish``)."""

    budget: int
    sigma: float

    def __post_init__(self) -> None:
        check_search("polish", self.budget, self.sigma)


@dataclass(frozen=True)
class RefineK:
    """A k line between every two of the grid's (below ``k_max``, if given), each new node started from
    the best of the interpolation of its two k neighbours' drives and the drives of the six nodes
    around it, then polished from the three best of them (``refine.refine_k``). The teacher's drive
    between two k lines is an interpolation, and where the best drive changes with k it falls short of
    a search there."""

    budget: int
    sigma: float
    k_max: float | None = None
    SEED_OFFSET = 900_000

    def __post_init__(self) -> None:
        check_search("refine_k", self.budget, self.sigma)

    def run(self, field, executor, seed: int) -> None:
        from .refine import refine_k

        refine_k(field, int(self.budget), float(self.sigma), executor=executor, seed=seed, k_max=_float(self.k_max))
        field.settle()


@dataclass(frozen=True)
class RefineLoad:
    """A load line between every two whose midpoint fraction lies in [``low``, ``high``], on every k line
    (searched up to ``k_max``; above it each new node a copy of a neighbour's drive), each new node
    started from the best of the interpolation of its lighter and heavier neighbours' drives and the six
    nodes around it, then polished from the three best (``refine.refine_load``). Between load lines
    0.12 apart the best drive can change where it slows steeply with the load."""

    budget: int
    sigma: float
    low: float
    high: float
    k_max: float | None = None
    SEED_OFFSET = 950_000

    def __post_init__(self) -> None:
        check_search("refine_load", self.budget, self.sigma)

    def run(self, field, executor, seed: int) -> None:
        from .refine import refine_load

        refine_load(field, int(self.budget), float(self.sigma), (float(self.low), float(self.high)),
                    executor=executor, seed=seed, k_max=_float(self.k_max))
        field.settle()


@dataclass(frozen=True)
class RefineSteep:
    """A load line at the midpoint of every cell whose midpoint fraction lies in [``low``, ``high``] and
    across which the forward velocity falls by more than ``relative_drop`` times the drive's stroke
    speed (``DriveDescription.stroke_speed``; 1/3 of it is 5 mm/s on the paper's drive) on at least one
    k line, searched as ``RefineLoad``'s. Where the best drive falls off an edge within one cell, the
    teacher between the two nodes plays one of their drives, and a search at the midpoint finds a
    faster one."""

    budget: int
    sigma: float
    low: float
    high: float
    relative_drop: float
    SEED_OFFSET = 960_000

    def __post_init__(self) -> None:
        check_search("refine_steep", self.budget, self.sigma)
        check_range("refine_steep relative_drop", self.relative_drop, 0.0, 2.0, low_open=True)

    def run(self, field, executor, seed: int) -> None:
        from .refine import refine_load

        refine_load(field, int(self.budget), float(self.sigma), (float(self.low), float(self.high)),
                    executor=executor, seed=seed, min_drop=float(self.relative_drop) * field.drive.stroke_speed,
                    record="refined_steep")
        if "refined_steep" in field.meta:  # no record where no cell is steep
            field.meta["refined_steep"]["relative_drop"] = float(self.relative_drop)
        field.settle()


@dataclass(frozen=True)
class PolishStall:
    """On every k line (up to ``k_max``, if given), the two nodes on either side of its stall (the heaviest that
    moves and the next heavier) play their own, their lighter and k neighbours' drives and the
    push/clamp cycle, then CMA-ES over two-action cycles runs from the three fastest and each keeps a
    faster drive (``refine.polish_stall``): the teacher's critical load is the stall node's."""

    budget: int
    sigma: float
    k_max: float | None = None
    SEED_OFFSET = 970_000

    def __post_init__(self) -> None:
        check_search("polish_stall", self.budget, self.sigma)

    def run(self, field, executor, seed: int) -> None:
        from .refine import polish_stall

        polish_stall(field, int(self.budget), float(self.sigma), executor=executor, seed=seed, k_max=_float(self.k_max))
        field.settle()


@dataclass(frozen=True)
class Band:
    """A band of the grid: k in [``k_low``, ``k_high``], load fractions in [``low``, ``high``], searched
    with ``budget`` evaluations per start and step ``sigma``."""

    budget: int
    sigma: float
    k_low: float
    k_high: float
    low: float
    high: float

    @property
    def k_band(self) -> tuple[float, float]:
        return float(self.k_low), float(self.k_high)

    @property
    def fraction_band(self) -> tuple[float, float]:
        return float(self.low), float(self.high)


@dataclass(frozen=True)
class PolishBand(Band):
    """Every node of the band searched as ``PolishStall``'s, from its two fastest trials
    (``refine.polish_band``); each new drive is written in its node's old cycle phase, so no line of
    the grid turns its phase."""

    SEED_OFFSET = 980_000

    def __post_init__(self) -> None:
        check_search("polish_band", self.budget, self.sigma)

    def run(self, field, executor, seed: int) -> None:
        from .refine import polish_band

        before = field.drives.copy()
        polish_band(field, int(self.budget), float(self.sigma), self.k_band, self.fraction_band, executor=executor, seed=seed)
        field.settle(keep_phases_of=before)


@dataclass(frozen=True)
class RefineBand(Band):
    """A load line between every two whose midpoint fraction lies in the band's, searched only at the
    k lines of the band from the best of the six nodes around each new node and every searched k line's
    nodes on its two load lines (elsewhere a copy of its faster neighbour's drive;
    ``refine.refine_band``); the old nodes keep their phase, new ones their lighter neighbour's."""

    SEED_OFFSET = 990_000

    def __post_init__(self) -> None:
        check_search("refine_band", self.budget, self.sigma)

    def run(self, field, executor, seed: int) -> None:
        from .refine import refine_band

        refine_band(field, int(self.budget), float(self.sigma), self.k_band, self.fraction_band, executor=executor, seed=seed)
        field.settle(keep_phases_of=field.drives.copy())


@dataclass(frozen=True)
class Audit:
    """The teacher checked against a stronger search, and mended where it falls short
    (``refine.audit``): at ``points`` random points of its domain (k over the grid's range, loads
    ``low``-``high`` times the trapezoid's critical load), CMA-ES over two-action cycles (``budget``
    evaluations from each of the ``starts`` fastest of the teacher's drives around the point, the
    trapezoid and the push/clamp cycle; step ``sigma``) searches again. Where it beats the teacher's
    drive (as the student is taught it) by more than ``gain`` (relative) and ``floor`` times the
    drive's stroke speed, the four nodes of the point's cell play the drive found and are searched
    again from it (``polish_budget`` evaluations per start). So the teacher searches more where a
    search still finds more, wherever that is on the drive, instead of in bands of k and load set
    by hand. With ``keep_found``, a drive found at a point the mended nodes still fall short at is
    kept as a point drive there (``DriveField.add_point_drives``)."""

    points: int
    budget: int
    sigma: float
    low: float
    high: float
    polish_budget: int
    gain: float = 0.03
    floor: float = 0.01
    starts: int = 2
    keep_found: bool = False
    SEED_OFFSET = 995_000

    def __post_init__(self) -> None:
        check_int("audit points", self.points, 1)
        check_search("audit", self.budget, self.sigma)
        check_int("audit polish_budget", self.polish_budget, 1)
        check_int("audit starts", self.starts, 1)
        check_range("audit gain", self.gain, 0.0, 1.0)
        check_range("audit floor", self.floor, 0.0, 1.0)
        check_bool("audit keep_found", self.keep_found)

    def run(self, field, executor, seed: int) -> None:
        from .refine import audit

        before = field.drives.copy()
        audit(field, int(self.points), int(self.budget), float(self.sigma), (float(self.low), float(self.high)),
              int(self.polish_budget), gain=float(self.gain), floor=float(self.floor), starts=int(self.starts),
              executor=executor, seed=seed, keep_found=self.keep_found)
        field.settle(keep_phases_of=before)


@dataclass(frozen=True)
class ExchangeAll:
    """Every node plays every distinct drive of the field (its grid drives and point drives, in both
    phases) and keeps the fastest if it beats its own (``refine.exchange_all``): each drive is screened over
    ``screen_periods`` periods (steady velocity over the last ``screen_average``), and the node's
    ``finalists`` fastest are played again over the full evaluation. The searches start from drives
    near each node, and a drive found at one k and load is often the best at others far from it; the
    strong reference transfers drives between points the same way. No search: the cost is the
    field's drives times its nodes times ``screen_periods``."""

    screen_periods: int = 12
    screen_average: int = 4
    finalists: int = 8
    SEED_OFFSET = 999_000

    def __post_init__(self) -> None:
        check_int("exchange_all screen_periods", self.screen_periods, 2)
        check_int("exchange_all screen_average", self.screen_average, 1)
        check_range("exchange_all screen_average", self.screen_average, 1, self.screen_periods - 1)
        check_int("exchange_all finalists", self.finalists, 1)

    def run(self, field, executor, seed: int) -> None:
        from .refine import exchange_all

        before = field.drives.copy()
        exchange_all(field, int(self.screen_periods), int(self.screen_average), int(self.finalists), executor)
        field.settle(keep_phases_of=before)


#: The refinement stages in the order the search runs them (after the polish passes).
STAGES = ("refine_k", "refine_load", "refine_steep", "polish_stall", "polish_band", "refine_band", "audit",
          "exchange_all")


@dataclass(frozen=True)
class FieldConfig:
    """The teacher's grid, its search budgets and its stages (each optional).

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
        polish: polish passes after the search, exchange and consolidation (``PolishPass``).
        refine_k, refine_load, refine_steep, polish_stall, polish_band, refine_band, audit,
            exchange_all: the refinement stages, run in this order after the polish passes, each
            followed by an exchange between neighbours (``RefineK``, ``RefineLoad``, ``RefineSteep``,
            ``PolishStall``, ``PolishBand``, ``RefineBand``, ``Audit``, ``ExchangeAll``; None: not
            run). The bands of
            ``polish_band`` and ``refine_band`` are in k, so they fit one drive; the shipped recipe
            uses ``audit`` instead.
        friction: (mu, mu1), the indenter-slider and slider-base friction coefficients the drives are
            searched at (-); the grid's loads stay fractions of the trapezoid's critical load at the
            paper's friction (0.3, 0.1).
        search_steps_per_period: the teacher plays its drives with the node solver's longest time step
            the drive's period over this (-; never shorter than the env's own step, and the solver still
            shortens its steps on fast edges), then plays every node's drive once more with the env's
            solver to keep its velocity; None: every play with the env's solver. The step is relative
            to the period, so a slow drive costs no more per period than a fast one
            (``DriveDescription.with_search_solver``, docs/results.md).
    """

    k_values: int = 13
    k_range: tuple[float, float] = (0.0, 0.6)
    load_fractions: int = 12
    max_load_fraction: float = 1.3
    fixed_budget: int = 300
    cycle_budget: int = 700
    sigma0: float = 0.25
    consolidate_tolerance: float = 0.0
    polish: tuple[PolishPass, ...] = ()
    refine_k: RefineK | None = None
    refine_load: RefineLoad | None = None
    refine_steep: RefineSteep | None = None
    polish_stall: PolishStall | None = None
    polish_band: PolishBand | None = None
    refine_band: RefineBand | None = None
    audit: Audit | None = None
    exchange_all: ExchangeAll | None = None
    friction: tuple[float, float] = PAPER_FRICTION
    search_steps_per_period: int | None = None

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
            if not isinstance(entry, PolishPass):
                raise ValueError(f"polish={self.polish!r}: each pass is a PolishPass (budget, sigma)")
        kinds = {"refine_k": RefineK, "refine_load": RefineLoad, "refine_steep": RefineSteep,
                 "polish_stall": PolishStall, "polish_band": PolishBand, "refine_band": RefineBand, "audit": Audit,
                 "exchange_all": ExchangeAll}
        for name, kind in kinds.items():
            stage = getattr(self, name)
            if stage is not None and not isinstance(stage, kind):
                raise ValueError(f"{name}={stage!r} is not a {kind.__name__} (or None)")
        k_bounded = [(name, getattr(self, name).k_max) for name in ("refine_k", "refine_load", "polish_stall")
                     if getattr(self, name) is not None and getattr(self, name).k_max is not None]
        for name, k_max in k_bounded:
            check_range(f"{name} k_max", k_max, *self.k_range, low_open=name == "refine_k")
        for name in ("refine_load", "refine_steep", "audit"):
            stage = getattr(self, name)
            if stage is not None:
                check_range(f"{name} low", stage.low, 0.0, self.max_load_fraction)
                check_range(f"{name} high", stage.high, stage.low, self.max_load_fraction)
        for name in ("polish_band", "refine_band"):
            band = getattr(self, name)
            if band is not None:
                check_range(f"{name} k_low", band.k_low, *self.k_range)
                check_range(f"{name} k_high", band.k_high, band.k_low, self.k_range[1])
                check_range(f"{name} low", band.low, 0.0, self.max_load_fraction)
                check_range(f"{name} high", band.high, band.low, self.max_load_fraction)
        if len(self.friction) != 2:
            raise ValueError(f"friction={self.friction!r} must be (mu, mu1)")
        check_range("friction mu", self.friction[0], 0.0, 2.0, low_open=True)
        check_range("friction mu1", self.friction[1], 0.0, 2.0)
        if self.search_steps_per_period is not None:
            check_int("search_steps_per_period", self.search_steps_per_period, MIN_SEARCH_STEPS)

    def named_stages(self) -> list[tuple[str, object]]:
        """(name, stage) of the refinement stages that are set, in the order the search runs them (``STAGES``)."""
        return [(name, getattr(self, name)) for name in STAGES if getattr(self, name) is not None]

    def stages(self) -> list:
        """The refinement stages that are set, in the order the search runs them (``STAGES``)."""
        return [stage for _, stage in self.named_stages()]

    @property
    def ks(self) -> np.ndarray:
        return np.linspace(*self.k_range, self.k_values)

    @property
    def fractions(self) -> np.ndarray:
        return np.linspace(0.0, self.max_load_fraction, self.load_fractions)


__all__ = ["PAPER_FRICTION", "STAGES", "Audit", "Band", "FieldConfig", "PolishBand", "PolishPass", "PolishStall",
           "ExchangeAll", "RefineBand", "RefineK", "RefineLoad", "RefineSteep", "check_search"]
