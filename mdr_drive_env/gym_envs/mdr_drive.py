"""MDRDrive-v0: learn the drive waveform of a stick-slip piezo micro-drive, one period per step."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..core import Contact, Drive, DriveParams, DriveSimulator, Material, numerics_preset
from ..core.materials import normal_force_analytic
from ..core.params import VARIANTS, is_real_number
from ..core.simulator import step_resolving_edge
from ..core.waveform import Waveform
from .sensor import (DEFAULT_ENCODER_NOISE, DEFAULT_FORCE_NOISE, DEFAULT_TRACE_SAMPLES, SensorHistory, SensorTier,
                     sample_positions)
from .spaces import (ActionMap, ObservationLayout, PrivilegedLayout, SensorLayout, codebook_rows,
                     load_action_codebook, sample_range, shortest_edge)


#: The observation modes (``observation=``) and their layouts; the sensor layout depends on ``history``.
OBSERVATIONS = {"full": ObservationLayout, "sensor": SensorLayout, "privileged": PrivilegedLayout}
#: Observation bounds as Python floats (ObservationLayout's, for the env's per-step clip).
_OBS_BOUNDS = (ObservationLayout.low.astype(float).tolist(), ObservationLayout.high.astype(float).tolist())
#: Periods per episode unless ``max_periods`` says otherwise.
DEFAULT_MAX_PERIODS = 50


def make_env(**kwargs) -> gym.Env:
    """The registered entry point of ``MDRDrive-v0``: :class:`MDRDriveEnv` in a ``TimeLimit`` of its
    own ``max_periods``, so that ``env.spec.max_episode_steps`` is the episode length whatever
    ``max_periods`` the caller passed to ``gym.make``."""
    from gymnasium.wrappers import TimeLimit

    env = MDRDriveEnv(**kwargs)
    return TimeLimit(env, env.max_periods)


def sensor_kwargs(kwargs: dict) -> dict:
    """``MDRDriveSensor-v0``'s keywords: ``mdr_drive_env.SENSOR_DEFAULTS`` for every one the caller
    leaves out; a ``cargo_mass`` given sets the load (the default ``load_ratio`` range then does not
    apply, so ``gym.make("MDRDriveSensor-v0", cargo_mass=0.1)`` has that cargo)."""
    from .. import SENSOR_DEFAULTS

    defaults = dict(SENSOR_DEFAULTS)
    if kwargs.get("cargo_mass") is not None:
        defaults.pop("load_ratio")
    return {**defaults, **kwargs}


def make_sensor_env(**kwargs) -> gym.Env:
    """The registered entry point of ``MDRDriveSensor-v0``: :func:`make_env` with :func:`sensor_kwargs`."""
    return make_env(**sensor_kwargs(kwargs))


def _draw(rng: np.random.Generator, low_high: tuple[float, float]) -> float:
    """A uniform draw from ``(low, high)``, or ``low`` without a draw if the range is one value (so
    fixed values leave the seeded stream of draws as it was)."""
    return low_high[0] if low_high[0] == low_high[1] else float(rng.uniform(*low_high))


class MDRDriveEnv(gym.Env):
    """
    ## Description

    A slider of mass M lies on a fixed base and carries a cargo load ``F_m = m g`` pulling it
    backwards (-X). An indenter of power-law graded material, ``E(z) = E0 (z/c0)^k``, oscillates
    horizontally (x) and vertically (z) and drags the slider forward by friction. The contact is the
    Method of Dimensionality Reduction (MDR) model of Lyashenko, Borysiuk & Popov (2020). Each step
    simulates one drive period ``T`` (default 2 ms) with the waveform the action chooses; the goal is
    to move the slider forward (+X) against the load as fast as possible.

    ## Action Space

    ``Box(-1, 1, (5,), float32)``, mapped affinely to the next period's waveform
    (``value = low + (a + 1) / 2 (high - low)``):

    | index | waveform parameter | range (defaults) |
    |---|---|---|
    | 0 | x amplitude | [0, ``x_amplitude_max``] = [0, 30 µm] |
    | 1 | x rise fraction t1/T (slow forward stroke; the fall is the rest) | [0.05, 0.95] |
    | 2 | z amplitude (maximum indentation depth) | [0, ``z_amplitude_max``] = [0, 6 µm] |
    | 3 | z rise fraction | [0.05, 0.95] |
    | 4 | z phase delay, fraction of T | [``z_phase_origin``, ``z_phase_origin`` + 1), modulo 1 |

    The z phase is periodic, so action -1 and +1 select the same phase, ``z_phase_origin`` (default
    0: the paper's phase at both ends of the box). Drives whose best phase lies just either side of
    that seam have actions 2 apart for waveforms that are close; ``z_phase_origin=0.5`` puts phase 0
    at action 0 and the seam half a period away. A policy's ``run.json`` keeps the value it was
    trained with, and ``mdr-drive evaluate`` plays it in such an env.

    Rise fractions and the phase are quantised to ``time_quantum`` (default 10 µs, 1/200 of T), so
    corners fall on the time steps of every numerics preset. The steady velocity is then a step
    function of the action: near the critical load one quantum can decide whether the slider moves,
    so a policy whose output is off by a few thousandths of the box can stall where the drive it
    imitates moves. ``time_quantum=5e-6`` halves the steps (any multiple of the numerics time step
    that divides the period is allowed; a policy's ``run.json`` keeps it, and ``mdr-drive evaluate``
    plays it in such an env). Actions outside the box are clipped; a non-finite action raises
    ``ValueError``. ``env.unwrapped.trapezoid_action()`` is the baseline: the paper's waveform
    (Fig. 2) exactly, or for another ``period`` or strokes its shape at that period and the full
    strokes ``x_amplitude_max``, ``z_amplitude_max``.

    **Codebook actions** (``action_codebook=``, an (N, 5) table of Box actions or the path of a
    ``.npy`` file holding one): ``Discrete(N)`` instead, action i plays the table's row i. The
    observation is unchanged (its previous-action entries hold the row played). For a policy that
    picks whole drives from a fixed set instead of regressing one (a codebook student,
    ``distill.action_codebook``, picks among its teacher grid's drives; ``action_codebook.npy``
    beside its ``model.zip``).

    Waveforms stay continuous across period boundaries: x starts and ends every period at 0; if a
    new z amplitude or phase makes z start at another depth than the last period ended, the jump is
    ramped out linearly over the new z triangle's shorter edge (``core.waveform.period_knots``).

    ## Observation Space

    ``Box(float32)`` of 14 entries, each normalised to order one and clipped to its bounds:

    | index | entry | unit and scale | bounds |
    |---|---|---|---|
    | 0 | displacement over the last period | m / ``reward_scale`` | [-100, 100] |
    | 1 | mean slider velocity over the last period | m/s / (``reward_scale`` / T) | [-100, 100] |
    | 2 | slider velocity at the period end | m/s / (``reward_scale`` / T) | [-100, 100] |
    | 3 | peak tangential force F_x of the last period | N / (mu F_ref) | [0, 2] |
    | 4 | peak normal force F_z of the last period | N / F_ref | [0, 2] |
    | 5-9 | previous action | - | [-1, 1] |
    | 10 | grading exponent k | - | [0, 1] |
    | 11 | load F_m | N / (mu F_ref) | [0, 100] |
    | 12 | load F_m | N / 10 N | [0, 100] |
    | 13 | fraction of the episode elapsed | - | [0, 1] |

    ``F_ref`` is the analytic normal force (paper Eq. 8) at the largest allowed depth
    ``z_amplitude_max`` for the episode's k, so entry 11 is the load against the largest friction
    force the contact can transmit. The first observation after ``reset`` has zeros in 0-9.
    ``env.unwrapped.observation_structure`` names the entries' slices (``"k"``, ``"dynamics"``, ...),
    so callers never hard-code indices.

    **Sensor observation** (``observation="sensor"``, and ``MDRDriveSensor-v0``): only what a position
    encoder on the slider measures, for a drive that knows neither its load nor its material nor its
    friction. For each of the last ``history`` periods (default 4, newest first): the displacement
    (/ ``reward_scale``), the mean and the end-of-period velocity (/ (``reward_scale`` / T)), bounds
    [-100, 100]; then the action of each of those periods, [-1, 1]; last the fraction of the episode
    elapsed, [0, 1]: ``8 history + 1`` entries (33 by default). Not k, not the load, not the
    friction coefficients, not the contact forces: a real drive measures none of them (the
    forces would need a force sensor in the contact, and any scale taken from the contact model
    would give k away). ``sensor_forces=True`` adds the peak F_x / 10 N and peak F_z / 100 N of each
    period, bounds [0, 100], for a drive with a force sensor. ``observation_structure`` has
    ``"measured"``, ``"actions"``, ``"episode_fraction"``.

    **Sensor tiers** (``sensor_tier``, with the sensor observation): ``"encoder"`` (the default) is
    the above, noise-free. ``"trace"`` adds per period the slider's position at ``trace_samples``
    (default 40) evenly spaced times, the last at the period's end, relative to its position at the
    period's start (/ ``reward_scale``, bounds [-100, 100]), each sample with Gaussian noise of
    ``encoder_noise`` (default 2e-9 m): a laboratory interferometer or capacitive sensor at about
    20 kHz (an integrated optical encoder at about 1 kHz would give ``trace_samples=2``).
    ``"self-sensing"`` also adds the peak F_x and F_z as ``sensor_forces`` does, sensed by the piezo
    from its own charge, each with Gaussian noise of ``force_noise`` (default 0.02) times the force.
    The noise is drawn from a stream seeded by the episode's: ``reset(seed=...)`` reproduces it, and
    the episode's draws are those of the other tiers. ``info`` still reports the hidden values
    (``k``, ``cargo_mass``, ``load_force``, ``friction_coefficient``, ``base_friction_coefficient``,
    ``load_step_period``), for evaluation, and ``env.unwrapped.privileged_observation()`` returns
    the full observation of the current state (with the load of the coming period, the new one when
    a load step falls on it): what a privileged teacher is told while a sensor policy learns
    (docs/adaptation.md).

    **Privileged observation** (``observation="privileged"``): the full observation and then the
    episode's friction ratio mu1 / mu, entry 14 (-), bounds [0, 10]
    (``observation_structure["friction_ratio"]``). For a teacher trained with friction drawn per
    episode: the full observation gives the load over mu F_ref, on which the drive depends at a
    given ratio mu1 / mu, but not that ratio, on which it depends much; mu itself follows from the
    load entries and k. The slider's motion tells the ratio, not mu and mu1 apart.
    ``privileged_observation(friction=True)`` returns it from any env.

    ## Rewards

    ``reward = max(displacement / reward_scale - actuation_penalty * effort, reward_floor)`` per
    period, where the displacement (m) is positive against the load and ``reward_scale`` defaults
    to 30 µm, the paper's x stroke. At k = 0, m = 0.1 kg the trapezoid moves the slider 23.29 µm in
    its first period (reward 0.78) and 30.41 µm per period once settled (reward 1.01)
    (``mdr-drive simulate --k 0 --cargo-mass 0.1 --periods 30``, displacement column / 30 µm).
    ``effort = ((A_x / A_x,max)^2 + (A_z / A_z,max)^2) / 2`` in [0, 1] is an electrical-energy proxy
    (a piezo stack's energy per cycle grows with the square of its stroke); the penalty is off by
    default. ``reward_floor`` (default None: no floor) clamps each period's reward from below: a
    slider the load drags back fast (hundreds of mm/s, rewards of -10 to -1000 per period) would
    otherwise dominate the returns a learner sees; the training recipe uses -2.

    ## Starting State

    Slider at rest at X = 0, indenter at x = z = 0 (no contact), springs unloaded. By default every
    episode has k = 0.2 and a cargo of m = 0.1 kg. k and the cargo mass are drawn uniformly from
    their ranges (if given as ``(low, high)``) with the env's seeded generator, or set for one
    episode by ``reset(options={"k": ..., "cargo_mass": ...})`` (or ``"load_ratio"`` instead of
    ``"cargo_mass"``, a value or a range). With ``load_ratio`` the load is drawn instead as a
    fraction of ``mu F_ref`` (observation entry 11), which puts the working range of every k in
    the same interval (the paper's trapezoid stalls at a ratio of 0.18 to 0.33 over k at mu = 0.3).
    ``reset(options={"load_step": (period, cargo_mass)})`` sets one episode's load step (below).
    ``friction_coefficient`` and ``base_friction_coefficient`` may be ranges too, drawn per episode
    (after k, before the load; fixed values draw nothing), or set for one episode by reset options
    of those names. With ``load_step_period`` (a period index
    or a range of them, in [1, max_periods - 1]) the cargo changes once per episode: before the
    period with that index is simulated, the load jumps to a new value drawn like the first (a cargo
    picked up or set down); ``info["load_step_period"]`` says when, ``info["cargo_mass"]`` what.
    ``MDRDriveSensor-v0`` draws k in [0, 0.6], the load ratio in [0, 0.4] (about 1.25 times the
    trapezoid's critical load), mu in [0.2, 0.4] and mu1 in [0.07, 0.13], without a load step unless
    ``load_step_period`` is given; any of them given to ``gym.make`` replaces its default (a
    ``cargo_mass`` replaces the load-ratio range).

    ## Episode End

    Truncation after ``max_periods`` steps (default 50, i.e. 0.1 s), ``truncated=True``;
    ``gym.make`` wraps the env in a ``TimeLimit`` of the same length, so ``env.spec.max_episode_steps``
    is ``max_periods``. Set the length with ``max_periods`` (gym.make's ``max_episode_steps`` can only
    shorten it, and then observation entry 13 does not reach 1). The drive has no absorbing failure
    state, so ``terminated`` is always False: a slider dragged back by its load keeps earning
    negative reward until the episode is truncated.

    ## Arguments

    ``gym.make("MDRDrive-v0", **kwargs)`` with flat keyword arguments (SI units):
    ``k`` (float or (low, high); default 0.2), ``cargo_mass`` (kg, float or (low, high); default 0.1), ``load_ratio`` (float or
    (low, high), replaces ``cargo_mass`` when given: ``m g = ratio mu F_ref``), ``youngs_modulus`` (Pa),
    ``poisson_ratio``, ``reference_depth`` (m), ``rigid_indenter`` (bool), ``indenter_radius`` (m),
    ``friction_coefficient``, ``base_friction_coefficient``, ``slider_mass`` (kg), ``gravity``
    (m/s^2), ``cargo_inertia`` (bool), ``variant`` (``"as-specified"``, the default, or
    ``"as-published"``: h_N doubled, the hypothesis about the paper's code), ``numerics`` (preset name: ``"fast"``, the default node
    solver, see docs/performance.md; ``"default"`` or ``"paper"`` for the reference solver; on a period whose
    shortest edge is under 10 of the preset's time steps, such as the fast solver's 5 µs on periods under 1 ms,
    the step is divided by the smallest whole number that makes it 10: ``env.unwrapped.numerics``), ``period`` (s), ``max_periods``,
    ``x_amplitude_max`` (m), ``z_amplitude_max`` (m), ``min_rise_fraction``,
    ``max_rise_fraction``, ``z_phase_origin`` (fraction of T, in [0, 1)), ``time_quantum`` (s), ``reward_scale`` (m), ``actuation_penalty``, ``reward_floor``, ``observation``
    (``"full"``, the default, ``"sensor"`` or ``"privileged"``), ``history`` (periods in the sensor observation),
    ``sensor_forces`` (bool), ``sensor_tier`` (``"encoder"``, ``"trace"`` or ``"self-sensing"``),
    ``trace_samples``, ``encoder_noise`` (m), ``force_noise``, ``load_step_period`` (int or (low, high), or None), ``action_codebook``
    ((N, 5) array or ``.npy`` path, or None), ``render_mode``
    (``"rgb_array"`` or ``"human"``). ``friction_coefficient`` and ``base_friction_coefficient`` take
    a float or a (low, high) range. Bad values raise ``ValueError`` naming the argument.

    ## Version History

    * v0: initial version; later within v0: the sensor observation, friction ranges, load steps,
      ``MDRDriveSensor-v0``, the privileged observation (one friction entry, the ratio mu1 / mu,
      where it first had mu and mu1), ``z_phase_origin``, ``time_quantum``, ``action_codebook`` and
      the sensor tiers (the full observation, the action map and the defaults are unchanged).
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __init__(
        self,
        k: float | tuple[float, float] = 0.2,
        cargo_mass: float | tuple[float, float] = 0.1,
        load_ratio: float | tuple[float, float] | None = None,
        youngs_modulus: float = 2e11,
        poisson_ratio: float = 0.3,
        reference_depth: float = 1.0,
        rigid_indenter: bool = False,
        indenter_radius: float = 2.5e-3,
        friction_coefficient: float | tuple[float, float] = 0.3,
        base_friction_coefficient: float | tuple[float, float] = 0.1,
        slider_mass: float = 0.05,
        gravity: float = 9.81,
        cargo_inertia: bool = False,
        variant: str = "as-specified",
        numerics: str = "fast",
        period: float = 2e-3,
        max_periods: int = DEFAULT_MAX_PERIODS,
        x_amplitude_max: float = 30e-6,
        z_amplitude_max: float = 6e-6,
        min_rise_fraction: float = 0.05,
        max_rise_fraction: float = 0.95,
        z_phase_origin: float = 0.0,
        time_quantum: float = 1e-5,
        reward_scale: float = 30e-6,
        actuation_penalty: float = 0.0,
        reward_floor: float | None = None,
        observation: str = "full",
        history: int = 4,
        sensor_forces: bool = False,
        sensor_tier: str = "encoder",
        trace_samples: int = DEFAULT_TRACE_SAMPLES,
        encoder_noise: float = DEFAULT_ENCODER_NOISE,
        force_noise: float = DEFAULT_FORCE_NOISE,
        load_step_period: int | tuple[int, int] | None = None,
        action_codebook=None,
        render_mode: str | None = None,
    ):
        self.k_range = sample_range("k", k, 0.0, 1.0, high_open=True)
        self.cargo_mass_range = sample_range("cargo_mass", cargo_mass, 0.0, math.inf)
        self.load_ratio_range = None if load_ratio is None else sample_range("load_ratio", load_ratio, 0.0, 10.0)
        self._material = Material(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                                  reference_depth=reference_depth)
        self.rigid_indenter = bool(rigid_indenter)
        self.friction_range = sample_range("friction_coefficient", friction_coefficient, 0.0, math.inf)
        self.base_friction_range = sample_range("base_friction_coefficient", base_friction_coefficient, 0.0, math.inf)
        self._contact = Contact(indenter_radius=indenter_radius, friction_coefficient=self.friction_range[0],
                                base_friction_coefficient=self.base_friction_range[0])  # validates the low ends
        self._drive = Drive(slider_mass=slider_mass, gravity=gravity, cargo_inertia=bool(cargo_inertia))
        if variant not in VARIANTS:
            raise ValueError(f"variant={variant!r} is not one of {list(VARIANTS)}")
        self.variant = variant
        preset = numerics_preset(numerics)
        if isinstance(max_periods, bool) or not (isinstance(max_periods, (int, np.integer)) and max_periods >= 1):
            raise ValueError(f"max_periods={max_periods!r} is outside the allowed range [1, inf)")
        for name, value in (("reward_scale", reward_scale), ("period", period)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name}={value!r} is outside the allowed range (0, inf)")
        if not (isinstance(actuation_penalty, (int, float)) and math.isfinite(actuation_penalty)
                and actuation_penalty >= 0):
            raise ValueError(f"actuation_penalty={actuation_penalty!r} is outside the allowed range [0, inf)")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r} is not one of {self.metadata['render_modes']}")
        if reward_floor is not None and not (isinstance(reward_floor, (int, float)) and math.isfinite(reward_floor)):
            raise ValueError(f"reward_floor={reward_floor!r} is outside the allowed range (-inf, inf) or None")
        self.reward_floor = None if reward_floor is None else float(reward_floor)
        # periods under 1 ms: the preset's longest step shortened so the shortest edge spans 10 steps
        rises = (min_rise_fraction, max_rise_fraction)
        self.numerics = preset if not all(is_real_number(v) for v in rises) else dataclasses.replace(
            preset, time_step=step_resolving_edge(preset.time_step, shortest_edge(float(period), *map(float, rises))))
        self.max_periods = int(max_periods)
        self.reward_scale = float(reward_scale)
        self.actuation_penalty = float(actuation_penalty)
        self.render_mode = render_mode
        self.action_map = ActionMap(period=float(period), x_amplitude_max=x_amplitude_max,
                                    z_amplitude_max=z_amplitude_max, min_rise_fraction=min_rise_fraction,
                                    max_rise_fraction=max_rise_fraction, time_step=self.numerics.time_step,
                                    time_quantum=float(time_quantum), z_phase_origin=z_phase_origin)
        self.action_codebook = load_action_codebook(action_codebook)
        self.action_space = (spaces.Box(-1.0, 1.0, shape=(ActionMap.SIZE,), dtype=np.float32)
                             if self.action_codebook is None else spaces.Discrete(len(self.action_codebook)))
        if observation not in OBSERVATIONS:
            raise ValueError(f"observation={observation!r} is not one of {list(OBSERVATIONS)}")
        self.observation = observation
        tier = SensorTier(sensor_tier, trace_samples, encoder_noise, force_noise)
        if tier.traced and trace_samples > self.action_map.steps_per_period:
            raise ValueError(f"trace_samples={trace_samples!r} is outside the allowed range [1, "
                             f"{self.action_map.steps_per_period}] (the period's time steps)")
        if tier.name != "encoder" and observation != "sensor":
            raise ValueError(f"sensor_tier={sensor_tier!r} needs observation='sensor' (MDRDriveSensor-v0)")
        self.sensor = None
        if observation == "sensor":
            layout = SensorLayout(history, sensor_forces or tier.name == "self-sensing",
                                  trace_samples if tier.traced else 0)
            self.sensor = SensorHistory(layout, tier)
        self._noise_rng: np.random.Generator | None = None
        layout = self.sensor.layout if self.sensor else OBSERVATIONS[observation]
        self.observation_space = spaces.Box(layout.low, layout.high, dtype=np.float32)
        self.observation_structure: dict[str, slice] = dict(layout.structure)
        self.load_step_range = None
        if load_step_period is not None:
            self.load_step_range = tuple(int(v) for v in sample_range("load_step_period", load_step_period, 1,
                                                                      self.max_periods - 1))
        self.sim: DriveSimulator | None = None
        self.last_trace: np.ndarray | None = None
        self._renderer = None
        self.params_for(self.k_range[1], self.cargo_mass_range[1])  # the heaviest model: bad values fail here, not at reset

    # --- helpers ---
    def params_for(self, k: float, cargo_mass: float, contact: Contact | None = None) -> DriveParams:
        """The physical model for one episode (``contact``: this episode's friction, default the low
        ends of the friction ranges)."""
        graded = dataclasses.replace(self._material, grading_exponent=k)
        return DriveParams(indenter=Material.rigid() if self.rigid_indenter else graded, slider=graded,
                           contact=contact or self._contact,
                           drive=dataclasses.replace(self._drive, cargo_mass=cargo_mass), variant=self.variant)

    def sample_episode(self, rng: np.random.Generator, options: dict[str, Any] | None = None):
        """(k, cargo mass, DriveParams) of a new episode: from ``options`` or drawn from the ranges."""
        options = {key: v for key, v in (options or {}).items() if key != "load_step"}  # reset() reads load_step
        unknown = set(options) - {"k", "cargo_mass", "load_ratio", "friction_coefficient", "base_friction_coefficient"}
        if unknown:
            raise ValueError(f"reset options {sorted(unknown)} are not supported (use 'k', 'cargo_mass', "
                             "'load_ratio', 'friction_coefficient', 'base_friction_coefficient', 'load_step')")
        if options.get("cargo_mass") is not None and options.get("load_ratio") is not None:
            raise ValueError("reset options 'cargo_mass' and 'load_ratio' both set the load: give one of them")
        for name in ("k", "cargo_mass", "friction_coefficient", "base_friction_coefficient"):
            if options.get(name) is not None and not is_real_number(options[name]):
                raise ValueError(f"reset option {name}={options[name]!r} must be a number (one episode, one value)")
        k = options.get("k", None)
        m = options.get("cargo_mass", None)
        k = float(rng.uniform(*self.k_range)) if k is None else float(k)
        contact = self._contact
        mu, mu1 = options.get("friction_coefficient"), options.get("base_friction_coefficient")
        if (mu is not None or mu1 is not None or self.friction_range[0] != self.friction_range[1]
                or self.base_friction_range[0] != self.base_friction_range[1]):  # a value given is not drawn
            contact = dataclasses.replace(
                contact, friction_coefficient=_draw(rng, self.friction_range) if mu is None else float(mu),
                base_friction_coefficient=_draw(rng, self.base_friction_range) if mu1 is None else float(mu1))
        ratio_range = self.load_ratio_range
        if options.get("load_ratio") is not None:
            ratio_range = sample_range("load_ratio", options["load_ratio"], 0.0, 10.0)
        if m is None:
            m = self.draw_load(rng, k, contact, ratio_range)
        return k, float(m), self.params_for(k, float(m), contact)  # validates k and cargo_mass

    def draw_load(self, rng: np.random.Generator, k: float, contact: Contact, ratio_range=None) -> float:
        """A cargo mass (kg) from the load ratio's range (a fraction of this contact's ``mu F_ref``)
        if the env has one, else from the cargo mass range."""
        ratio_range = ratio_range or self.load_ratio_range
        if ratio_range is not None:
            p0 = self.params_for(k, 0.0, contact)
            return float(rng.uniform(*ratio_range)) * contact.friction_coefficient * self.reference_force(p0) \
                / p0.drive.gravity
        return float(rng.uniform(*self.cargo_mass_range))

    def reference_force(self, params: DriveParams) -> float:
        """F_ref (N): the analytic normal force at the largest allowed depth (Eq. 8)."""
        return normal_force_analytic(self.action_map.z_amplitude_max, params.k, params.contact.indenter_radius,
                                     params.normal_stiffness_prefactor, params.c0)

    def trapezoid_action(self) -> np.ndarray:
        """The trapezoid baseline as float32 in the box: the paper's waveform shape (Fig. 2) at this
        env's period and full strokes (``x_amplitude_max``, ``z_amplitude_max``); with the defaults,
        the paper's waveform exactly."""
        amap = self.action_map
        return amap.to_action(Waveform.paper(amap.period, amap.x_amplitude_max, amap.z_amplitude_max))

    def box_action(self, action) -> np.ndarray:
        """The Box action (5,) float64 that ``action`` plays: itself, or with ``action_codebook`` the
        table's row it indexes, in float32 as a Box action (``ValueError`` for an index outside it)."""
        if isinstance(action, (dict, str, bytes)) or np.asarray(action).dtype.kind not in "biuf":
            raise ValueError(f"action {action!r} is not {'an index' if self.action_codebook is not None else 'an array'}"
                             f" of real numbers (the action space is {self.action_space})")
        if self.action_codebook is not None:
            if np.size(action) != 1:
                raise ValueError(f"action {action!r} is not one index of the action space {self.action_space}")
            action = codebook_rows(self.action_codebook, np.asarray(action).reshape(()))
        if np.size(action) != ActionMap.SIZE:
            raise ValueError(f"action of shape {np.shape(action)} is not one of the action space {self.action_space}")
        return np.asarray(action, dtype=np.float64).reshape(ActionMap.SIZE)

    def action_to_waveform(self, action: np.ndarray) -> Waveform:
        """The waveform (SI units) an action selects; clips to the box, raises on non-finite."""
        return self.action_map.to_waveform(action)

    # --- Gymnasium API ---
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self.k, self.cargo_mass, self.params = self.sample_episode(self.np_random, options)
        self.sim = DriveSimulator(self.params, self.numerics, max_depth=self.action_map.z_amplitude_max)
        self.force_ref = self.reference_force(self.params)
        self.period_index = 0
        self.last_trace = None
        self.last_reward: float | None = None  # of the last period (None before the first)
        self.last_mean_velocity: float | None = None  # m/s
        self._prev_action = np.zeros(ActionMap.SIZE, dtype=np.float32)
        self._last_result = None
        self.load_step = None  # (period index, new cargo mass in kg) of this episode's load step
        if (options or {}).get("load_step") is not None:  # given for this episode: (period, cargo mass in kg)
            step = options["load_step"]
            if not (isinstance(step, (tuple, list)) and len(step) == 2 and is_real_number(step[1])):
                raise ValueError(f"reset option load_step={step!r} must be (period, cargo mass in kg)")
            period, mass = step
            if isinstance(period, (bool, np.bool_)) or not (isinstance(period, (int, np.integer))
                                                             and 1 <= period <= self.max_periods - 1):
                raise ValueError(f"reset option load_step period={period!r} is outside the allowed range "
                                 f"[1, {self.max_periods - 1}]")
            self.load_step = (int(period), float(self.params.with_cargo_mass(float(mass)).drive.cargo_mass))
        elif self.load_step_range is not None:
            period = int(self.np_random.integers(self.load_step_range[0], self.load_step_range[1] + 1))
            self.load_step = (period, self.draw_load(self.np_random, self.k, self.params.contact))
        if self.sensor is not None:
            self.sensor.reset()
            if self.sensor.tier.noisy:  # its own stream, seeded from the episode's: noise leaves the draws alone
                self._noise_rng = np.random.default_rng(int(self.np_random.integers(2**63)))
        obs = self._observation(None)
        return obs, self._info(None, None)

    def step(self, action):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        if self.period_index >= self.max_periods:
            raise RuntimeError(f"the episode ended (truncated after its {self.max_periods} periods): call reset() "
                               "before step()")
        action = self.box_action(action)
        wp = self.action_map.to_params(action)
        if self.load_step is not None and self.period_index == self.load_step[0]:  # the cargo changes now
            self.cargo_mass = self.load_step[1]
            self.params = self.sim.params = self.params.with_cargo_mass(self.cargo_mass)
        traced = self.sensor is not None and self.sensor.tier.traced
        record = 1 if traced else self.action_map.steps_per_period // 200 if self.render_mode is not None else 0
        result = self.sim.step_params(wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase,
                                      wp.period, record_every=record)
        self.last_trace = result.trace
        self._last_result = result
        self.period_index += 1
        self._prev_action = np.minimum(np.maximum(action, -1.0), 1.0).astype(np.float32)  # clip, cheaper
        if self.sensor is not None:
            positions = (sample_positions(result.trace, result.displacement, wp.period, self.sensor.tier.trace_samples)
                         if traced else None)
            self.sensor.push(result.displacement, result.mean_velocity, result.end_velocity,
                             result.peak_tangential_force, result.peak_normal_force, self._prev_action,
                             self.reward_scale, self.action_map.period, positions, self._noise_rng)
        effort = self.action_map.effort(wp.x_amplitude, wp.z_amplitude)
        reward = self.reward_of(result.displacement, effort)
        obs = self._observation(result)
        self.last_reward, self.last_mean_velocity = float(reward), result.mean_velocity
        truncated = self.period_index >= self.max_periods
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), False, truncated, self._info(result, wp, float(effort))

    def reward_of(self, displacement, effort):
        """Reward(s) of a period: displacement (m) / reward_scale - actuation_penalty * effort,
        clamped below at reward_floor if set (floats or arrays; the vector env uses it too)."""
        reward = displacement / self.reward_scale - self.actuation_penalty * effort
        return reward if self.reward_floor is None else np.maximum(reward, self.reward_floor)

    def dynamics_of(self, displacement, mean_velocity, end_velocity, peak_fx, peak_fz, force_ref,
                    friction_ref) -> np.ndarray:
        """Observation entries 0-4 from SI values, F_ref and each drive's own mu F_ref (N): floats
        give (5,), (n,) arrays (n, 5)."""
        v_scale = self.reward_scale / self.action_map.period
        return np.array([displacement / self.reward_scale, mean_velocity / v_scale, end_velocity / v_scale,
                         peak_fx / friction_ref, peak_fz / force_ref]).T  # (5,) stays (5,); (5, n) becomes (n, 5)

    def _observation(self, r) -> np.ndarray:
        """The observation after period result ``r`` (None after reset)."""
        if self.sensor is not None:
            return self.sensor.observation(self.period_index / self.max_periods)
        full = self._full_observation(r, self.params)
        return self._with_friction(full) if self.observation == "privileged" else full

    def _with_friction(self, full: np.ndarray) -> np.ndarray:
        """``full`` with the episode's friction ratio mu1 / mu appended (``PrivilegedLayout``)."""
        c = self.params.contact
        ratio = PrivilegedLayout.ratio([c.friction_coefficient, c.base_friction_coefficient])
        return np.concatenate([full, np.array([ratio], dtype=np.float32)])

    def privileged_observation(self, friction: bool = False) -> np.ndarray:
        """The full observation (``ObservationLayout``: k and the load included) of the current state,
        whatever ``observation`` is, with the load of the coming period (the new one when a load step
        falls on it): what a privileged teacher is told while a sensor policy learns (float32). With
        ``friction``, the ``PrivilegedLayout`` (mu1 / mu appended)."""
        if self.sim is None:
            raise RuntimeError("call reset() before privileged_observation()")
        params = self.params
        if self.load_step is not None and self.period_index == self.load_step[0]:
            params = params.with_cargo_mass(self.load_step[1])
        full = self._full_observation(self._last_result, params)
        return self._with_friction(full) if friction else full

    def _full_observation(self, r, p: DriveParams) -> np.ndarray:
        """The full observation after period result ``r`` (None after reset) under model ``p``. The
        same numbers as ``ObservationLayout.build`` (which the vector env uses), in plain floats:
        building a 14-entry array with NumPy costs more than the arithmetic."""
        mu_fref = p.contact.friction_coefficient * self.force_ref
        if r is None:
            values = [0.0] * 5
        else:
            v_scale = self.reward_scale / self.action_map.period  # as dynamics_of
            values = [r.displacement / self.reward_scale, r.mean_velocity / v_scale, r.end_velocity / v_scale,
                      r.peak_tangential_force / mu_fref, r.peak_normal_force / self.force_ref]
        values += self._prev_action.tolist()
        values += [p.k, p.drive.load / mu_fref, p.drive.load / 10.0, self.period_index / self.max_periods]
        low, high = _OBS_BOUNDS
        return np.array([min(max(v, lo), hi) for v, lo, hi in zip(values, low, high)], dtype=np.float32)

    def _info(self, r, wp, effort=0.0) -> dict[str, Any]:
        c = self.params.contact
        info: dict[str, Any] = {"k": self.k, "cargo_mass": self.cargo_mass, "load_force": self.params.drive.load,
                                "friction_coefficient": c.friction_coefficient,
                                "base_friction_coefficient": c.base_friction_coefficient,
                                "load_step_period": None if self.load_step is None else self.load_step[0],
                                "period_index": self.period_index}
        if r is not None:
            info.update(
                displacement=r.displacement, mean_velocity=r.mean_velocity, end_velocity=r.end_velocity,
                slider_position=r.end_position, peak_tangential_force=r.peak_tangential_force,
                peak_normal_force=r.peak_normal_force, indenter_dissipation=r.indenter_dissipation,
                base_dissipation=r.base_dissipation, load_work=r.load_work, effort=effort,
                waveform=wp._asdict(),
            )
        return info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to gym.make")
            return None
        from .rendering import Renderer

        if self._renderer is None:
            self._renderer = Renderer(human=self.render_mode == "human")
        frame = self._renderer.draw(self)
        return frame if self.render_mode == "rgb_array" else None

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_renderer"] = None  # matplotlib figures do not pickle
        return state

