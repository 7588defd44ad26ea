"""Steady-state velocity rules and the critical-load bisection."""

import numpy as np
import pytest
from tests.conftest import COARSE

from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform, critical_load, steady_velocity


def test_paper_rule_is_the_sixth_period_mean():
    p = DriveParams.paper(k=0.2, cargo_mass=0.1)
    sv = steady_velocity(p, numerics=COARSE, rule="paper")
    sim = DriveSimulator(p, COARSE)
    sixth = sim.run(Waveform.paper(), 6)[5]
    assert sv.velocity == sixth.mean_velocity == sixth.displacement / 2e-3
    assert sv.periods_run == 6 and len(sv.period_velocities) == 6


def test_settled_rule_waits_out_a_decaying_alternation():
    p = DriveParams.paper(k=0.2, cargo_mass=0.1)  # alternates between two period velocities, decaying
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


# --- the state a run ends in (docs/model.md, "Steady velocity") ---

def test_motion_state_on_synthetic_runs():
    from mdr_drive_env.core.analysis import motion_state

    v_min = -0.3  # the paper's return stroke: -30 um / 0.1 ms
    periodic = [0.01, 0.012, 0.011, 0.012, 0.011, 0.012, 0.011]
    assert motion_state(periodic, v_min, window=2, rtol=1e-3) == "settled"
    decaying = 0.015 - 0.01 * 0.8 ** np.arange(8)
    assert motion_state(decaying, v_min) == "settling"
    backwards_steady = [-0.002, -0.0021, -0.0021, -0.0021, -0.0021]
    assert motion_state(backwards_steady, v_min) == "settled"  # a steady velocity, negative
    accelerating = -0.2 * np.arange(1, 8)  # constant deceleration past the return stroke's speed
    assert motion_state(accelerating, v_min) == "runaway"
    assert motion_state(accelerating[:2], v_min) == "settling"  # -0.2, -0.4: not both past v_min yet
    assert motion_state(periodic, v_min, load_margin=-1e-3) == "runaway"  # the load beats every push
    with pytest.raises(ValueError):
        motion_state([], v_min)


def test_a_load_beyond_every_push_runs_away_and_is_not_a_velocity():
    # k = 0.6, m = 0.5 kg: F_m = 4.9 N against (mu + mu1) max F_z = 0.15 N
    sv = steady_velocity(DriveParams.paper(k=0.6, cargo_mass=0.5))
    assert sv.state == "runaway" and not sv.settled
    assert sv.periods_run < 20  # detected early, not run to max_periods
    assert steady_velocity(DriveParams.paper(k=0.6, cargo_mass=0.5), rule="paper").state == "runaway"


def test_the_paper_rule_does_not_claim_settled_in_a_transient():
    # k = 0.6 unloaded: period 6 is still in the transient (about 5.7 mm/s, about 15 mm/s settled)
    p = DriveParams.paper(k=0.6)
    paper, settled = steady_velocity(p, rule="paper"), steady_velocity(p)
    assert paper.state == "settling" and paper.velocity < 8e-3
    assert settled.state == "settled" and settled.velocity == pytest.approx(15.0e-3, rel=0.01)
    # k = 0.2, m = 0.1 kg: a decaying alternation, settled only after tens of periods
    p = DriveParams.paper(k=0.2, cargo_mass=0.1)
    assert steady_velocity(p, rule="paper").state == "settling"
    sv = steady_velocity(p)
    assert sv.state == "settled" and sv.periods_run > 20
    assert sv.velocity == pytest.approx(11.01e-3, rel=2e-3)


def test_a_steady_backward_drift_is_settled_not_runaway():
    # k = 0.3, m = 0.1 kg: the load drags the slider back at a steady -7.66 mm/s
    sv = steady_velocity(DriveParams.paper(k=0.3, cargo_mass=0.1))
    assert sv.state == "settled" and sv.velocity == pytest.approx(-7.66e-3, rel=2e-3)


def test_critical_load_never_counts_a_runaway_as_moving(monkeypatch):
    from mdr_drive_env.core import analysis

    fake = analysis.SteadyVelocity(1.0, 6, "runaway", np.ones(6))  # a positive number, but a runaway
    monkeypatch.setattr(analysis, "steady_velocity", lambda *a, **kw: fake)
    assert analysis.critical_load(DriveParams.paper()).cargo_mass == 0.0
