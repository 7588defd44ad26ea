"""Steady-state velocity rules and the critical-load bisection."""

import numpy as np
import pytest
from conftest import COARSE

from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform, critical_load, steady_velocity


def test_paper_rule_is_the_sixth_period_mean():
    p = DriveParams.paper(k=0.2, cargo_mass=0.1)
    sv = steady_velocity(p, numerics=COARSE, rule="paper")
    sim = DriveSimulator(p, COARSE)
    sixth = sim.run(Waveform.paper(), 6)[5]
    assert sv.velocity == sixth.mean_velocity == sixth.displacement / 2e-3
    assert sv.periods_run == 6 and len(sv.period_velocities) == 6


def test_settled_rule_averages_period_doubling():
    p = DriveParams.paper(k=0.2, cargo_mass=0.1)  # alternates between two period velocities
    sv = steady_velocity(p, numerics=COARSE, rule="settled", window=2, rtol=1e-3)
    assert sv.settled
    v = sv.period_velocities
    assert abs(np.mean(v[-2:]) - np.mean(v[-4:-2])) <= 1e-3 * abs(sv.velocity) + 1e-6
    assert sv.velocity == pytest.approx(np.mean(v[-2:]))


def test_settled_rule_reports_not_settled():
    sv = steady_velocity(DriveParams.paper(k=0.2, cargo_mass=0.1), numerics=COARSE, rule="settled",
                         rtol=0.0, atol=0.0, max_periods=8)
    assert not sv.settled and sv.periods_run == 8
    with pytest.raises(ValueError, match="rule="):
        steady_velocity(DriveParams.paper(), numerics=COARSE, rule="nope")


def test_critical_load_brackets_the_sign_change():
    p = DriveParams.paper(k=0.2)
    cl = critical_load(p, numerics=COARSE, tolerance=2e-3, upper_guess=0.25)
    lo, hi = cl.bracket
    assert 0 < lo < hi and hi - lo <= 2e-3 and cl.cargo_mass == lo
    assert cl.load_force == pytest.approx(lo * 9.81)
    assert steady_velocity(p.with_cargo_mass(lo), numerics=COARSE).velocity > 0
    assert steady_velocity(p.with_cargo_mass(hi), numerics=COARSE).velocity <= 0


def test_critical_load_is_zero_when_the_drive_cannot_move():
    from mdr_drive_env.core import AxisWaveform

    no_stroke = Waveform(x=AxisWaveform(0.0, 1.9e-3, 0.1e-3))  # z oscillates, x does not move
    p = DriveParams.paper(k=0.2)
    assert steady_velocity(p, no_stroke, numerics=COARSE).velocity == 0.0
    cl = critical_load(p, no_stroke, numerics=COARSE)
    assert cl.cargo_mass == 0.0 and cl.evaluations == 1
