"""Power-law graded materials in the Method of Dimensionality Reduction (MDR).

Closed forms of docs/model.md (Hess 2016, the graded MDR):

* ``h_N(k, nu)``, ``h_T(k, nu)``: the dimensionless factors of the 1D foundation stiffness,
* ``c_N``, ``c_T``: the foundation stiffness per unit length of a pair of bodies (paper Eqs. 3-5),
* the MDR profile of a paraboloid and the analytic normal force (paper Eqs. 2, 7, 8),
* the graded Cattaneo-Mindlin tangential force at fixed indentation (used by the tests).

Everything here is plain Python/NumPy: these are evaluated once per parameter set, never in the
simulator's hot loop.
"""

from __future__ import annotations

import math

import numpy as np


def _beta(k: float, nu: float) -> float:
    return math.sqrt((1.0 + k) * (1.0 - k * nu / (1.0 - nu)))


def _gamma_ratio(k: float, nu: float) -> float:
    """``sin(pi b/2) G((3+k+b)/2) G((3+k-b)/2) / (b G(1+k/2)^2)``, shared by h_N and h_T."""
    b = _beta(k, nu)
    return (
        math.sin(math.pi * b / 2.0)
        * math.gamma((3.0 + k + b) / 2.0)
        * math.gamma((3.0 + k - b) / 2.0)
        / (b * math.gamma(1.0 + k / 2.0) ** 2)
    )


def h_normal(k: float, nu: float) -> float:
    """Normal stiffness factor ``h_N(k, nu)`` of the graded MDR (dimensionless).

    ``h_N(0, nu) = 1`` (homogeneous MDR).
    """
    _check_k_nu(k, nu)
    return (1.0 + k) ** 2 * math.cos(math.pi * k / 2.0) / (_beta(k, nu) ** 2 * _gamma_ratio(k, nu))


def h_tangential(k: float, nu: float) -> float:
    """Tangential stiffness factor ``h_T(k, nu)`` of the graded MDR (dimensionless).

    ``h_T(0, nu) = 2 / ((1 + nu)(2 - nu))`` (homogeneous MDR).
    """
    _check_k_nu(k, nu)
    return 2.0 * math.cos(math.pi * k / 2.0) / ((1.0 + nu) * (1.0 + (1.0 - nu) * _gamma_ratio(k, nu)))


def _check_k_nu(k: float, nu: float) -> None:
    if not (math.isfinite(k) and 0.0 <= k < 1.0):
        raise ValueError(f"grading exponent k={k!r} is outside the allowed range [0, 1)")
    if not (math.isfinite(nu) and -1.0 < nu <= 0.5):
        raise ValueError(f"poisson_ratio nu={nu!r} is outside the allowed range (-1, 0.5]")


def mdr_profile(x: np.ndarray | float, k: float, radius: float) -> np.ndarray | float:
    """MDR profile of a paraboloid of radius ``radius`` (m): ``g(x) = x^2 / ((1+k) R)`` (m)."""
    return x * x / ((1.0 + k) * radius)


def contact_radius(depth: float, k: float, radius: float) -> float:
    """Contact radius ``a`` (m) at indentation depth ``depth`` (m): ``a^2 = (1+k) R d`` (Eq. 7)."""
    return math.sqrt(max(depth, 0.0) * (1.0 + k) * radius)


def normal_force_analytic(depth: float, k: float, radius: float, c_n: float, c0: float) -> float:
    """Normal force (N) of the paraboloid at depth ``depth`` (m), paper Eq. 8 for any pair.

    ``c_n`` is the prefactor ``C_N`` (Pa) of the foundation stiffness ``c_N(x) = C_N (|x|/c0)^k``:
    ``F_z = 4 C_N a^(3+k) / ((1+k)^2 (3+k) R c0^k)``.
    """
    a = contact_radius(depth, k, radius)
    return 4.0 * c_n * a ** (3.0 + k) / ((1.0 + k) ** 2 * (3.0 + k) * radius * c0**k)


def mindlin_tangential_force(
    shift: float, depth: float, k: float, radius: float, c_n: float, c_t: float, c0: float, mu: float
) -> float:
    """Graded Cattaneo-Mindlin tangential force (N) at fixed depth after a monotonic shift (m).

    Every spring carries ``u_x = min(shift, lambda (d - g(x)))`` with ``lambda = mu C_N / C_T``;
    the integral over the contact is evaluated with scipy's adaptive quadrature. It saturates at
    ``mu F_z`` for ``shift >= lambda d``.
    """
    from scipy.integrate import quad

    a = contact_radius(depth, k, radius)
    lam = mu * c_n / c_t
    x_stick = math.sqrt(max(0.0, (depth - shift / lam) * (1.0 + k) * radius))  # |x| where slip starts

    def integrand(x: float) -> float:
        u = min(shift, lam * (depth - x * x / ((1.0 + k) * radius)))
        return c_t * (x / c0) ** k * u

    points = [x_stick] if 0.0 < x_stick < a else None
    value, _ = quad(integrand, 0.0, a, points=points, epsabs=0.0, epsrel=1e-12, limit=200)
    return 2.0 * value
