"""N independent drives stepped by one compiled call per period (the fast solver, ``method="nodes"``).

Each drive has its own model (k, load, ...) and waveform; all share the numerics and the node
positions in g. The drives are spread over ``num_threads`` threads (numba ``prange``; at least
``MIN_DRIVES_PER_THREAD`` drives a thread, fewer drives run serially); each drive is computed by one
thread exactly as alone, so results equal N separate :class:`DriveSimulator` runs with the same
numerics bit for bit, whatever the thread count. Used by the vector environment.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from numba import njit, prange

from . import kernel as K

# Numba's threading layer: "workqueue" unless the user chose one (NUMBA_THREADING_LAYER). The GNU
# OpenMP layer it would otherwise pick kills any process that fork()s after a parallel call
# ("fork() called from a process already using GNU OpenMP"), and the sweeps fork worker processes.
# workqueue is fork-safe; it is not thread-safe (call the batched solver from one thread at a time).
if numba.config.THREADING_LAYER == "default":
    numba.config.THREADING_LAYER = "workqueue"
from .fast_kernel import advance_nodes, node_positions, node_weights, normal_force, scratch_size
from .params import DriveParams, Numerics, numerics_preset
from .waveform import MAX_Z_KNOTS, knots_into

#: Drives per thread below which the serial kernel is faster (thread start-up costs more than it saves).
MIN_DRIVES_PER_THREAD = 16

# columns of the per-drive parameter table
P_CT, P_CN, P_K, P_S, P_C0K, P_SLIP, P_MASS, P_LOAD, P_MU1 = range(9)
N_PARAMS = 9


@njit(cache=True, inline="always")
def advance_drive(e, u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out, knots,
                  scratch, trace):
    """Advance drive e by one period with its waveform row ``waveforms[e] = (x_amplitude,
    x_rise_time, z_amplitude, z_rise_time, z_phase)`` (m, s, -), allocating nothing (allocations
    serialise numba's threads): ``knots[e]`` holds the drive's knots, ``scratch[e]`` the kernel's
    scratch (:func:`fast_kernel.scratch_size`), ``trace`` an empty (0, 7) array."""
    z_start = state[e, K.S_ZIND] if state[e, K.S_TIME] > 0.0 else -1.0
    wf = waveforms[e]
    buf = knots[e]
    tx, vx = buf[0, :3], buf[1, :3]
    nz = knots_into(wf[0], wf[1], wf[2], wf[3], wf[4], period, z_start, -1.0, tx, vx, buf[2], buf[3])
    tz, vz = buf[2, :nz], buf[3, :nz]
    m = model[e]
    if state[e, K.S_TIME] == 0.0:  # first period: indenter at its start, pressed to depth vz[0]
        state[e, K.S_XIND] = vx[0]
        state[e, K.S_ZIND] = vz[0]
        state[e, K.S_FZ] = normal_force(vz[0], m[P_CN], m[P_K], m[P_S], m[P_C0K])
    advance_nodes(u[e], state[e], g, w[e], left[e], p1[e], p3[e], m[P_CT], m[P_CN], m[P_K], m[P_S],
                  m[P_C0K], m[P_SLIP], tx, vx, tz, vz, dt_max, x_step, z_step, m[P_MASS], m[P_LOAD],
                  m[P_MU1], 0, trace, out[e], scratch[e])


@njit(cache=True, parallel=True)
def advance_batch_parallel(u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out,
                           knots, scratch, trace):
    """Every drive by one period (:func:`advance_drive`), the drives spread over numba's threads."""
    for e in prange(u.shape[0]):
        advance_drive(e, u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out, knots,
                      scratch, trace)


@njit(cache=True)
def advance_batch_serial(u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out,
                         knots, scratch, trace):
    """Every drive by one period (:func:`advance_drive`), one after the other on this thread."""
    for e in range(u.shape[0]):
        advance_drive(e, u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out, knots,
                      scratch, trace)


def default_threads() -> int:
    """The cores available to this process, at most numba's thread pool."""
    return max(1, min(len(os.sched_getaffinity(0)), numba.config.NUMBA_NUM_THREADS))


class BatchedDriveSimulator:
    """``n`` drives with the fast solver, stepped together.

    Args:
        n: number of drives.
        numerics: a ``method="nodes"`` :class:`Numerics` or preset name (default ``"fast"``).
        max_depth: largest indentation (m) any waveform will use.
        num_threads: threads that step the drives (default: the cores available to this process,
            at most numba's thread pool); results do not depend on it.
    """

    def __init__(self, n: int, numerics: Numerics | str = "fast", max_depth: float = 6e-6,
                 num_threads: int | None = None):
        self.numerics = numerics_preset(numerics)
        if self.numerics.method != "nodes":
            raise ValueError(f"numerics={numerics!r}: the batched solver needs method='nodes'")
        if n < 1:
            raise ValueError(f"n={n!r} is outside the allowed range [1, inf)")
        self.n = n
        self.num_threads = default_threads() if num_threads is None else num_threads
        if isinstance(self.num_threads, bool) or not isinstance(self.num_threads, (int, np.integer)) or not (
                1 <= self.num_threads <= numba.config.NUMBA_NUM_THREADS):
            raise ValueError(f"num_threads={num_threads!r} is outside the allowed range "
                             f"[1, {numba.config.NUMBA_NUM_THREADS}]")
        self.num_threads = int(self.num_threads)
        self.max_depth = float(max_depth)
        nodes = self.numerics.nodes
        self.g = node_positions(self.max_depth, nodes, self.numerics.node_power)
        self.u = np.zeros((n, nodes))
        self.state = np.zeros((n, K.STATE_SIZE))
        self.w = np.zeros((n, nodes))
        self.left = np.zeros((n, nodes))
        self.p1 = np.zeros((n, nodes))
        self.p3 = np.zeros((n, nodes))
        self.model = np.zeros((n, N_PARAMS))
        self.out = np.zeros((n, K.OUT_SIZE))
        # per drive: rows tx, vx, tz, vz, and the kernel's scratch (the period's corners and more)
        self._knots = np.zeros((n, 4, 3 + MAX_Z_KNOTS))
        self._scratch = np.zeros((n, scratch_size(3 + MAX_Z_KNOTS, nodes)))
        self._empty_trace = np.zeros((0, 7))
        self.params: list[DriveParams | None] = [None] * n

    def set_params(self, i: int, params: DriveParams) -> None:
        """Give drive ``i`` the model ``params`` and reset it."""
        k, radius = params.k, params.contact.indenter_radius
        self.w[i], self.left[i], self.p1[i], self.p3[i] = node_weights(self.g, k, radius, params.c0)
        self.model[i] = (params.tangential_stiffness_prefactor, params.normal_stiffness_prefactor, k,
                         (1.0 + k) * radius, params.c0**k, params.slip_ratio, params.drive.moving_mass,
                         params.drive.load, params.contact.base_friction_coefficient)
        self.params[i] = params
        self.reset(i)

    def reset(self, i: int) -> None:
        """Drive ``i`` at rest at X = 0, no contact, springs unloaded."""
        self.u[i] = 0.0
        self.state[i] = 0.0

    def step(self, waveforms: np.ndarray, period: float) -> np.ndarray:
        """One period for every drive; ``waveforms`` is (n, 5): x amplitude (m), x rise time (s),
        z amplitude (m), z rise time (s), z phase (-). Returns the (n, OUT_SIZE) per-period results
        (columns ``kernel.O_*``)."""
        if any(p is None for p in self.params):
            raise RuntimeError("set_params() every drive before step()")
        num = self.numerics
        threads = min(self.num_threads, self.n // MIN_DRIVES_PER_THREAD)
        if threads > 1:
            numba.set_num_threads(threads)
            kernel = advance_batch_parallel
        else:
            kernel = advance_batch_serial
        kernel(self.u, self.state, self.g, self.w, self.left, self.p1, self.p3, self.model,
               np.ascontiguousarray(waveforms, dtype=np.float64), float(period), num.time_step,
               num.max_x_step, num.max_z_step, self.out, self._knots, self._scratch, self._empty_trace)
        return self.out
