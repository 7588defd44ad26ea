"""The drive simulator: MDR spring grid + slider state, advanced one drive period per kernel call."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import kernel as K
from .fast_kernel import advance_nodes, node_positions, node_weights, normal_force, scratch_size
from .materials import contact_radius
from .params import DriveParams, Numerics, numerics_preset
from .waveform import MAX_Z_KNOTS, Waveform, knots_from_params, period_knots

#: Steps per edge below which a waveform is too fast for the time step.
MIN_STEPS_PER_EDGE = 10


@dataclass(frozen=True)
class PeriodResult:
    """What happened during one drive period (SI units).

    Attributes:
        displacement: slider displacement over the period (m), + is against the load.
        mean_velocity: displacement / T (m/s).
        peak_tangential_force: max |F_x| over the period (N).
        peak_normal_force: max F_z over the period (N).
        indenter_dissipation: energy dissipated by slip in the indenter contact (J), including
            the energy released by springs leaving the contact.
        base_dissipation: work of the base friction ``sgn(V) mu1 F_z`` on the slider (J).
        load_work: work done against the load, ``F_m * displacement`` (J).
        indenter_work_x: work of the indenter's horizontal motion on the contact (J).
        indenter_work_z: work of the indenter's vertical motion on the contact (J).
        end_velocity: slider velocity at the end of the period (m/s).
        end_position: slider position at the end of the period (m).
        trace: (rows, 7) array with columns ``kernel.TRACE_COLUMNS`` (s, m, m, m, m/s, N, N), or None.
    """

    displacement: float
    mean_velocity: float
    peak_tangential_force: float
    peak_normal_force: float
    indenter_dissipation: float
    base_dissipation: float
    load_work: float
    indenter_work_x: float
    indenter_work_z: float
    end_velocity: float
    end_position: float
    trace: np.ndarray | None = field(default=None, repr=False)


def step_resolving_edge(time_step: float, edge: float) -> float:
    """The longest time step (s) of at most ``time_step`` that resolves an edge of ``edge`` (s) with
    ``MIN_STEPS_PER_EDGE`` steps: ``time_step`` itself where it does, else ``time_step / n`` for the
    smallest whole ``n`` that does. Dividing by a whole number keeps every time that was a multiple
    of ``time_step`` (a waveform's time quantum) a multiple of the shorter step. Non-positive or
    non-finite values are returned as is, for the caller's validation to refuse."""
    if not (time_step > 0 and edge > 0 and math.isfinite(edge)) or edge >= MIN_STEPS_PER_EDGE * time_step * (1 - 1e-9):
        return time_step
    return time_step / math.ceil(MIN_STEPS_PER_EDGE * time_step / edge - 1e-9)


def check_numerics(numerics: Numerics, waveform: Waveform) -> int:
    """Validate dt against the waveform and return the number of steps per period.

    dt must resolve the fastest edge with at least ``MIN_STEPS_PER_EDGE`` steps, and, for the
    grid solver, divide the period (so period boundaries fall on steps; the node solver cuts its
    steps at every corner itself).
    """
    dt = numerics.time_step
    n = waveform.period / dt
    n_steps = int(round(n))
    if numerics.method == "grid" and abs(n - n_steps) > 1e-6 * n_steps:
        raise ValueError(f"Numerics.time_step={dt!r} does not divide the period {waveform.period!r} s")
    if waveform.fastest_edge < MIN_STEPS_PER_EDGE * dt:
        raise ValueError(
            f"Numerics.time_step={dt!r} is not small against the waveform: the fastest edge "
            f"({waveform.fastest_edge!r} s) needs at least {MIN_STEPS_PER_EDGE} steps"
        )
    return n_steps


class DriveSimulator:
    """MDR model of the stick-slip drive, stepped one drive period at a time.

    Args:
        params: the physical model (bodies, contact, drive).
        numerics: a :class:`Numerics` or a preset name: ``"fast"`` (the default: the node solver,
            the most accurate and fastest preset), ``"default"`` or ``"paper"`` (the paper's grid
            scheme at two resolutions).
        max_depth: largest indentation (m) any waveform will use; sizes the spring grid.

    The state (spring displacements, slider position and velocity, indenter position) persists
    across :meth:`step` calls; each call may use another waveform.
    """

    def __init__(self, params: DriveParams, numerics: Numerics | str = "fast", max_depth: float = 6e-6):
        if not (math.isfinite(max_depth) and max_depth > 0.0):
            raise ValueError(f"max_depth={max_depth!r} is outside the allowed range (0, inf)")
        self.params = params
        self.numerics = numerics_preset(numerics)
        self.max_depth = float(max_depth)
        self._build_grid()
        self.state = np.zeros(K.STATE_SIZE)
        self._out = np.zeros(K.OUT_SIZE)
        self._empty_trace = np.zeros((0, len(K.TRACE_COLUMNS)))
        self._scratch = np.empty(scratch_size(3 + MAX_Z_KNOTS, self.numerics.nodes))  # the node solver's scratch
        self.reset()

    def _build_grid(self) -> None:
        p = self.params
        k, radius, num = p.k, p.contact.indenter_radius, self.numerics
        self.slip_ratio = p.slip_ratio
        if num.method == "nodes":
            self.g = node_positions(self.max_depth, num.nodes, num.node_power)
            w, left, p1, p3 = node_weights(self.g, k, radius, p.c0)
            self.spring_x = np.sqrt((1.0 + k) * radius * self.g)
            self.kx = p.tangential_stiffness_prefactor * w  # stiffness of a node inside the contact
            self.kz = p.normal_stiffness_prefactor * w
            # the kernel's model arguments, fixed for the simulator's life
            self._model = (self.g, w, left, p1, p3, p.tangential_stiffness_prefactor, p.normal_stiffness_prefactor,
                           k, (1.0 + k) * radius, p.c0**k, self.slip_ratio)
            return
        dx = num.spring_spacing
        a_max = contact_radius(self.max_depth, k, radius)
        n = int(math.ceil(a_max / dx)) + 2
        x = np.arange(n, dtype=np.float64) * dx
        weight = np.full(n, 2.0)
        weight[0] = 1.0
        shape = (x / p.c0) ** k * dx * weight
        self.spring_x = x
        self.g = x * x / ((1.0 + k) * radius)
        self.kx = p.tangential_stiffness_prefactor * shape
        self.kz = p.normal_stiffness_prefactor * shape
        self._model = (self.g, self.kx, self.kz, self.slip_ratio)

    def reset(self, position: float = 0.0, velocity: float = 0.0) -> None:
        """Slider at ``position`` (m) with ``velocity`` (m/s), no contact, indenter at 0."""
        self.u_x = np.zeros_like(self.g)
        self.state[:] = 0.0
        self.state[K.S_X] = position
        self.state[K.S_V] = velocity

    # --- state accessors (SI units) ---
    @property
    def position(self) -> float:
        """Slider position X (m)."""
        return float(self.state[K.S_X])

    @property
    def velocity(self) -> float:
        """Slider velocity V (m/s)."""
        return float(self.state[K.S_V])

    @property
    def time(self) -> float:
        """Simulated time since reset (s)."""
        return float(self.state[K.S_TIME])

    @property
    def indenter_depth(self) -> float:
        """Current indentation d = z (m)."""
        return float(self.state[K.S_ZIND])

    @property
    def forces(self) -> tuple[float, float]:
        """Current (F_x, F_z) (N)."""
        return float(self.state[K.S_FX]), float(self.state[K.S_FZ])

    def elastic_normal_force(self, depth: float) -> float:
        """F_z (N) of the solver's springs at indentation ``depth`` (m) (exact Eq. 8 for the node solver)."""
        p = self.params
        if self.numerics.method == "nodes":
            return normal_force(depth, p.normal_stiffness_prefactor, p.k, (1.0 + p.k) * p.contact.indenter_radius,
                                p.c0**p.k)
        return float(np.dot(self.kz, np.maximum(depth - self.g, 0.0)))

    def elastic_energy(self) -> tuple[float, float]:
        """Elastic energy (J) stored in the (tangential, normal) springs."""
        d = self.indenter_depth
        uz = np.maximum(d - self.g, 0.0)
        return 0.5 * float(np.dot(self.kx, self.u_x**2)), 0.5 * float(np.dot(self.kz, uz**2))

    def kinetic_energy(self) -> float:
        """Kinetic energy (J) of the moving mass."""
        return 0.5 * self.params.drive.moving_mass * self.velocity**2

    def step(self, waveform: Waveform, record_every: int = 0) -> PeriodResult:
        """Advance one drive period with ``waveform``.

        Args:
            waveform: the indenter's x/z waveform for this period. If its z starts at another
                depth than the previous period ended, the step is blended out
                (:func:`waveform.period_knots`).
            record_every: record a trace row every this many time steps (0: no trace).
        """
        check_numerics(self.numerics, waveform)
        z_start = self.indenter_depth if self.time > 0.0 else None
        return self.step_knots(*period_knots(waveform, z_start=z_start), record_every=record_every)

    def step_knots(
        self, tx: np.ndarray, vx: np.ndarray, tz: np.ndarray, vz: np.ndarray, record_every: int = 0
    ) -> PeriodResult:
        """Advance one period given x(t), z(t) as piecewise-linear knots (s, m), local time from 0.

        Both knot sets start at t = 0 and end at the same period T, which dt must divide. The
        first call after :meth:`reset` places the indenter at ``(vx[0], vz[0])``.
        """
        tx, vx, tz, vz = (np.ascontiguousarray(a, dtype=np.float64) for a in (tx, vx, tz, vz))
        for name, t, v in (("x", tx, vx), ("z", tz, vz)):
            if t.ndim != 1 or t.shape != v.shape or t.size < 2:
                raise ValueError(f"{name} knots must be two 1D arrays of equal length >= 2")
            if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
                raise ValueError(f"{name} knots must be finite")
            if t[0] != 0.0 or np.any(np.diff(t) <= 0.0):
                raise ValueError(f"{name} knot times must start at 0 and increase strictly")
        period = float(tx[-1])
        if tz[-1] != period:
            raise ValueError(f"x and z knots must end at the same period (got {period!r} s and {tz[-1]!r} s)")
        dt = self.numerics.time_step
        n_steps = int(round(period / dt))
        if self.numerics.method == "grid" and (n_steps < 1 or abs(period / dt - n_steps) > 1e-6 * n_steps):
            raise ValueError(f"Numerics.time_step={dt!r} does not divide the period {period!r} s")
        if vz.max() > self.max_depth * (1.0 + 1e-12):
            raise ValueError(f"z reaches {vz.max()!r} m, beyond the simulator's max_depth {self.max_depth!r} m")
        if record_every < 0:
            raise ValueError(f"record_every={record_every!r} is outside the allowed range [0, inf)")
        return self._advance(tx, vx, tz, vz, int(record_every))

    def step_params(self, x_amplitude: float, x_rise_time: float, z_amplitude: float, z_rise_time: float,
                    z_phase: float, period: float, record_every: int = 0) -> PeriodResult:
        """Fast path of :meth:`step` from plain floats (m, s; ``z_phase`` in [0, 1)), unvalidated.

        For callers that guarantee valid values (the env's action map): no dataclasses are built.
        """
        z_start = self.state[K.S_ZIND] if self.state[K.S_TIME] > 0.0 else -1.0
        return self._advance(*knots_from_params(x_amplitude, x_rise_time, z_amplitude, z_rise_time, z_phase,
                                                period, z_start, -1.0), record_every)

    def _advance(self, tx, vx, tz, vz, record_every: int) -> PeriodResult:
        if self.state[K.S_TIME] == 0.0:  # first period: indenter at its start, pressed to depth vz[0], springs unloaded
            self.state[K.S_XIND] = vx[0]
            self.state[K.S_ZIND] = vz[0]
            self.state[K.S_FZ] = self.elastic_normal_force(vz[0])
        if record_every:
            period, dt = tx[-1], self.numerics.time_step
            n_steps = int(round(period / dt))
            if self.numerics.method == "nodes":  # steps adapt per segment: bound their number
                n_steps = (int(np.ceil(period / dt)) + tx.size + tz.size
                           + int(np.ceil(np.abs(np.diff(vx)).sum() / self.numerics.max_x_step))
                           + int(np.ceil(np.abs(np.diff(vz)).sum() / self.numerics.max_z_step)))
            trace = np.empty((n_steps // record_every, len(K.TRACE_COLUMNS)))
        else:
            trace = self._empty_trace
        self.run_kernel(tx, vx, tz, vz, record_every, trace, self._out)
        o = self._out.tolist()  # one conversion, then plain floats
        return PeriodResult(
            displacement=o[K.O_DISPLACEMENT],
            mean_velocity=o[K.O_MEAN_VELOCITY],
            peak_tangential_force=o[K.O_PEAK_FX],
            peak_normal_force=o[K.O_PEAK_FZ],
            indenter_dissipation=o[K.O_DISS_INDENTER],
            base_dissipation=o[K.O_DISS_BASE],
            load_work=o[K.O_WORK_LOAD],
            indenter_work_x=o[K.O_WORK_INDENTER_X],
            indenter_work_z=o[K.O_WORK_INDENTER_Z],
            end_velocity=float(self.state[K.S_V]),
            end_position=float(self.state[K.S_X]),
            trace=trace[: int(o[K.O_N_RECORDED])] if record_every else None,
        )

    def run_kernel(self, tx, vx, tz, vz, record_every: int, trace: np.ndarray, out: np.ndarray) -> None:
        """One compiled kernel call for one period: no validation, no result object.

        ``tx, vx, tz, vz`` are float64 knots (:meth:`step_knots`), ``trace`` a (rows, 7) buffer
        (``record_every = 0``: none), ``out`` the (``kernel.OUT_SIZE``,) per-period results.
        """
        p, num = self.params, self.numerics
        tail = (p.drive.moving_mass, p.drive.load, p.contact.base_friction_coefficient, int(record_every), trace, out)
        if num.method == "nodes":
            size = scratch_size(tx.size + tz.size, num.nodes)
            scratch = self._scratch if size <= self._scratch.size else np.empty(size)
            advance_nodes(self.u_x, self.state, *self._model, tx, vx, tz, vz, num.time_step, num.max_x_step,
                          num.max_z_step, *tail, scratch)
        else:
            K.advance_period(self.u_x, self.state, *self._model, tx, vx, tz, vz, int(round(tx[-1] / num.time_step)),
                             num.time_step, *tail)

    def run(self, waveform: Waveform, n_periods: int, record_every: int = 0) -> list[PeriodResult]:
        """Run ``n_periods`` (>= 1) periods with the same waveform; see :meth:`step`."""
        if isinstance(n_periods, bool) or not isinstance(n_periods, (int, np.integer)) or n_periods < 1:
            raise ValueError(f"n_periods={n_periods!r} is outside the allowed range [1, inf)")
        return [self.step(waveform, record_every) for _ in range(int(n_periods))]


def concat_traces(results: list[PeriodResult]) -> np.ndarray:
    """One (rows, 7) trace from the per-period traces of a run."""
    return np.concatenate([r.trace for r in results if r.trace is not None], axis=0)
