"""The reference simulator against closed forms, invariants and conservation laws."""

import dataclasses

import numpy as np
import pytest
from tests.conftest import COARSE

from mdr_drive_env.core import (
    AxisWaveform,
    Contact,
    Drive,
    DriveParams,
    DriveSimulator,
    Numerics,
    Waveform,
    mindlin_tangential_force,
)
from mdr_drive_env.core import kernel as K

IMMOVABLE = Drive(slider_mass=1e30)  # the slider does not move: a fixed half-space


def _const(value, period):
    return np.array([0.0, period]), np.array([value, value])


def _random_waveform(rng):
    period = 2e-3
    xr = rng.integers(1, 20) * 1e-4
    zr = rng.integers(1, 20) * 1e-4
    return Waveform(
        x=AxisWaveform(rng.uniform(0, 30e-6), xr, period - xr),
        z=AxisWaveform(rng.uniform(0.5e-6, 6e-6), zr, period - zr),
        z_phase=float(rng.integers(0, 20) / 20),
    )


@pytest.mark.parametrize("k", [0.0, 0.3, 0.6])
def test_tangential_loading_follows_graded_cattaneo_mindlin(k):
    """Fixed depth, monotonic shift: F_x(delta) equals the scipy integral of docs/model.md."""
    params = dataclasses.replace(DriveParams.paper(k=k), drive=IMMOVABLE)
    depth, period = 4e-6, 1e-3
    sim = DriveSimulator(params, Numerics(1e-6, 2e-8), max_depth=depth)
    lam = params.slip_ratio
    delta_max = 1.2 * lam * depth  # beyond full slip
    tx, vx = np.array([0.0, period]), np.array([0.0, delta_max])
    r = sim.step_knots(tx, vx, *_const(depth, period), record_every=50)
    c_n, c_t = params.normal_stiffness_prefactor, params.tangential_stiffness_prefactor
    fz = r.trace[0, K.T_FZ]
    for row in r.trace:
        delta = row[K.T_X]
        exact = mindlin_tangential_force(delta, depth, k, 2.5e-3, c_n, c_t, 1.0, 0.3)
        assert row[K.T_FX] == pytest.approx(exact, rel=2e-3, abs=1e-6 * fz)
    assert r.trace[-1, K.T_FX] == pytest.approx(0.3 * fz, rel=1e-12)  # full slip: mu F_z


def test_coulomb_bound_at_every_instant_with_random_waveforms(rng):
    params = DriveParams.paper(k=0.2, cargo_mass=0.05)
    sim = DriveSimulator(params, COARSE)
    for _ in range(8):
        r = sim.step(_random_waveform(rng), record_every=1)
        fx, fz = r.trace[:, K.T_FX], r.trace[:, K.T_FZ]
        assert np.all(np.abs(fx) <= 0.3 * fz * (1 + 1e-12) + 1e-300)
        assert r.peak_tangential_force <= 0.3 * r.peak_normal_force * (1 + 1e-12)


def _full_grid(sim):
    """The same springs without the symmetry: x = 0, -dx, +dx, -2dx, ... each with weight 1."""
    n = sim.g.size
    idx = np.concatenate(([0], np.repeat(np.arange(1, n), 2)))
    w = np.where(idx == 0, 1.0, 0.5)  # half-grid weights are 1, 2, 2, ...
    return sim.g[idx].copy(), sim.kx[idx] * w, sim.kz[idx] * w


def test_symmetric_half_grid_equals_full_grid():
    params = DriveParams.paper(k=0.2, cargo_mass=0.1)
    half = DriveSimulator(params, COARSE)
    g, kx, kz = _full_grid(half)
    wf = Waveform.paper()
    results = [half.step(wf, record_every=10) for _ in range(3)]
    trace_half = np.concatenate([r.trace for r in results])

    from mdr_drive_env.core.waveform import period_knots

    u = np.zeros_like(g)
    state = np.zeros(K.STATE_SIZE)
    out = np.zeros(K.OUT_SIZE)
    rows = []
    for _ in range(3):
        tr = np.empty((200, 7))
        z0 = state[K.S_ZIND] if state[K.S_TIME] > 0 else None
        K.advance_period(u, state, g, kx, kz, half.slip_ratio, *period_knots(wf, z0), 2000, 1e-6,
                         0.05, params.drive.load, 0.1, 10, tr, out)
        rows.append(tr)
    trace_full = np.concatenate(rows)
    np.testing.assert_allclose(trace_full, trace_half, rtol=1e-9, atol=1e-15)


def test_pinned_indenter_keeps_unloaded_slider_at_rest():
    sim = DriveSimulator(DriveParams.paper(k=0.3), COARSE)
    period = 2e-3
    for _ in range(3):
        r = sim.step_knots(*_const(0.0, period), *_const(5e-6, period), record_every=1)
        assert np.all(r.trace[:, K.T_SLIDER_X] == 0.0)
        assert np.all(r.trace[:, K.T_SLIDER_V] == 0.0)
        assert np.all(r.trace[:, K.T_FX] == 0.0)
        assert r.trace[0, K.T_FZ] > 1.0
    assert sim.position == 0.0 and sim.velocity == 0.0


def _energy_residual(dt, k):
    """Relative residuals of the x and z energy balances over 3 periods, the last ending mid-contact."""
    sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=0.1), Numerics(dt, 1e-7))
    w_x = d_ind = d_base = w_load = w_z = 0.0
    for wf in (Waveform.paper(), Waveform.paper(), Waveform(z_phase=0.25)):
        r = sim.step(wf)
        w_x += r.indenter_work_x
        d_ind += r.indenter_dissipation
        d_base += r.base_dissipation
        w_load += r.load_work
        w_z += r.indenter_work_z
    e_t, e_n = sim.elastic_energy()
    assert e_t > 0 and e_n > 0 and d_ind > 0 and d_base > 0
    balance_x = w_x - (sim.kinetic_energy() + e_t + d_ind + d_base + w_load)
    return balance_x / w_x, (w_z - e_n) / e_n


@pytest.mark.parametrize("k", [0.0, 0.3])
def test_energy_balance_closes_to_integration_error(k):
    """Indenter work = kinetic + elastic energy + dissipation (indenter, base) + work on the load."""
    rel_x_coarse, rel_z_coarse = _energy_residual(2e-6, k)
    rel_x_fine, rel_z_fine = _energy_residual(5e-7, k)
    assert abs(rel_x_fine) < 3e-3
    assert abs(rel_z_fine) < 1e-5
    # an integration error: first order in dt for the friction side, second for the normal side
    assert abs(rel_x_coarse / rel_x_fine) > 3.0
    assert abs(rel_z_coarse / rel_z_fine) > 10.0


def test_state_persists_across_calls_and_waveform_changes_are_continuous(rng):
    params = DriveParams.paper(k=0.2, cargo_mass=0.05)
    a = DriveSimulator(params, COARSE)
    b = DriveSimulator(params, COARSE)
    wf = Waveform.paper()
    ra = a.run(wf, 4)
    rb = [b.step(wf) for _ in range(4)]
    assert [r.displacement for r in ra] == [r.displacement for r in rb]
    # a phase change: z stays continuous at the boundary
    shifted = Waveform(z_phase=0.5)
    z_end = a.indenter_depth
    r = a.step(shifted, record_every=1)
    assert abs(r.trace[0, K.T_Z] - z_end) < 6e-6 * 1e-6 / 1.7e-4 * 10  # one step of the blend ramp
    assert a.time == pytest.approx(5 * 2e-3)


def test_reset_restores_a_fresh_simulator():
    sim = DriveSimulator(DriveParams.paper(cargo_mass=0.1), COARSE)
    first = sim.step(Waveform.paper())
    sim.run(Waveform.paper(), 2)
    sim.reset()
    again = sim.step(Waveform.paper())
    assert again.displacement == first.displacement


def test_paper_k0_drive_moves_forward_and_slows_with_load():
    v = []
    for m in (0.0, 0.4, 0.8):
        sim = DriveSimulator(DriveParams.paper(cargo_mass=m), COARSE)
        v.append(sim.run(Waveform.paper(), 6)[-1].mean_velocity)
    assert v[0] > v[1] > v[2]
    assert 0.0 < v[0] < 0.3  # slower than the indenter's fastest edge (30 um in 0.1 ms)


def test_contact_without_base_friction_and_load_moves_no_slider_backwards():
    """mu1 = 0, no load: the slider is only ever pushed forward by the indenter's slow stroke."""
    params = dataclasses.replace(DriveParams.paper(), contact=Contact(base_friction_coefficient=0.0))
    sim = DriveSimulator(params, COARSE)
    rs = sim.run(Waveform.paper(), 3)
    assert all(r.base_dissipation == 0.0 for r in rs)
    assert rs[-1].end_position > 0
