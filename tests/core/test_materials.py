"""Material factors and closed forms against the test vectors and limits of docs/model.md."""

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

# docs/model.md, nu = 0.3
VECTORS = [
    (0.0, 1.000000, 0.904977),
    (0.2, 1.165829, 0.836335),
    (0.3, 1.201198, 0.772445),
    (0.5, 1.141409, 0.595146),
    (0.9, 0.353040, 0.122829),
]


@pytest.mark.parametrize("k,h_n,h_t", VECTORS)
def test_h_factors_match_the_test_vectors(k, h_n, h_t):
    assert h_normal(k, 0.3) == pytest.approx(h_n, abs=1e-6)
    assert h_tangential(k, 0.3) == pytest.approx(h_t, abs=1e-6)


@pytest.mark.parametrize("nu", [-0.5, 0.0, 0.25, 0.3, 0.49, 0.5])
def test_homogeneous_limits(nu):
    assert h_normal(0.0, nu) == pytest.approx(1.0, abs=1e-12)
    assert h_tangential(0.0, nu) == pytest.approx(2.0 / ((1 + nu) * (2 - nu)), rel=1e-12)


def jitcharoen_h_normal(k: float, nu: float, youngs_modulus: float = 2e11, radius: float = 2.5e-3) -> float:
    """h_N implied by the graded Hertz contact of Jitcharoen et al. (1998), after Giannakopoulos
    and Suresh (1997) (docs/model.md): a rigid sphere of diameter D = 2R pressed with force P
    into ``E(z) = E0 z^k`` (c0 = 1 m) has ``a^(3+k) = P D c1 G(1/2+k/2) G(3/2+k/2) / (pi 2^(2-k))
    (1+k)(3+k)/2``; the MDR force ``P = 4 h_N E0 a^(3+k) / ((1-nu^2)(1+k)^2(3+k) R)`` must give the
    same a for the same P. Independent of materials.py: only the gamma function is shared."""
    g = math.gamma
    q = math.sqrt((1 + k) * (1 - k * nu / (1 - nu)))
    c1 = (2 * q * math.sin(math.pi * q / 2) * (1 - nu**2) * g((3 + k + q) / 2) * g((3 + k - q) / 2) * g((1 - k) / 2)
          / (youngs_modulus * math.sqrt(math.pi) * (1 + k) * g(2 + k) * g(1 + k / 2)))
    a_per_force = (2 * radius * c1 * g(0.5 + k / 2) * g(1.5 + k / 2) / (math.pi * 2 ** (2 - k))
                   * (1 + k) * (3 + k) / 2)  # a^(3+k) / P
    return (1 - nu**2) * (1 + k) ** 2 * (3 + k) * radius / (4 * youngs_modulus * a_per_force)


@pytest.mark.parametrize("nu", [0.0, 0.15, 0.25, 0.3, 0.4, 0.49])
@pytest.mark.parametrize("k", [0.0, 0.05, 0.2, 0.3, 0.45, 0.6, 0.75, 0.89])
def test_h_normal_equals_the_graded_hertz_solution_of_jitcharoen(k, nu):
    assert h_normal(k, nu) == pytest.approx(jitcharoen_h_normal(k, nu), rel=1e-6)


def test_jitcharoen_check_is_hertz_at_k0_and_not_trivially_equal():
    # k = 0: the rigid sphere on a half-space, a^3 = 3 P R (1 - nu^2) / (4 E0), i.e. h_N = 1
    assert jitcharoen_h_normal(0.0, 0.3) == pytest.approx(1.0, rel=1e-12)
    # the check has teeth: a wrong h_N (the as-published hypothesis, x2) fails it
    assert abs(2 * h_normal(0.3, 0.3) / jitcharoen_h_normal(0.3, 0.3) - 1) > 0.5


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
