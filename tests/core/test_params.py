"""Validation of the parameter dataclasses: bad values raise ValueError naming the field."""

import math

import numpy as np
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
    assert Drive(cargo_inertia=np.bool_(True)).cargo_inertia is True  # a NumPy bool is stored as Python's
    with pytest.raises(ValueError, match=r"Drive.cargo_inertia=1 must be true or false"):
        Drive(cargo_inertia=1)
    assert Drive(cargo_mass=0.1, load_force=2.0).load == 2.0
    p = DriveParams.paper(k=0.3, cargo_mass=0.2)
    assert p.with_k(0.5).k == 0.5 and p.with_k(0.5).drive.cargo_mass == 0.2
    assert p.with_cargo_mass(0.4).drive.load == pytest.approx(0.4 * 9.81)


def test_waveform_beyond_grid_raises():
    sim = DriveSimulator(DriveParams.paper(), Numerics(1e-6, 1e-7), max_depth=3e-6)
    with pytest.raises(ValueError, match="max_depth"):
        sim.step(Waveform.paper())


# --- the "as-published" variant (docs/paper_reproduction.md) ---

def test_as_published_doubles_h_normal_only():
    spec, pub = DriveParams.paper(k=0.3), DriveParams.paper(k=0.3, variant="as-published")
    assert pub.normal_stiffness_prefactor == pytest.approx(2 * spec.normal_stiffness_prefactor, rel=1e-15)
    assert pub.tangential_stiffness_prefactor == spec.tangential_stiffness_prefactor
    assert pub.slip_ratio == pytest.approx(2 * spec.slip_ratio, rel=1e-15)
    # identical bodies: C_N = 2 h_N E0 / (2 (1 - nu^2)), i.e. h_N E0 / (1 - nu^2)
    from mdr_drive_env.core import h_normal

    assert pub.normal_stiffness_prefactor == pytest.approx(h_normal(0.3, 0.3) * 2e11 / (1 - 0.09), rel=1e-12)


def test_as_published_composes_with_overrides_and_a_rigid_indenter():
    import dataclasses

    mat = Material(grading_exponent=0.2, h_normal_override=1.7, h_tangential_override=0.6)
    p = DriveParams(indenter=mat, slider=mat, variant="as-published")
    assert p.normal_stiffness_prefactor == pytest.approx(2 * 1.7 * 2e11 / (2 * (1 - 0.09)), rel=1e-12)
    assert p.tangential_stiffness_prefactor == pytest.approx(0.6 * 2e11 / 2, rel=1e-12)
    rigid = DriveParams(indenter=Material.rigid(), slider=mat)
    assert dataclasses.replace(rigid, variant="as-published").normal_stiffness_prefactor == pytest.approx(
        2 * rigid.normal_stiffness_prefactor, rel=1e-15)
    assert p.with_k(0.4).variant == p.with_cargo_mass(0.2).variant == "as-published"


def test_unknown_variant_is_rejected():
    with pytest.raises(ValueError, match="DriveParams.variant='as-built'"):
        DriveParams(variant="as-built")


def test_the_variant_decides_the_papers_open_point():
    """k = 0.3, m = 0.1 kg: the text says the drive still moves the cargo forward (docs/paper_reproduction.md)."""
    from mdr_drive_env.core import steady_velocity

    spec = steady_velocity(DriveParams.paper(k=0.3, cargo_mass=0.1))
    pub = steady_velocity(DriveParams.paper(k=0.3, cargo_mass=0.1, variant="as-published"))
    assert spec.settled and spec.velocity == pytest.approx(-7.66e-3, rel=2e-3)
    assert pub.settled and pub.velocity == pytest.approx(11.86e-3, rel=2e-3)


def test_env_and_cli_take_the_variant(capsys):
    import json

    import gymnasium as gym

    import mdr_drive_env  # noqa: F401
    from mdr_drive_env.cli import main
    from mdr_drive_env.core import DriveSimulator, Waveform

    api = [r.mean_velocity for r in DriveSimulator(DriveParams.paper(0.3, 0.1, "as-published")).run(Waveform.paper(), 3)]
    env = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.1, variant="as-published")
    env.reset(seed=1)
    assert [env.step(env.unwrapped.trapezoid_action())[4]["mean_velocity"] for _ in range(3)] == api
    assert main(["simulate", "--k", "0.3", "--cargo-mass", "0.1", "--variant", "as-published", "--periods", "3",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["period_mean_velocity"] == api and out["params"]["variant"] == "as-published"
    with pytest.raises(ValueError, match="variant="):
        gym.make("MDRDrive-v0", variant="nope")
