"""N independent drives stepped by one compiled call per period (the fast solver, ``method="nodes"``).

Each drive has its own model (k, load, ...) and waveform; all share the numerics and the node
positions in g. The drives are split into ``num_threads`` contiguous chunks (at least
``MIN_DRIVES_PER_THREAD`` drives a chunk; fewer drives run serially): the calling thread steps the
first chunk while helper threads step the others, each with the same compiled serial loop, which
releases the GIL. Each drive is computed by one thread exactly as alone, so results equal N
separate :class:`DriveSimulator` runs with the same numerics bit for bit, whatever the thread count.
Used by the vector environment.

Why not numba's ``prange``: with its fork-safe ``workqueue`` layer every parallel call waited for
sleeping workers (about 75 us a call on 2 cores, measured with an empty loop) while the calling
thread idled, so at 64 drives two threads stepped the vector env no faster than one; the OpenMP
layer is faster but kills forked children, and the sweeps fork.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
from numba import njit

from . import kernel as K
from .fast_kernel import advance_nodes, node_positions, node_weights, normal_force, scratch_size
from .params import DriveParams, Numerics, numerics_preset
from .waveform import MAX_Z_KNOTS, knots_into

#: Drives per thread below which one thread is faster (handing work to a thread costs more than it
#: saves; measured in the vector env on 2 cores: with 8 drives one thread was faster, with 16 two).
MIN_DRIVES_PER_THREAD = 8

#: Most threads one batched simulator may use.
MAX_THREADS = 256

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


@njit(cache=True, nogil=True)
def advance_batch_serial(u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out,
                         knots, scratch, trace):
    """Every drive by one period (:func:`advance_drive`), one after the other on this thread, without
    the GIL (so helper threads can step other drives at the same time)."""
    for e in range(u.shape[0]):
        advance_drive(e, u, state, g, w, left, p1, p3, model, waveforms, period, dt_max, x_step, z_step, out, knots,
                      scratch, trace)


def check_threads(name: str, threads) -> int:
    """``threads`` as an int, or a ``ValueError`` naming ``name`` unless it is an integer (not a bool)
    in [1, ``MAX_THREADS``]."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or not 1 <= threads <= MAX_THREADS:
        raise ValueError(f"{name}={threads!r} is outside the allowed range [1, {MAX_THREADS}]")
    return int(threads)


#: Threads a batched simulator of this process uses by default when set (``set_process_threads``).
_process_threads: int | None = None


def default_threads() -> int:
    """The threads a batched simulator uses unless told: the cores available to this process, at most
    ``NUMBA_NUM_THREADS`` (which the Ray sweeps set to 1 per task, so that N CPUs run N tasks;
    ``mdr_drive_env.sweep``) and at most its share of the cores if one was set
    (:func:`set_process_threads`)."""
    cores = max(1, min(len(os.sched_getaffinity(0)), numba.config.NUMBA_NUM_THREADS))
    return cores if _process_threads is None else min(cores, _process_threads)


def set_process_threads(threads: int | None) -> None:
    """Give every batched simulator of this process ``threads`` threads by default (None: the cores
    available again). The sweeps' local workers set their share of the cores, so that N workers on N
    cores do not each step their CMA-ES populations on N threads (docs/performance.md). Results do
    not depend on the thread count."""
    global _process_threads
    _process_threads = None if threads is None else check_threads("threads", threads)


_helpers: ThreadPoolExecutor | None = None
_helpers_lock = threading.Lock()


def _helper_pool(workers: int) -> ThreadPoolExecutor:
    """The process's pool of helper threads, grown to at least ``workers`` threads."""
    global _helpers
    with _helpers_lock:
        if _helpers is None or _helpers._max_workers < workers:
            old, _helpers = _helpers, ThreadPoolExecutor(workers, thread_name_prefix="mdr-drive-batch")
            if old is not None:
                old.shutdown(wait=False)
        return _helpers


def _forget_helpers() -> None:
    """In a forked child the parent's helper threads do not exist: start a new pool when needed."""
    global _helpers, _helpers_lock
    _helpers, _helpers_lock = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_helpers)


class BatchedDriveSimulator:
    """``n`` drives with the fast solver, stepped together.

    Args:
        n: number of drives.
        numerics: a ``method="nodes"`` :class:`Numerics` or preset name (default ``"fast"``).
        max_depth: largest indentation (m) any waveform will use.
        num_threads: threads that step the drives, the calling one included (default:
            :func:`default_threads`); results do not depend on it.
    """

    def __init__(self, n: int, numerics: Numerics | str = "fast", max_depth: float = 6e-6,
                 num_threads: int | None = None):
        self.numerics = numerics_preset(numerics)
        if self.numerics.method != "nodes":
            raise ValueError(f"numerics={numerics!r}: the batched solver needs method='nodes'")
        if n < 1:
            raise ValueError(f"n={n!r} is outside the allowed range [1, inf)")
        self.n = n
        self.num_threads = default_threads() if num_threads is None else check_threads("num_threads", num_threads)
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

    def copy_params(self, i: int, source: int) -> None:
        """Give drive ``i`` the model of drive ``source`` (set already) and reset it: what
        ``set_params(i, params)`` with ``source``'s params does, without recomputing its node weights."""
        if self.params[source] is None:
            raise RuntimeError(f"copy_params({i}, {source}): drive {source} has no params yet")
        for array in (self.w, self.left, self.p1, self.p3, self.model):
            array[i] = array[source]
        self.params[i] = self.params[source]
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
        waveforms = np.ascontiguousarray(waveforms, dtype=np.float64)
        period = float(period)
        threads = max(1, min(self.num_threads, self.n // MIN_DRIVES_PER_THREAD))
        bounds = [self.n * i // threads for i in range(threads + 1)]
        pool = _helper_pool(threads - 1) if threads > 1 else None
        pending = [pool.submit(self._advance_drives, bounds[i], bounds[i + 1], waveforms, period)
                   for i in range(1, threads)]
        self._advance_drives(bounds[0], bounds[1], waveforms, period)
        for job in pending:
            job.result()
        return self.out

    def _advance_drives(self, first: int, stop: int, waveforms: np.ndarray, period: float) -> None:
        """Drives ``first .. stop-1`` by one period, on the calling thread (the GIL released)."""
        num, sl = self.numerics, slice(first, stop)
        advance_batch_serial(self.u[sl], self.state[sl], self.g, self.w[sl], self.left[sl], self.p1[sl], self.p3[sl],
                             self.model[sl], waveforms[sl], period, num.time_step, num.max_x_step, num.max_z_step,
                             self.out[sl], self._knots[sl], self._scratch[sl], self._empty_trace)
