"""Parameters of the drive model: small frozen dataclasses in SI units, validated at construction.

A bad value raises ``ValueError`` naming the field, the value and the allowed range, e.g.
``Material.poisson_ratio=0.7 is outside the allowed range (-1, 0.5]``.

Defaults are the paper's parameter set (docs/model.md).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from . import materials

_INF = math.inf
#: Physically meaningful bounds of the model's quantities (SI units): a value outside them is a
#: mistake (a unit off by 10^3, a typo), not a drive, and its arithmetic would overflow.
BOUNDS = {
    "youngs_modulus": (1e3, 1e13),       # Pa: from soft gels to diamond
    "reference_depth": (1e-9, 1e3),      # m
    "indenter_radius": (1e-7, 10.0),     # m
    "friction_coefficient": (0.0, 10.0),  # -
    "slider_mass": (1e-6, _INF),         # kg: a huge mass is the immovable (fixed half-space) limit
    "cargo_mass": (0.0, 1e4),            # kg
    "gravity": (0.0, 1e3),               # m/s^2
    "load_force": (0.0, 1e6),            # N
}


def check_range(
    name: str, value: float, low: float = -_INF, high: float = _INF, *, low_open: bool = False, high_open: bool = False
) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is a finite number in the range.

    Any real number passes the type check, NumPy scalars (``np.float32(0.2)``) included; bools do not.
    """
    interval = f"{'(' if low_open or low == -_INF else '['}{low:g}, {high:g}{')' if high_open or high == _INF else ']'}"
    ok = is_real_number(value) and math.isfinite(value)
    if ok:
        ok = (value > low if low_open else value >= low) and (value < high if high_open else value <= high)
    if not ok:
        raise ValueError(f"{name}={value!r} is outside the allowed range {interval}")


def check_int(name: str, value, low: int = 0) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is an integer (not a bool) >= ``low``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < low:
        raise ValueError(f"{name}={value!r} is outside the allowed range [{low}, inf)")


def check_bool(name: str, value) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is ``True`` or ``False`` (a YAML true/false)."""
    if not isinstance(value, bool):
        raise ValueError(f"{name}={value!r} must be true or false")


def is_real_number(value) -> bool:
    """True for a real number (Python or NumPy, int or float), False for bools and everything else."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def store_floats(obj, *names: str) -> None:
    """Store the named fields of a frozen dataclass as Python floats (NumPy scalars included), so
    that compiled kernels always see float64 arguments. Non-numbers are left for validation."""
    for name in names:
        value = getattr(obj, name)
        if is_real_number(value):
            object.__setattr__(obj, name, float(value))


@dataclass(frozen=True)
class Material:
    """A power-law graded elastic body, ``E(z) = E0 (z/c0)^k``.

    Attributes:
        youngs_modulus: E0 (Pa), in [1e3, 1e13]; ``math.inf`` makes the body rigid.
        poisson_ratio: nu (-), constant through the depth, in (-1, 0.5].
        grading_exponent: k (-), in [0, 1); k = 0 is a homogeneous body.
        reference_depth: c0 (m), the depth at which E = E0, in [1e-9, 1e3].
        h_normal_override: replaces the closed-form ``h_N(k, nu)`` (-) if given.
        h_tangential_override: replaces the closed-form ``h_T(k, nu)`` (-) if given.
    """

    youngs_modulus: float = 2e11
    poisson_ratio: float = 0.3
    grading_exponent: float = 0.0
    reference_depth: float = 1.0
    h_normal_override: float | None = None
    h_tangential_override: float | None = None

    def __post_init__(self) -> None:
        store_floats(self, "youngs_modulus", "poisson_ratio", "grading_exponent", "reference_depth",
                     "h_normal_override", "h_tangential_override")
        if self.youngs_modulus != _INF:
            check_range("Material.youngs_modulus", self.youngs_modulus, *BOUNDS["youngs_modulus"])
        check_range("Material.poisson_ratio", self.poisson_ratio, -1.0, 0.5, low_open=True)
        check_range("Material.grading_exponent", self.grading_exponent, 0.0, 1.0, high_open=True)
        check_range("Material.reference_depth", self.reference_depth, *BOUNDS["reference_depth"])
        for name in ("h_normal_override", "h_tangential_override"):
            value = getattr(self, name)
            if value is not None:
                check_range(f"Material.{name}", value, 0.0, low_open=True)

    @classmethod
    def rigid(cls) -> "Material":
        """A rigid body (E0 = inf)."""
        return cls(youngs_modulus=_INF)

    @property
    def is_rigid(self) -> bool:
        return self.youngs_modulus == _INF

    @property
    def h_normal(self) -> float:
        """h_N(k, nu) (-), or the override."""
        if self.h_normal_override is not None:
            return self.h_normal_override
        return materials.h_normal(self.grading_exponent, self.poisson_ratio)

    @property
    def h_tangential(self) -> float:
        """h_T(k, nu) (-), or the override."""
        if self.h_tangential_override is not None:
            return self.h_tangential_override
        return materials.h_tangential(self.grading_exponent, self.poisson_ratio)

    def normal_compliance(self) -> float:
        """``(1 - nu^2) / (h_N E0)`` (1/Pa); 0 for a rigid body."""
        return 0.0 if self.is_rigid else (1.0 - self.poisson_ratio**2) / (self.h_normal * self.youngs_modulus)

    def tangential_compliance(self) -> float:
        """``1 / (h_T E0)`` (1/Pa); 0 for a rigid body."""
        return 0.0 if self.is_rigid else 1.0 / (self.h_tangential * self.youngs_modulus)


@dataclass(frozen=True)
class Contact:
    """Indenter geometry and friction.

    Attributes:
        indenter_radius: R (m), radius of the paraboloid ``f(r) = r^2 / (2R)``, in [1e-7, 10].
        friction_coefficient: mu (-), indenter-slider Coulomb friction, in (0, 10].
        base_friction_coefficient: mu1 (-), slider-base friction, ``F_base = sgn(V) mu1 F_z``, in [0, 10].
    """

    indenter_radius: float = 2.5e-3
    friction_coefficient: float = 0.3
    base_friction_coefficient: float = 0.1

    def __post_init__(self) -> None:
        store_floats(self, "indenter_radius", "friction_coefficient", "base_friction_coefficient")
        check_range("Contact.indenter_radius", self.indenter_radius, *BOUNDS["indenter_radius"])
        check_range("Contact.friction_coefficient", self.friction_coefficient, *BOUNDS["friction_coefficient"],
                    low_open=True)
        check_range("Contact.base_friction_coefficient", self.base_friction_coefficient, *BOUNDS["friction_coefficient"])


@dataclass(frozen=True)
class Drive:
    """The slider and its cargo.

    Attributes:
        slider_mass: M (kg), finite and >= 1e-6; a huge mass (1e30) holds the slider still.
        cargo_mass: m (kg), in [0, 1e4]; it sets the load ``F_m = m g`` against the motion.
        gravity: g (m/s^2), in [0, 1e3].
        load_force: F_m (N), in [0, 1e6], if given, replacing ``m g``.
        cargo_inertia: if True the cargo also accelerates with the slider (moving mass M + m);
            the paper's choice is False (moving mass M).
    """

    slider_mass: float = 0.05
    cargo_mass: float = 0.0
    gravity: float = 9.81
    load_force: float | None = None
    cargo_inertia: bool = False

    def __post_init__(self) -> None:
        store_floats(self, "slider_mass", "cargo_mass", "gravity", "load_force")
        check_range("Drive.slider_mass", self.slider_mass, *BOUNDS["slider_mass"])
        check_range("Drive.cargo_mass", self.cargo_mass, *BOUNDS["cargo_mass"])
        check_range("Drive.gravity", self.gravity, *BOUNDS["gravity"])
        if self.load_force is not None:
            check_range("Drive.load_force", self.load_force, *BOUNDS["load_force"])
        if isinstance(self.cargo_inertia, np.bool_):
            object.__setattr__(self, "cargo_inertia", bool(self.cargo_inertia))
        check_bool("Drive.cargo_inertia", self.cargo_inertia)

    @property
    def load(self) -> float:
        """F_m (N), the constant force against the +X direction."""
        return self.cargo_mass * self.gravity if self.load_force is None else float(self.load_force)

    @property
    def moving_mass(self) -> float:
        """The mass (kg) in ``M X'' = F_x - F_base - F_m``."""
        return self.slider_mass + (self.cargo_mass if self.cargo_inertia else 0.0)


#: Model variants. ``as-specified`` is the model of docs/model.md; ``as-published``
#: is the hypothesis about the paper's own code (docs/paper_reproduction.md): h_N doubled, h_T as is.
VARIANTS: tuple[str, ...] = ("as-specified", "as-published")
#: Factor on h_N of each variant (h_T is never scaled).
VARIANT_H_NORMAL_FACTOR = {"as-specified": 1.0, "as-published": 2.0}


@dataclass(frozen=True)
class DriveParams:
    """The whole physical model: two bodies, the contact, the drive and the model variant.

    The bodies must share k and c0 unless one of them is rigid (docs/model.md). For a rigid
    indenter on a graded slider the normal-tangential coupling is neglected (it vanishes only at
    ``nu = 1/(2+k)``).

    Attributes:
        variant: ``"as-specified"`` (default), the model as derived; or ``"as-published"``, the
            hypothesis that the paper's code doubled h_N and kept h_T (the slip the paper admits for
            its predecessor). The factor applies to whatever h_N is in force, the closed form or
            ``Material.h_normal_override``, of each elastic body, so it doubles ``C_N`` (and the
            slip ratio) and leaves ``C_T``.
    """

    indenter: Material = field(default_factory=Material)
    slider: Material = field(default_factory=Material)
    contact: Contact = field(default_factory=Contact)
    drive: Drive = field(default_factory=Drive)
    variant: str = "as-specified"

    def __post_init__(self) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(f"DriveParams.variant={self.variant!r} is not one of {list(VARIANTS)}")
        if self.indenter.is_rigid and self.slider.is_rigid:
            raise ValueError("DriveParams: indenter and slider cannot both be rigid")
        if not (self.indenter.is_rigid or self.slider.is_rigid):
            for name in ("grading_exponent", "reference_depth"):
                a, b = getattr(self.indenter, name), getattr(self.slider, name)
                if a != b:
                    raise ValueError(f"DriveParams: indenter.{name}={a!r} and slider.{name}={b!r} must be equal")

    @classmethod
    def paper(cls, k: float = 0.0, cargo_mass: float = 0.0, variant: str = "as-specified") -> "DriveParams":
        """The paper's parameter set (both bodies of the same graded steel-like material)."""
        return cls(
            indenter=Material(grading_exponent=k),
            slider=Material(grading_exponent=k),
            drive=Drive(cargo_mass=cargo_mass),
            variant=variant,
        )

    @property
    def _graded(self) -> Material:
        return self.slider if self.indenter.is_rigid else self.indenter

    @property
    def k(self) -> float:
        """Grading exponent k (-) of the contact."""
        return self._graded.grading_exponent

    @property
    def c0(self) -> float:
        """Reference depth c0 (m)."""
        return self._graded.reference_depth

    @property
    def normal_stiffness_prefactor(self) -> float:
        """C_N (Pa) in ``c_N(x) = C_N (|x|/c0)^k`` (paper Eq. 3), times the variant's h_N factor."""
        factor = VARIANT_H_NORMAL_FACTOR[self.variant]
        return factor / (self.indenter.normal_compliance() + self.slider.normal_compliance())

    @property
    def tangential_stiffness_prefactor(self) -> float:
        """C_T (Pa) in ``c_T(x) = C_T (|x|/c0)^k`` (paper Eq. 4)."""
        return 1.0 / (self.indenter.tangential_compliance() + self.slider.tangential_compliance())

    @property
    def slip_ratio(self) -> float:
        """``lambda = mu C_N / C_T`` (-): a spring slips when ``|u_x| >= lambda u_z``."""
        return self.contact.friction_coefficient * self.normal_stiffness_prefactor / self.tangential_stiffness_prefactor

    def with_k(self, k: float) -> "DriveParams":
        """The same model with grading exponent k in every graded body."""
        return dataclasses.replace(
            self,
            indenter=self.indenter if self.indenter.is_rigid else dataclasses.replace(self.indenter, grading_exponent=k),
            slider=self.slider if self.slider.is_rigid else dataclasses.replace(self.slider, grading_exponent=k),
        )

    def with_cargo_mass(self, cargo_mass: float) -> "DriveParams":
        """The same model with another cargo mass m (kg) (and load m g)."""
        return dataclasses.replace(self, drive=dataclasses.replace(self.drive, cargo_mass=cargo_mass))


@dataclass(frozen=True)
class Numerics:
    """Discretisation of the solver.

    Attributes:
        time_step: dt (s) of the integration.
        spring_spacing: dx (m), the distance between MDR springs (``method="grid"``).
        method: ``"grid"``, the reference solver: springs uniform in x, the paper's ``sgn(V)``
            base friction; or ``"nodes"``, the fast solver: finite-element nodes uniform in the
            MDR profile g with closed-form weights, Coulomb stick at the base (core/fast_kernel.py).
        nodes: number of nodes of the fast solver (``method="nodes"``).
        max_x_step: largest indenter x motion per step (m) of the fast solver: steps shrink on
            fast edges. ``time_step`` is then the longest step.
        max_z_step: the same for z (m).
        node_power: node i sits at ``g_i = g_top (i / (nodes - 2))^node_power`` (-): 1 is uniform
            in g, 2 uniform in x; above 1, small contacts get more nodes.
    """

    time_step: float
    spring_spacing: float = 1e-7
    method: str = "grid"
    nodes: int = 64
    max_x_step: float = 1.0
    max_z_step: float = 1.0
    node_power: float = 1.0

    def __post_init__(self) -> None:
        store_floats(self, "time_step", "spring_spacing", "max_x_step", "max_z_step", "node_power")
        if isinstance(self.nodes, numbers.Integral) and not isinstance(self.nodes, (bool, np.bool_)):
            object.__setattr__(self, "nodes", int(self.nodes))
        check_range("Numerics.time_step", self.time_step, 0.0, 1e-4, low_open=True)
        check_range("Numerics.spring_spacing", self.spring_spacing, 0.0, 1e-5, low_open=True)
        if self.method not in ("grid", "nodes"):
            raise ValueError(f"Numerics.method={self.method!r} is not one of ['grid', 'nodes']")
        check_range("Numerics.max_x_step", self.max_x_step, 0.0, low_open=True)
        check_range("Numerics.max_z_step", self.max_z_step, 0.0, low_open=True)
        check_range("Numerics.node_power", self.node_power, 1.0, 3.0)
        if not isinstance(self.nodes, int) or isinstance(self.nodes, bool) or not 4 <= self.nodes <= 1_000_000:
            raise ValueError(f"Numerics.nodes={self.nodes!r} is outside the allowed range [4, 1000000]")


#: Named numerics presets. ``paper`` is the paper's exact discretisation; ``default`` is the
#: cheaper grid chosen from the convergence study (scripts/convergence.py, docs/numerics.md);
#: ``fast`` is the fast solver (scripts/bench_speed.py, docs/performance.md).
NUMERICS_PRESETS: dict[str, Numerics] = {
    "paper": Numerics(time_step=1e-7, spring_spacing=1e-8),
    "default": Numerics(time_step=1e-6, spring_spacing=1e-7),
    "fast": Numerics(time_step=5e-6, method="nodes", nodes=48, max_x_step=3e-7, max_z_step=1e-7, node_power=1.5),
}


def numerics_preset(name: str | Numerics) -> Numerics:
    """Look up a numerics preset by name (a ``Numerics`` passes through)."""
    if isinstance(name, Numerics):
        return name
    try:
        return NUMERICS_PRESETS[name]
    except KeyError:
        raise ValueError(f"numerics={name!r} is not one of {sorted(NUMERICS_PRESETS)}") from None
