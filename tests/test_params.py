"""Validation of the parameter dataclasses: bad values raise ValueError naming the field."""

import math

import pytest

from mdr_drive_env.core import AxisWaveform, Contact, Drive, DriveParams, Material, Numerics, Waveform, numerics_preset
from mdr_drive_env.core.simulator import DriveSimulator, check_numerics


@pytest.mark.parametrize(
    "factory,field,value",
    [
        (Material, "grading_exponent", 1.0),
        (Material, "grading_exponent", -0.1),
        (Material, "poisson_ratio", 0.6),
        (Material, "poisson_ratio", -1.0),
        (Material, "youngs_modulus", -1.0),
        (Material, "youngs_modulus", math.nan),
        (Material, "reference_depth", 0.0),
        (Material, "h_normal_override", 0.0),
        (Contact, "indenter_radius", 0.0),
        (Contact, "friction_coefficient", math.inf),
        (Contact, "base_friction_coefficient", -0.1),
        (Drive, "slider_mass", -0.05),
        (Drive, "cargo_mass", -1.0),
        (Drive, "load_force", math.nan),
        (Numerics, "time_step", 0.0),
        (Numerics, "spring_spacing", -1e-8),
    ],
)
def test_bad_values_raise_naming_the_field(factory, field, value):
    kwargs = {"time_step": 1e-6, "spring_spacing": 1e-7} if factory is Numerics else {}
    kwargs[field] = value
    with pytest.raises(ValueError, match=rf"{factory.__name__}\.{field}=.*allowed range"):
        factory(**kwargs)


@pytest.mark.parametrize("field", ["amplitude", "rise_time", "fall_time"])
def test_axis_waveform_rejects_bad_edges(field):
    kwargs = {"amplitude": 1e-6, "rise_time": 1e-3, "fall_time": 1e-3, field: -1.0}
    with pytest.raises(ValueError, match=f"AxisWaveform.{field}"):
        AxisWaveform(**kwargs)
    if field != "amplitude":
        kwargs[field] = 0.0
        with pytest.raises(ValueError, match=f"AxisWaveform.{field}"):
            AxisWaveform(**kwargs)


def test_waveform_periods_must_match_and_phase_in_range():
    with pytest.raises(ValueError, match="period"):
        Waveform(x=AxisWaveform(1e-6, 1e-3, 1e-3), z=AxisWaveform(1e-6, 1e-3, 2e-3))
    with pytest.raises(ValueError, match="Waveform.z_phase"):
        Waveform(z_phase=1.0)


def test_dt_must_be_small_against_the_waveform():
    with pytest.raises(ValueError, match="not small against the waveform"):
        check_numerics(Numerics(2e-5, 1e-7), Waveform.paper())  # 0.1 ms edge in 5 steps
    with pytest.raises(ValueError, match="does not divide the period"):
        check_numerics(Numerics(3e-7, 1e-7), Waveform.paper())
    assert check_numerics(Numerics(1e-7, 1e-8), Waveform.paper()) == 20000


def test_pair_must_share_k_unless_rigid():
    with pytest.raises(ValueError, match="grading_exponent"):
        DriveParams(indenter=Material(grading_exponent=0.1), slider=Material(grading_exponent=0.2))
    with pytest.raises(ValueError, match="both be rigid"):
        DriveParams(indenter=Material.rigid(), slider=Material.rigid())
    DriveParams(indenter=Material.rigid(), slider=Material(grading_exponent=0.2))


def test_presets_and_derived_quantities():
    assert numerics_preset("paper") == Numerics(1e-7, 1e-8)
    with pytest.raises(ValueError, match="numerics='nope'"):
        numerics_preset("nope")
    d = Drive(cargo_mass=0.1)
    assert d.load == pytest.approx(0.981)
    assert d.moving_mass == 0.05
    assert Drive(cargo_mass=0.1, cargo_inertia=True).moving_mass == pytest.approx(0.15)
    assert Drive(cargo_mass=0.1, load_force=2.0).load == 2.0
    p = DriveParams.paper(k=0.3, cargo_mass=0.2)
    assert p.with_k(0.5).k == 0.5 and p.with_k(0.5).drive.cargo_mass == 0.2
    assert p.with_cargo_mass(0.4).drive.load == pytest.approx(0.4 * 9.81)


def test_waveform_beyond_grid_raises():
    sim = DriveSimulator(DriveParams.paper(), Numerics(1e-6, 1e-7), max_depth=3e-6)
    with pytest.raises(ValueError, match="max_depth"):
        sim.step(Waveform.paper())
