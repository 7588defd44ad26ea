"""A drive description: the physical stage a policy is built for and judged on.

A drive is a set of ``MDRDrive-v0`` keywords (SI units); anything left out keeps the env's default,
the paper's drive (M = 50 g, R = 2.5 mm, steel, mu = 0.3, mu1 = 0.1, T = 2 ms, strokes 30 and 6 um).
A YAML file holds one (``agents/configs/drives/``, docs/your_drive.md)::

    slider_mass: 0.02          # kg
    indenter_radius: 1.5e-3    # m
    period: 1.0e-3             # s
    x_amplitude_max: 20.0e-6   # m
    z_amplitude_max: 4.0e-6    # m
    k: [0.0, 0.6]              # optional: the grading exponents its policy is built for and judged on
    load_ratio: [0.0, 0.55]    # optional: its loads, as fractions of mu F_ref (MDRDrive-v0's load_ratio)

``mdr-drive recipe``, ``evaluate`` and ``benchmark`` take it as ``--drive FILE``; a policy built for
it keeps its keywords in its ``run.json`` (``env_kwargs``) and plays on it wherever it is loaded.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mdr_drive_env.core import Waveform
from mdr_drive_env.core.params import check_int
from mdr_drive_env.gym_envs.spaces import ActionMap, sample_range

#: The keywords a drive description may set, with their units: the stage's physics and its strokes.
DRIVE_KEYS = {
    "slider_mass": "kg", "indenter_radius": "m", "youngs_modulus": "Pa (E0)", "poisson_ratio": "-",
    "reference_depth": "m (c0)", "rigid_indenter": "bool", "friction_coefficient": "- (mu, indenter-slider)",
    "base_friction_coefficient": "- (mu1, slider-base)", "gravity": "m/s^2", "cargo_inertia": "bool",
    "variant": "as-specified or as-published", "period": "s (T)", "x_amplitude_max": "m (full x stroke)",
    "z_amplitude_max": "m (full z stroke)",
}
#: The optional domain of a description: the k range and the load range (fractions of mu F_ref).
DOMAIN_KEYS = {"k": "- (low, high)", "load_ratio": "- (low, high), fractions of mu F_ref"}
#: The domain every policy of this package is built for unless a description says otherwise.
DEFAULT_K_RANGE = (0.0, 0.6)
DEFAULT_LOAD_RATIO_RANGE = (0.0, 0.55)
#: Why a drive needs mu > mu1 (the error every check of a friction pair gives).
WHY_MU_EXCEEDS_MU1 = ("the base holds the slider with mu1 times the contact's normal force and the contact pulls it "
                      "with at most mu times it, so no drive moves it forward")
#: The fewest time steps per period a search solver may take (``DriveDescription.search_steps_per_period``).
MIN_SEARCH_STEPS = 50


@dataclass(frozen=True)
class DriveDescription:
    """One drive: ``MDRDrive-v0`` keywords and the k and load ranges its policies cover.

    Attributes:
        settings: the keywords it sets (a sorted tuple of (name, value) pairs, names in ``DRIVE_KEYS``);
            empty for the paper's drive.
        k_range: (low, high) of the grading exponent k (-).
        load_ratio_range: (low, high) of the load as a fraction of mu F_ref (-).
        name: a label for tables and files (the YAML file's stem).
        search_steps_per_period: the node solver's longest time step for open-loop plays on this
            description (``numerics``) is the period over this (-; never shorter than the env's own
            step); None: the env's solver. The teacher's searches set it (``with_search_solver``); it
            is not part of what the drive is: descriptions that differ only in it compare equal.
    """

    settings: tuple = ()
    k_range: tuple[float, float] = DEFAULT_K_RANGE
    load_ratio_range: tuple[float, float] = DEFAULT_LOAD_RATIO_RANGE
    name: str = "paper"
    search_steps_per_period: int | None = dataclasses.field(default=None, compare=False)

    def __post_init__(self) -> None:
        settings = dict(self.settings)
        unknown = sorted(set(settings) - set(DRIVE_KEYS))
        if unknown:
            raise ValueError(f"drive key {unknown[0]!r} is not one of {sorted(DRIVE_KEYS) + sorted(DOMAIN_KEYS)}")
        object.__setattr__(self, "settings", tuple(sorted((k, _plain(v)) for k, v in settings.items())))
        object.__setattr__(self, "k_range", sample_range("k", self.k_range, 0.0, 1.0, high_open=True))
        object.__setattr__(self, "load_ratio_range", sample_range("load_ratio", self.load_ratio_range, 0.0, 10.0))
        if self.search_steps_per_period is not None:
            check_int("search_steps_per_period", self.search_steps_per_period, MIN_SEARCH_STEPS)
        contact = template(self.settings).params_for(0.0, 0.0).contact  # the env validates every value
        mu, mu1 = contact.friction_coefficient, contact.base_friction_coefficient
        if mu <= mu1:  # M X'' = F_x - mu1 F_z - F_m with |F_x| <= mu F_z: never a forward push (docs/model.md)
            raise ValueError(f"friction_coefficient={mu!r} must exceed base_friction_coefficient={mu1!r}: "
                             f"{WHY_MU_EXCEEDS_MU1}")

    @classmethod
    def from_mapping(cls, mapping: dict, name: str = "drive") -> "DriveDescription":
        """A description from a mapping of ``DRIVE_KEYS`` and, optionally, ``k`` and ``load_ratio``."""
        if not isinstance(mapping, dict):
            raise ValueError(f"a drive description is a mapping of MDRDrive-v0 keywords, not {type(mapping).__name__}")
        mapping = {key: _number(value) if key != "variant" else value for key, value in mapping.items()}
        k = mapping.pop("k", DEFAULT_K_RANGE)
        load = mapping.pop("load_ratio", DEFAULT_LOAD_RATIO_RANGE)
        return cls(tuple(mapping.items()), k, load, name)

    @classmethod
    def load(cls, path: str | Path) -> "DriveDescription":
        """The description in the YAML file ``path``; a one-line ``ValueError`` naming the file for a
        missing file, bad YAML, an unknown key or a bad value."""
        from .yaml_config import read_yaml

        data = read_yaml(path)
        try:
            return cls.from_mapping(data, Path(path).stem)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None

    @classmethod
    def from_env_kwargs(cls, env_kwargs: dict, name: str = "drive") -> "DriveDescription":
        """The drive an env's keywords describe (a policy's run.json ``env_kwargs``): its ``DRIVE_KEYS``."""
        return cls(tuple((k, v) for k, v in env_kwargs.items() if k in DRIVE_KEYS), name=name)

    # --- what it is ---
    @property
    def env_kwargs(self) -> dict:
        """Its ``MDRDrive-v0`` keywords (the drive's physics and strokes; not its ranges)."""
        return dict(self.settings)

    def to_mapping(self) -> dict:
        """The mapping ``from_mapping`` reads back (for YAML and run.json)."""
        return {**self.env_kwargs, "k": list(self.k_range), "load_ratio": list(self.load_ratio_range)}

    def to_record(self) -> dict:
        """The named mapping a file keeps (run.json's, recipe.json's, blind.json's ``drive``, a teacher
        field's meta): ``to_mapping`` with ``name``."""
        return {"name": self.name, **self.to_mapping()}

    @classmethod
    def from_record(cls, record: dict) -> "DriveDescription":
        """The description ``to_record`` wrote."""
        record = dict(record)
        return cls.from_mapping(record, record.pop("name", "drive"))

    @property
    def is_paper(self) -> bool:
        """Whether it is the paper's drive: the same physical model and action map as the env's defaults."""
        paper = template(())
        return (self.action_map() == paper.action_map
                and template(self.settings).params_for(0.2, 0.0) == paper.params_for(0.2, 0.0))

    def with_search_solver(self, steps_per_period: int | None) -> "DriveDescription":
        """The same drive, its open-loop plays (``numerics``) run with the node solver's longest step
        the period over ``steps_per_period`` (never shorter than the env's own; None: the env's solver)."""
        return dataclasses.replace(self, search_steps_per_period=steps_per_period)

    def with_settings(self, **settings) -> "DriveDescription":
        """The same description with ``settings`` added or replaced."""
        return dataclasses.replace(self, settings=tuple({**self.env_kwargs, **settings}.items()))

    # --- derived quantities ---
    @property
    def period(self) -> float:
        """T (s)."""
        return self.action_map().period

    @property
    def z_amplitude_max(self) -> float:
        """The full z stroke (m): the deepest indentation any action makes."""
        return self.action_map().z_amplitude_max

    @property
    def stroke_speed(self) -> float:
        """The full x stroke over the period (m/s): the drive's velocity scale (15 mm/s for the paper's).
        The recipe's velocity thresholds are fractions of it, so they carry over to another drive."""
        amap = self.action_map()
        return amap.x_amplitude_max / amap.period

    def action_map(self, time_quantum: float | None = None) -> ActionMap:
        """The env's action map on this drive, with rises and the z phase quantised to ``time_quantum``
        (s; default the env's)."""
        return _action_map(self.settings, None if time_quantum is None else float(time_quantum))

    @property
    def numerics(self):
        """The fast-solver numerics of open-loop plays on this drive (``Numerics``): the env's (the preset,
        its longest time step shortened on periods under 1 ms so the waveform's shortest edge spans 10
        steps), with the longest step the period over ``search_steps_per_period`` where that is longer."""
        env = template(self.settings).numerics
        if self.search_steps_per_period is None:
            return env
        return dataclasses.replace(env, time_step=max(env.time_step, self.period / self.search_steps_per_period))

    @property
    def indenter_min_velocity(self) -> float:
        """The fastest backward x stroke any action can make (m/s): full stroke over the shortest fall."""
        amap = self.action_map()
        return -amap.x_amplitude_max / ((1.0 - amap.max_rise_fraction) * amap.period)

    def trapezoid_action(self, time_quantum: float | None = None) -> np.ndarray:
        """The baseline's action (float64): the paper's waveform shape (Fig. 2, its rise fractions and
        phase) at this drive's period and full strokes; for the paper's drive its waveform exactly."""
        amap = self.action_map(time_quantum)  # as the env's trapezoid_action, in float64 and at time_quantum
        return amap.to_action(Waveform.paper(amap.period, amap.x_amplitude_max, amap.z_amplitude_max))

    def params(self, k: float, cargo_mass: float, friction: tuple[float, float] | None = None):
        """The physical model (``DriveParams``) at grading exponent k and cargo mass (kg), with
        ``friction`` = (mu, mu1) instead of the drive's own if given (a pair drawn over ranges: its nominal
        values, ``nominal_friction``)."""
        env = template(self.settings)
        params = env.params_for(float(k), float(cargo_mass))
        if friction is None and (env.friction_range[0] != env.friction_range[1]
                                 or env.base_friction_range[0] != env.base_friction_range[1]):
            friction = self.nominal_friction
        if friction is None:
            return params
        return dataclasses.replace(params, contact=dataclasses.replace(
            params.contact, friction_coefficient=float(friction[0]), base_friction_coefficient=float(friction[1])))

    @property
    def nominal_friction(self) -> tuple[float, float]:
        """(mu, mu1), the friction coefficients the drive is evaluated at unless told otherwise (-): each
        as the drive sets it, the middle of its range where it is drawn per episode (a sensor policy's
        drive: ``MDRDriveSensor-v0``'s ranges are centred on the paper's 0.3 and 0.1)."""
        env = template(self.settings)
        return (round(float(np.mean(env.friction_range)), 12),
                round(float(np.mean(env.base_friction_range)), 12))

    @property
    def stage_settings(self) -> tuple:
        """``settings`` with a friction pair drawn over ranges (a sensor policy's drive) at its nominal values
        (``nominal_friction``), and a value equal to the paper drive's left out: two descriptions with the
        same stage settings describe one stage, whichever of its policies, told or sensor, records them."""
        settings = dict(self.settings)
        defaults = template(())
        for key, nominal, default in zip(("friction_coefficient", "base_friction_coefficient"), self.nominal_friction,
                                         (defaults.friction_range[0], defaults.base_friction_range[0])):
            if key in settings:
                settings[key] = nominal
                if nominal == default:
                    del settings[key]
        return tuple(sorted(settings.items()))

    def sensor_env_kwargs(self) -> dict:
        """The ``MDRDriveSensor-v0`` keywords of a sensor policy on this drive: its physics and strokes,
        with k drawn over its k range, the load over its load range up to ``SENSOR_DEFAULTS``' 0.4 of
        mu F_ref, and the friction pair over the ranges the description sets for it or, where it sets one
        value, over ``SENSOR_DEFAULTS``' relative spread around it (x 2/3 to 4/3 for mu, x 0.7 to 1.3 for
        mu1: the paper drive's 0.2-0.4 and 0.07-0.13). ``ValueError`` where the ranges let mu fall to mu1."""
        from mdr_drive_env import SENSOR_DEFAULTS

        env = template(self.settings)
        paper = template(())
        ranges = {}
        for name, own, nominal in (("friction_coefficient", env.friction_range, paper.friction_range[0]),
                                   ("base_friction_coefficient", env.base_friction_range, paper.base_friction_range[0])):
            if own[0] != own[1]:
                ranges[name] = list(own)
            else:
                ranges[name] = [round(own[0] * bound / nominal, 12) for bound in SENSOR_DEFAULTS[name]]
        if ranges["friction_coefficient"][0] <= ranges["base_friction_coefficient"][1]:
            raise ValueError(f"{self.name}: the sensor policy's friction ranges mu {ranges['friction_coefficient']} and "
                             f"mu1 {ranges['base_friction_coefficient']} overlap: {WHY_MU_EXCEEDS_MU1} (set narrower "
                             "ranges as [low, high] in the drive file)")
        load_high = SENSOR_DEFAULTS["load_ratio"][1]
        load = [min(self.load_ratio_range[0], load_high), min(self.load_ratio_range[1], load_high)]
        return {**self.env_kwargs, **{key: list(v) if isinstance(v, tuple) else v for key, v in SENSOR_DEFAULTS.items()},
                "k": list(self.k_range), "load_ratio": load, **ranges}

    def reference_force(self, k: float, friction_coefficient: float | None = None) -> float:
        """mu F_ref (N) at k: the largest friction force the contact transmits at the full z stroke."""
        env = template(self.settings)
        p = self.params(k, 0.0)
        mu = p.contact.friction_coefficient if friction_coefficient is None else friction_coefficient
        return mu * env.reference_force(p)

    def __str__(self) -> str:
        shown = ", ".join(f"{k}={v}" for k, v in self.settings) or "the paper's"
        return f"{self.name} ({shown}; k {self.k_range[0]:g}-{self.k_range[1]:g})"


def _number(value):
    """A YAML value, with a number YAML 1.1 reads as a string (``3.0e11``, without the exponent's sign) as a float."""
    if isinstance(value, list):
        return [_number(v) for v in value]
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _plain(value):
    """A YAML or NumPy value as a plain, hashable Python value (lists as tuples)."""
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    if isinstance(value, np.generic):
        return value.item()
    return value


@functools.lru_cache(maxsize=32)
def template(settings: tuple):
    """An ``MDRDriveEnv`` (unwrapped, never stepped) with the drive ``settings``: the one home of how
    keywords become a physical model and an action map."""
    from mdr_drive_env.gym_envs.mdr_drive import MDRDriveEnv

    try:
        return MDRDriveEnv(**dict(settings))
    except TypeError as e:
        raise ValueError(f"drive: {e}") from None


@functools.lru_cache(maxsize=64)
def _action_map(settings: tuple, time_quantum: float | None) -> ActionMap:
    amap = template(settings).action_map
    return amap if time_quantum is None else dataclasses.replace(amap, time_quantum=time_quantum)


#: The paper's drive: every keyword at the env's default.
PAPER_DRIVE = DriveDescription()

__all__ = ["DEFAULT_K_RANGE", "DEFAULT_LOAD_RATIO_RANGE", "DOMAIN_KEYS", "DRIVE_KEYS", "DriveDescription", "PAPER_DRIVE",
           "WHY_MU_EXCEEDS_MU1", "template"]
