"""The fast solver's Numba kernel: MDR springs as finite-element nodes uniform in g.

The reference solver (``kernel.py``) places springs uniformly in x. Here the spring state is
sampled at nodes ``g_0 = 0 < g_1 < ...`` of the MDR profile ``g = x^2 / ((1+k) R)`` and interpolated
linearly in g between them. In g, the normal displacement ``u_z = d - g`` and the slip limits
``+-lambda (d - g)`` are linear, so with hat-function weights integrated in closed form:

* the normal force is exact (paper Eq. 8) at any number of nodes,
* slipping regions are integrated exactly, and the Coulomb bound ``|F_x| <= mu F_z`` holds exactly,
* the contact edge, which falls between nodes, is a partial cell with a closed-form weight.

Time integration: velocity Verlet (second order; one spring update per step). Base friction: the
paper's ``sgn(V) mu1 F_z`` makes V chatter around 0 while the slider sticks to the base; here the
slider stops at the instant within a step where V reaches 0, then sticks while
``|F_x - F_m| <= mu1 F_z`` or accelerates the other way: the same dt -> 0 limit without chatter.

State and per-period result layouts are those of ``kernel.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .inline_pow import pow_positive
from .kernel import S_FX, S_FZ, S_NACT, S_TIME, S_V, S_X, S_XIND, S_ZIND, _interp, record_row, store_period


def node_positions(max_depth: float, nodes: int, power: float) -> np.ndarray:
    """Node positions in g (m): ``g_i = max_depth (i / (nodes - 2))^power``; the last node lies
    beyond ``max_depth``, so a full contact always ends inside the grid."""
    return max_depth * (np.arange(nodes, dtype=np.float64) / (nodes - 2)) ** power


def node_weights(g: np.ndarray, k: float, radius: float, c0: float):
    """Closed-form hat-function weights of nodes ``g`` (per unit stiffness prefactor, both halves).

    Returns ``(w, left)``: ``w[i] = int c(x) phi_i dx`` over both neighbouring cells (the weight of a
    node inside the contact) and ``left[i]``, the part from the cell to its left (the weight of the
    last node in contact, to which the edge cell's weight is added). Also ``x^(k+1)``, ``x^(k+3)``.
    """
    s = (1.0 + k) * radius
    x = np.sqrt(s * g)
    p1 = x ** (k + 1.0)
    p3 = x ** (k + 3.0)
    scale = 2.0 / c0**k  # both halves of the symmetric contact, (|x|/c0)^k
    i1 = np.diff(p1) / (k + 1.0)  # int x^k dx over each cell
    i3 = np.diff(p3) / (s * (k + 3.0))  # int x^k g(x) dx over each cell
    dg = np.diff(g)
    right = scale * (g[1:] * i1 - i3) / dg  # cell i, hat of its left node i
    left_cell = scale * (i3 - g[:-1] * i1) / dg  # cell i, hat of its right node i + 1
    w = np.zeros_like(g)
    left = np.zeros_like(g)
    w[:-1] += right
    w[1:] += left_cell
    left[1:] = left_cell
    return w, left, p1, p3


@njit(cache=True, error_model="numpy")
def normal_force(d, c_n, k, s, c0k):
    """F_z (N) at depth d (m), paper Eq. 8: ``2 C_N / c0^k int_0^a x^k (d - x^2/s) dx``, s = (1+k) R."""
    if d <= 0.0:
        return 0.0
    a = np.sqrt(s * d)
    a1 = a ** (k + 1.0)
    return c_n * 2.0 / c0k * (d * a1 / (k + 1.0) - a1 * a * a / (s * (k + 3.0)))


@njit(cache=True, inline="always", error_model="numpy")
def _half_kick(V, drive, f_lim, h, mass, inv_mass):
    """Advance V over h (s) under ``drive = F_x - F_m`` (N) and Coulomb base friction ``f_lim`` (N).

    The base force opposes V; if V reaches 0 within h, the slider stops there and, for the rest of
    h, sticks while ``|drive| <= f_lim`` or accelerates the other way. Returns (V, base impulse).
    """
    if V != 0.0:
        f_base = f_lim if V > 0.0 else -f_lim
        v_new = V + h * (drive - f_base) * inv_mass
        if v_new * V > 0.0:
            return v_new, f_base * h
        if v_new == 0.0:
            return 0.0, f_base * h
        tau = -V * mass / (drive - f_base)  # time to stop
        h_rest = h - tau
        imp = f_base * tau
    else:
        h_rest = h
        imp = 0.0
    if drive > f_lim:
        return h_rest * (drive - f_lim) * inv_mass, imp + f_lim * h_rest
    if drive < -f_lim:
        return h_rest * (drive + f_lim) * inv_mass, imp - f_lim * h_rest
    return 0.0, imp + drive * h_rest  # sticks: static friction balances the drive


#: Nodes per SIMD block of :func:`_update_nodes` (8 doubles: one AVX-512 register, two AVX2 ones).
NODE_BLOCK = 8


@njit(cache=True, inline="always", error_model="numpy")
def merge_breaks(tx, tz, out):
    """The sorted distinct times of the sorted knot times ``tx`` and ``tz`` (``np.unique`` of both,
    without allocating), written into ``out`` (size >= tx.size + tz.size); returns their number."""
    i = 0
    j = 0
    n = 0
    while i < tx.size or j < tz.size:
        if j == tz.size or (i < tx.size and tx[i] <= tz[j]):
            v = tx[i]
            i += 1
        else:
            v = tz[j]
            j += 1
        if n == 0 or v != out[n - 1]:
            out[n] = v
            n += 1
    return n


@njit(cache=True, inline="always", error_model="numpy")
def _update_nodes(u_x, g, w, n, shift, d_new, slip_ratio, fx_part, slip_sum):
    """Shift nodes ``0 .. n-1`` by ``shift`` and clamp them to ``+-lim``, ``lim = slip_ratio max(d_new - g, 0)``
    (so a node out of contact returns to 0); add each node's ``w lim |overshoot|`` to ``slip_sum[i]``;
    return ``sum w u``.

    Two passes, both vectorised without letting the compiler reorder a sum (so the result is the
    same bit for bit wherever the loop is compiled: the single and the batched solver): an
    elementwise pass that writes each node's ``w u`` into ``fx_part`` (scratch, at least n long),
    then the sum in ``NODE_BLOCK`` = 8 lanes (node ``i`` in lane ``i % 8``), added in a fixed order at
    the end. (16 lanes in two registers, to halve the chain of dependent additions, gave results that
    differed in the last bit between the single and the batched solver: tested, not used.)
    """
    for i in range(n):
        u = u_x[i] + shift
        lim = slip_ratio * max(d_new - g[i], 0.0)
        v = min(max(u, -lim), lim)
        u_x[i] = v
        fx_part[i] = w[i] * v
        slip_sum[i] += w[i] * lim * abs(u - v)
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
    n_blocks = n // 8
    for p in range(n_blocks):
        i = 8 * p
        a0 += fx_part[i + 0]
        a1 += fx_part[i + 1]
        a2 += fx_part[i + 2]
        a3 += fx_part[i + 3]
        a4 += fx_part[i + 4]
        a5 += fx_part[i + 5]
        a6 += fx_part[i + 6]
        a7 += fx_part[i + 7]
    for i in range(8 * n_blocks, n):  # a node count that is not a multiple of 8
        a0 += fx_part[i]
    return ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7))


#: Steps whose depth-only quantities (depth, a^(k+1), F_z) are computed together, vectorised, before
#: they are stepped: off the step-to-step dependency chain, and without a libm call inside the step.
STEP_BLOCK = 64


def scratch_size(n_knots: int, nodes: int) -> int:
    """Floats of scratch :func:`advance_nodes` needs for a period with ``n_knots`` knots in all, on
    ``nodes`` nodes."""
    return n_knots + 3 * STEP_BLOCK + 2 * nodes


@njit(cache=True, inline="always", error_model="numpy")
def _depth_block(za, dz_seg, zb, first, count, n_in_seg, s, half_kp1, fz_scale, inv_kp1, inv_kp3s, d_buf, a1_buf,
                 fz_buf):
    """Depth ``d`` (m), ``a^(k+1)`` and F_z (N, paper Eq. 8) at steps ``first + 1 .. first + count`` of a
    segment from depth ``za`` to ``zb`` in ``n_in_seg`` steps of ``dz_seg``; elementwise, so vectorised."""
    for j in range(count):
        step = first + 1 + j
        d = zb if step == n_in_seg else za + step * dz_seg
        sd = s * max(d, 1e-300)  # a^2 (m^2)
        a1 = pow_positive(sd, half_kp1)
        d_buf[j] = d
        a1_buf[j] = a1
        fz_buf[j] = fz_scale * (d * a1 * inv_kp1 - a1 * sd * inv_kp3s) if d > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def advance_nodes(
    u_x,
    state,
    g,
    w,
    left,
    p1,
    p3,
    c_t,
    c_n,
    k,
    s,
    c0k,
    slip_ratio,
    tx,
    vx,
    tz,
    vz,
    dt_max,
    x_step,
    z_step,
    moving_mass,
    load,
    mu1,
    record_every,
    trace,
    out,
    scratch,
):
    """Advance ``u_x`` (node values, m) and ``state`` by one period, allocating nothing
    (``scratch``: at least :func:`scratch_size` ``(tx.size + tz.size, g.size)`` floats).

    The period is cut at every corner of x(t) and z(t); each segment is split into equal steps no
    longer than ``dt_max`` (s) in which the indenter moves at most ``x_step`` (m) in x and
    ``z_step`` (m) in z. ``w``, ``left``, ``p1``, ``p3`` from :func:`node_weights`; ``c_t``, ``c_n``:
    C_T, C_N (Pa); ``s = (1+k) R``; ``c0k = c0^k``. Other arguments as in ``kernel.advance_period``.
    """
    n_nodes = g.size
    kp1 = k + 1.0
    kp3s = s * (k + 3.0)
    inv_kp1 = 1.0 / kp1
    half_kp1 = 0.5 * kp1
    inv_kp3s = 1.0 / kp3s
    edge_scale = 2.0 / c0k
    X = state[S_X]
    V = state[S_V]
    fx_now = state[S_FX]
    fz_now = state[S_FZ]
    n_act = np.int64(state[S_NACT])  # nodes in contact: g[0 .. n_act-1] < d
    x_prev = state[S_XIND]
    z_prev = state[S_ZIND]
    t_start = state[S_TIME]
    X_start = X
    inv_mass = 1.0 / moving_mass
    period = tx[tx.size - 1]
    peak_fx = 0.0
    peak_fz = 0.0
    diss_base = 0.0
    work_load = 0.0
    work_x = 0.0
    work_z = 0.0
    n_rec = 0
    n_breaks = merge_breaks(tx, tz, scratch)
    breaks = scratch[:n_breaks]
    d_buf = scratch[n_breaks:n_breaks + STEP_BLOCK]
    a1_buf = scratch[n_breaks + STEP_BLOCK:n_breaks + 2 * STEP_BLOCK]
    fz_buf = scratch[n_breaks + 2 * STEP_BLOCK:n_breaks + 3 * STEP_BLOCK]
    fx_part = scratch[n_breaks + 3 * STEP_BLOCK:n_breaks + 3 * STEP_BLOCK + n_nodes]
    slip_sum = scratch[n_breaks + 3 * STEP_BLOCK + n_nodes:n_breaks + 3 * STEP_BLOCK + 2 * n_nodes]
    slip_sum[:] = 0.0  # per node: w lim |overshoot| summed over the period's steps
    diss_edge = 0.0  # the edge cells' part of it
    fz_scale = c_n * edge_scale
    block_first = 0
    block_end = 0
    n_steps_total = 0
    step_in_seg = 0
    n_in_seg = 0
    seg = -1
    t_seg = 0.0
    dt = 0.0
    half_dt = 0.0
    inv_dt = 0.0
    xa = xb = za = zb = dx_seg = dz_seg = 0.0
    while True:
        if step_in_seg == n_in_seg:  # next segment: choose its step
            seg += 1
            if seg == breaks.size - 1:
                break
            t0 = breaks[seg]
            t1 = breaks[seg + 1]
            xa, _ = _interp(t0, tx, vx, 0)
            xb, _ = _interp(t1, tx, vx, 0)
            za, _ = _interp(t0, tz, vz, 0)
            zb, _ = _interp(t1, tz, vz, 0)
            n_in_seg = max(1, int(np.ceil((t1 - t0) / dt_max - 1e-9)),
                           int(np.ceil(abs(xb - xa) / x_step - 1e-9)), int(np.ceil(abs(zb - za) / z_step - 1e-9)))
            dt = (t1 - t0) / n_in_seg
            half_dt = 0.5 * dt
            inv_dt = 1.0 / dt
            dx_seg = (xb - xa) / n_in_seg  # x(t) and z(t) are linear within a segment
            dz_seg = (zb - za) / n_in_seg
            t_seg = t0
            step_in_seg = 0
            block_end = 0
        if step_in_seg == block_end:  # the next block of steps' depth-only quantities
            block_first = step_in_seg
            block_end = min(n_in_seg, block_first + STEP_BLOCK)
            _depth_block(za, dz_seg, zb, block_first, block_end - block_first, n_in_seg, s, half_kp1, fz_scale,
                         inv_kp1, inv_kp3s, d_buf, a1_buf, fz_buf)
        j = step_in_seg - block_first
        step_in_seg += 1
        n_steps_total += 1
        x_new = xb if step_in_seg == n_in_seg else xa + step_in_seg * dx_seg
        d_new = d_buf[j]

        # velocity Verlet: half kick with the forces at t_n, drift, springs, half kick at t_{n+1}
        V, imp1 = _half_kick(V, fx_now - load, mu1 * fz_now, half_dt, moving_mass, inv_mass)
        dX = dt * V
        X += dX
        shift = (x_new - x_prev) - dX
        work_x += fx_now * (x_new - x_prev)
        work_load += load * dX

        # nodes in contact: g < d
        n_new = n_act
        while n_new < n_nodes and g[n_new] < d_new:
            n_new += 1
        while n_new > 0 and g[n_new - 1] >= d_new:
            n_new -= 1
        if n_new == n_nodes:
            raise ValueError("indentation exceeds the node grid; build the simulator with a larger max_depth")
        fx = 0.0
        fz = 0.0
        if n_new > 0:
            last = n_new - 1
            a1 = a1_buf[j]  # a^(k+1), a the contact radius
            a3 = a1 * s * d_new
            fz = fz_buf[j]  # paper Eq. 8, exact
            gap = d_new - g[last]
            edge = 0.0
            if gap > 1e-12 * d_new:
                edge = edge_scale * (d_new * (a1 - p1[last]) * inv_kp1 - (a3 - p3[last]) * inv_kp3s) / gap
            u_last = u_x[last] + shift
            # every node up to the contact edge and past the nodes that just left it, in whole SIMD blocks
            n_loop = min(n_nodes, (max(n_new, n_act) + NODE_BLOCK - 1) // NODE_BLOCK * NODE_BLOCK)
            fx = _update_nodes(u_x, g, w, n_loop, shift, d_new, slip_ratio, fx_part, slip_sum)
            dw = left[last] + edge - w[last]  # the last node in contact carries the edge cell, not its hat
            u = u_x[last]
            fx = c_t * (fx + dw * u)
            diss_edge += dw * slip_ratio * gap * abs(u_last - u)
        else:
            for i in range(n_act):
                u_x[i] = 0.0

        V, imp2 = _half_kick(V, fx - load, mu1 * fz, half_dt, moving_mass, inv_mass)
        diss_base += (imp1 + imp2) * inv_dt * dX  # mean base force over the step times the displacement
        work_z += 0.5 * (fz_now + fz) * (d_new - z_prev)
        fx_now = fx
        fz_now = fz
        x_prev = x_new
        z_prev = d_new
        n_act = n_new
        if abs(fx) > peak_fx:
            peak_fx = abs(fx)
        if fz > peak_fz:
            peak_fz = fz
        if record_every > 0 and n_steps_total % record_every == 0:
            t = breaks[seg + 1] if step_in_seg == n_in_seg else t_seg + step_in_seg * dt
            n_rec = record_row(trace, n_rec, t_start + t, x_new, d_new, X, V, fx, fz)

    slip = 0.0
    for i in range(n_nodes):
        slip += slip_sum[i]
    diss_ind = c_t * (slip + diss_edge)
    store_period(state, out, X, V, fx_now, fz_now, n_act, x_prev, z_prev, t_start + period, X_start, period,
                 peak_fx, peak_fz, diss_ind, diss_base, work_load, work_x, work_z, n_rec)
