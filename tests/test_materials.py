"""Material factors and closed forms against physics.md's test vectors and limits."""

import math

import numpy as np
import pytest

from mdr_drive_env.core import (
    DriveParams,
    DriveSimulator,
    Material,
    Numerics,
    h_normal,
    h_tangential,
    normal_force_analytic,
)

# physics.md section 1, nu = 0.3
VECTORS = [
    (0.0, 1.000000, 0.904977),
    (0.2, 1.165829, 0.836335),
    (0.3, 1.201198, 0.772445),
    (0.5, 1.141409, 0.595146),
    (0.9, 0.353040, 0.122829),
]


@pytest.mark.parametrize("k,h_n,h_t", VECTORS)
def test_h_factors_match_physics_md_vectors(k, h_n, h_t):
    assert h_normal(k, 0.3) == pytest.approx(h_n, abs=1e-6)
    assert h_tangential(k, 0.3) == pytest.approx(h_t, abs=1e-6)


@pytest.mark.parametrize("nu", [-0.5, 0.0, 0.25, 0.3, 0.49, 0.5])
def test_homogeneous_limits(nu):
    assert h_normal(0.0, nu) == pytest.approx(1.0, abs=1e-12)
    assert h_tangential(0.0, nu) == pytest.approx(2.0 / ((1 + nu) * (2 - nu)), rel=1e-12)


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_h_factors_continuous_at_k_zero(nu):
    for h in (h_normal, h_tangential):
        assert h(1e-7, nu) == pytest.approx(h(0.0, nu), rel=1e-5)


def test_paper_eq5_for_identical_bodies():
    k, nu, e0 = 0.3, 0.3, 2e11
    p = DriveParams.paper(k=k)
    assert p.normal_stiffness_prefactor == pytest.approx(h_normal(k, nu) * e0 / (2 * (1 - nu**2)), rel=1e-12)
    assert p.tangential_stiffness_prefactor == pytest.approx(h_tangential(k, nu) * e0 / 2, rel=1e-12)


def test_rigid_indenter_drops_its_term():
    graded = Material(youngs_modulus=1e11, poisson_ratio=0.25, grading_exponent=0.4)
    p = DriveParams(indenter=Material.rigid(), slider=graded)
    assert p.k == 0.4
    assert p.normal_stiffness_prefactor == pytest.approx(h_normal(0.4, 0.25) * 1e11 / (1 - 0.25**2), rel=1e-12)
    assert p.tangential_stiffness_prefactor == pytest.approx(h_tangential(0.4, 0.25) * 1e11, rel=1e-12)


def test_dissimilar_bodies_add_compliances():
    a = Material(youngs_modulus=2e11, poisson_ratio=0.3, grading_exponent=0.2)
    b = Material(youngs_modulus=7e10, poisson_ratio=0.1, grading_exponent=0.2)
    p = DriveParams(indenter=a, slider=b)
    expected = 1 / ((1 - 0.09) / (h_normal(0.2, 0.3) * 2e11) + (1 - 0.01) / (h_normal(0.2, 0.1) * 7e10))
    assert p.normal_stiffness_prefactor == pytest.approx(expected, rel=1e-12)


def test_h_overrides_are_used():
    m = Material(grading_exponent=0.3, h_normal_override=1.5, h_tangential_override=0.5)
    assert m.h_normal == 1.5 and m.h_tangential == 0.5
    p = DriveParams(indenter=m, slider=m)
    assert p.normal_stiffness_prefactor == pytest.approx(1.5 * 2e11 / (2 * 0.91), rel=1e-12)


def _discrete_normal_force(sim, depth):
    return float(np.dot(sim.kz, np.maximum(depth - sim.g, 0.0)))


@pytest.mark.parametrize("k", [0.0, 0.2, 0.5, 0.9])
@pytest.mark.parametrize("depth", [1e-6, 3e-6, 6e-6])
def test_discrete_normal_force_converges_to_eq8(k, depth):
    p = DriveParams.paper(k=k)
    errors = []
    for dx in (4e-7, 1e-7, 2.5e-8):
        sim = DriveSimulator(p, Numerics(1e-6, dx), max_depth=6e-6)
        exact = normal_force_analytic(depth, k, 2.5e-3, p.normal_stiffness_prefactor, 1.0)
        errors.append(abs(_discrete_normal_force(sim, depth) / exact - 1.0))
    assert errors[-1] < 2e-3
    assert errors[0] > errors[1] > errors[2]


def test_eq8_value_homogeneous_steel():
    # k = 0: F = 4 E* a^3 / (3 R) with E* = E / (2 (1 - nu^2)) (paper's identical bodies)
    a = math.sqrt(2.5e-3 * 6e-6)
    e_star = 2e11 / (2 * 0.91)
    assert normal_force_analytic(6e-6, 0.0, 2.5e-3, e_star, 1.0) == pytest.approx(4 * e_star * a**3 / (3 * 2.5e-3))
