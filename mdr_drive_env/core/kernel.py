"""The Numba kernel of the reference solver: one call advances the drive by one period.

Time stepping (docs/model.md, paper Eqs. 13-16), per step ``t_n -> t_{n+1}``:

1. forces ``F_x``, ``F_z`` from the spring state at ``t_n`` (kept from the previous step);
2. semi-implicit Euler for the slider: ``V += dt (F_x - sgn(V) mu1 F_z - F_m) / M``, then
   ``X += dt V`` with the new velocity;
3. the relative shift ``[x(t_{n+1}) - x(t_n)] - [X_{n+1} - X_n]`` is added to every spring in
   contact at ``t_{n+1}`` (``u_z = d(t_{n+1}) - g_i > 0``);
4. springs with ``|u_x| >= lambda u_z`` are set to ``sign(u_x) lambda u_z`` (slip), with
   ``lambda = mu C_N / C_T``;
5. springs that left the contact are reset to 0 (they re-enter at 0).

Springs are passed in order of increasing ``g_i`` (the symmetric half grid |x_i| = i dx with
weights 1, 2, 2, ... folded into ``kx``, ``kz``), so the springs in contact are a prefix.

The state persists across calls in ``u_x`` and ``state``; the caller may change the waveform
between calls. All arrays are float64 and the scalar types are fixed, so the kernel compiles once.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# state vector layout
S_X, S_V, S_FX, S_FZ, S_NACT, S_XIND, S_ZIND, S_TIME = range(8)
STATE_SIZE = 8

# per-period result layout
(
    O_DISPLACEMENT,
    O_MEAN_VELOCITY,
    O_PEAK_FX,
    O_PEAK_FZ,
    O_DISS_INDENTER,
    O_DISS_BASE,
    O_WORK_LOAD,
    O_WORK_INDENTER_X,
    O_WORK_INDENTER_Z,
    O_N_RECORDED,
) = range(10)
OUT_SIZE = 10

# trace column layout
T_TIME, T_X, T_Z, T_SLIDER_X, T_SLIDER_V, T_FX, T_FZ = range(7)
TRACE_COLUMNS = ("t", "x", "z", "X", "V", "F_x", "F_z")


@njit(cache=True, inline="always")
def _interp(t, times, values, j):
    """Piecewise-linear value at ``t`` with a forward-moving segment pointer ``j``."""
    last = times.size - 2
    while j < last and t > times[j + 1]:
        j += 1
    t0 = times[j]
    t1 = times[j + 1]
    w = (t - t0) / (t1 - t0)
    if w > 1.0:
        w = 1.0
    return values[j] + (values[j + 1] - values[j]) * w, j


@njit(cache=True, inline="always")
def record_row(trace, n_rec, t, x, z, X, V, fx, fz):
    """Write one trace row (if the buffer has room); returns the new row count."""
    if n_rec < trace.shape[0]:
        trace[n_rec, T_TIME] = t
        trace[n_rec, T_X] = x
        trace[n_rec, T_Z] = z
        trace[n_rec, T_SLIDER_X] = X
        trace[n_rec, T_SLIDER_V] = V
        trace[n_rec, T_FX] = fx
        trace[n_rec, T_FZ] = fz
        n_rec += 1
    return n_rec


@njit(cache=True, inline="always")
def store_period(state, out, X, V, fx, fz, n_act, x_ind, z_ind, t_end, X_start, period, peak_fx, peak_fz,
                 diss_ind, diss_base, work_load, work_x, work_z, n_rec):
    """Write the state at the end of a period and the period's results."""
    state[S_X] = X
    state[S_V] = V
    state[S_FX] = fx
    state[S_FZ] = fz
    state[S_NACT] = n_act
    state[S_XIND] = x_ind
    state[S_ZIND] = z_ind
    state[S_TIME] = t_end
    out[O_DISPLACEMENT] = X - X_start
    out[O_MEAN_VELOCITY] = (X - X_start) / period
    out[O_PEAK_FX] = peak_fx
    out[O_PEAK_FZ] = peak_fz
    out[O_DISS_INDENTER] = diss_ind
    out[O_DISS_BASE] = diss_base
    out[O_WORK_LOAD] = work_load
    out[O_WORK_INDENTER_X] = work_x
    out[O_WORK_INDENTER_Z] = work_z
    out[O_N_RECORDED] = n_rec


@njit(cache=True)
def advance_period(
    u_x,
    state,
    g,
    kx,
    kz,
    slip_ratio,
    tx,
    vx,
    tz,
    vz,
    n_steps,
    dt,
    moving_mass,
    load,
    mu1,
    record_every,
    trace,
    out,
):
    """Advance ``u_x`` and ``state`` by ``n_steps`` steps of ``dt`` (one period).

    Args:
        u_x: tangential spring displacements (m), modified in place.
        state: ``[X, V, F_x, F_z, n_in_contact, x_indenter, z_indenter, time]``, in place.
        g: MDR profile at the springs (m), ascending.
        kx, kz: tangential and normal spring stiffness (N/m), weights included.
        slip_ratio: lambda = mu C_N / C_T (-).
        tx, vx, tz, vz: knots of x(t) and z(t) (s, m) over the period, local time from 0.
        n_steps, dt: number of steps and step (s); ``n_steps dt`` is the period.
        moving_mass: M (kg); load: F_m (N); mu1: base friction coefficient.
        record_every: record a trace row every this many steps (0: none).
        trace: (rows, 7) buffer for the trace, see ``TRACE_COLUMNS``.
        out: (OUT_SIZE,) per-period results, overwritten.
    """
    n_springs = g.size
    X = state[S_X]
    V = state[S_V]
    fx_now = state[S_FX]
    fz_now = state[S_FZ]
    n_act = np.int64(state[S_NACT])
    x_prev = state[S_XIND]
    z_prev = state[S_ZIND]
    t_start = state[S_TIME]
    X_start = X
    period = tx[tx.size - 1]

    jx = 0
    jz = 0
    peak_fx = 0.0
    peak_fz = 0.0
    diss_ind = 0.0
    diss_base = 0.0
    work_load = 0.0
    work_x = 0.0
    work_z = 0.0
    n_rec = 0
    inv_m = dt / moving_mass

    for n in range(n_steps):
        t = (n + 1) * dt
        if n == n_steps - 1:
            t = period
        x_new, jx = _interp(t, tx, vx, jx)
        d_new, jz = _interp(t, tz, vz, jz)

        # slider: semi-implicit Euler with base friction sgn(V) mu1 F_z
        if V > 0.0:
            f_base = mu1 * fz_now
        elif V < 0.0:
            f_base = -mu1 * fz_now
        else:
            f_base = 0.0
        V = V + inv_m * (fx_now - f_base - load)
        dX = dt * V
        X += dX
        shift = (x_new - x_prev) - dX
        work_x += fx_now * (x_new - x_prev)
        diss_base += f_base * dX
        work_load += load * dX

        # springs in contact at t_{n+1}: prefix of g < d
        n_new = n_act
        while n_new < n_springs and g[n_new] < d_new:
            n_new += 1
        while n_new > 0 and g[n_new - 1] >= d_new:
            n_new -= 1
        if n_new == n_springs and n_springs > 0:
            raise ValueError("indentation exceeds the spring grid; build the simulator with a larger max_depth")
        for i in range(n_new, n_act):  # left the contact: release and reset
            diss_ind += 0.5 * kx[i] * u_x[i] * u_x[i]
            u_x[i] = 0.0

        fx = 0.0
        fz = 0.0
        for i in range(n_new):
            uz = d_new - g[i]
            lim = slip_ratio * uz
            u = u_x[i] + shift
            if u > lim:
                diss_ind += kx[i] * lim * (u - lim)
                u = lim
            elif u < -lim:
                diss_ind += kx[i] * lim * (-lim - u)
                u = -lim
            u_x[i] = u
            fx += kx[i] * u
            fz += kz[i] * uz

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
        if record_every > 0 and (n + 1) % record_every == 0:
            n_rec = record_row(trace, n_rec, t_start + t, x_new, d_new, X, V, fx, fz)

    store_period(state, out, X, V, fx_now, fz_now, n_act, x_prev, z_prev, t_start + period, X_start, period,
                 peak_fx, peak_fz, diss_ind, diss_base, work_load, work_x, work_z, n_rec)
