"""What a drive's sensors can tell of what they hide, by the drive played and the sensor tier.

    mdr-drive identifiability --seed 20261501 --out results/identifiability     # make identifiability

Episodes of ``MDRDriveSensor-v0`` (k, the load, mu and mu1 hidden and drawn as it draws them; no
load step). Each *drive* plays them for P periods:

* ``trapezoid``: the paper's trapezoid every period, from rest;
* ``probe``: the deliberate probe (``sensor_episodes.probe_actions``: the trapezoid, reversed,
  out of contact, half depth, symmetric, a clamp) in turn, from rest;
* ``teacher``: the full-observation policy told the truth (``--teacher``, default the sensor
  policies' teacher), from rest;
* ``trapezoid-steady`` and ``teacher-steady``: the same drives, the P periods that end at period
  ``steady_end`` (30: the periods the reports' steady velocity averages), once the start has
  settled;
* ``sensor-steady``: a sensor policy (``--sensor-policy``, default the shipped position-only one)
  on its own sensor observation, the P periods that end at ``steady_end``: what it reads while it
  drives on its own guesses.

What each tier measures of those P periods are the measurements of the sensor observation a policy
with ``history = P`` would see (``gym_envs.sensor``): ``encoder``, the per-period displacement, mean
and end velocity; ``trace``, also the positions through each period (``trace_samples``,
``encoder_noise``); ``self-sensing``, also the sensed peak forces. The actions played are left out:
the teacher's are a function of the hidden values it is told, and would tell them. The episodes are
played once in the ``self-sensing`` tier and each tier reads its own columns of that observation
(the same measurements; a ``trace`` env would draw its own noise).

For every drive, tier and P, an MLP (``student.estimator.Estimator``) is fitted on ``episodes``
draws to all of ``TARGETS`` at once, and scored on ``test_episodes`` other draws (the same draws for
every drive) by the standardised error: the root mean square error over the entry's standard
deviation on the test draws (0 exact, 1 no better than the mean).

Writes ``identifiability.json``, ``identifiability.md`` and ``identifiability.png`` (the errors at
the largest P, one panel per tier). One task per drive runs on the sweep
executor (``--workers``, ``--ray-address``) and is kept as it finishes (``--resume``).
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from mdr_drive_env.core.params import check_int
from mdr_drive_env.files import json_safe, write_text
from mdr_drive_env.gym_envs.sensor import DEFAULT_ENCODER_NOISE, DEFAULT_FORCE_NOISE, DEFAULT_TRACE_SAMPLES, SENSOR_TIERS
from mdr_drive_env.gym_envs.spaces import ActionMap, PrivilegedLayout, SensorLayout
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from .adaptation import FULL_POLICY, SENSOR_POLICY

#: The drives (module docstring), in the report's order.
DRIVES = ("trapezoid", "probe", "teacher", "trapezoid-steady", "teacher-steady", "sensor-steady")
#: What is estimated: the privileged observation's hidden entries (``PrivilegedLayout`` names), then
#: mu and mu1 apart.
TARGETS = ("k", "load_over_friction", "load_over_10N", "friction_ratio", "mu", "mu1")
#: The report's column heads of ``TARGETS``.
TARGET_LABELS = ("k", "load / (mu F_ref)", "load", "mu1 / mu", "mu", "mu1")
#: Offset between the seeds of the draws and of the estimators' fits.
FIT_SEED_OFFSET = 7919


@dataclass(frozen=True)
class IdentifiabilityConfig:
    """The study (module docstring).

    Attributes:
        seed: seed of the hidden draws (episode i is reset with ``seed + i``) and of the fits (-).
        episodes: draws each estimator is fitted on (-), >= 2.
        test_episodes: further draws it is scored on (-), >= 2.
        periods: the P of the study, each in [1, 64] (periods the sensors measure) (-).
        drives: which of ``DRIVES`` to play.
        tiers: which of the sensor tiers to score (``gym_envs.sensor.SENSOR_TIERS``).
        steady_end: the period the steady drives' P periods end at (-), > max(periods).
        trace_samples: position samples per period (-), in [1, 1000].
        encoder_noise: standard deviation of each position sample (m).
        force_noise: relative standard deviation of each sensed force (-).
        teacher: folder of the full-observation policy the ``teacher`` drives play.
        sensor_policy: folder of the sensor policy the ``sensor-steady`` drive plays.
        estimator_arch: hidden layer sizes of the estimator (-).
        steps: Adam steps of each fit (-).
        batch: minibatch size (-).
        learning_rate: Adam step size, decaying linearly to zero (-).
    """

    seed: int
    episodes: int = 8000
    test_episodes: int = 2000
    periods: tuple[int, ...] = (4, 8)
    drives: tuple[str, ...] = DRIVES
    tiers: tuple[str, ...] = SENSOR_TIERS
    steady_end: int = 30
    trace_samples: int = DEFAULT_TRACE_SAMPLES
    encoder_noise: float = DEFAULT_ENCODER_NOISE
    force_noise: float = DEFAULT_FORCE_NOISE
    teacher: str = FULL_POLICY
    sensor_policy: str = SENSOR_POLICY
    estimator_arch: tuple[int, ...] = (256, 256)
    steps: int = 6000
    batch: int = 256
    learning_rate: float = 1e-3

    def __post_init__(self) -> None:
        from mdr_drive_env.gym_envs.sensor import SensorTier

        check_int("seed", self.seed, 0)
        check_int("episodes", self.episodes, 2)
        check_int("test_episodes", self.test_episodes, 2)
        for name in ("steps", "batch"):
            check_int(name, getattr(self, name), 1)
        if not self.periods or not all(isinstance(p, int) and 1 <= p <= 64 for p in self.periods):
            raise ValueError(f"periods={self.periods!r} must be whole numbers in [1, 64]")
        for name, allowed in (("drives", DRIVES), ("tiers", SENSOR_TIERS)):
            value = getattr(self, name)
            if not value or any(v not in allowed for v in value) or len(set(value)) < len(value):
                raise ValueError(f"{name}={value!r} must name distinct entries of {list(allowed)}")
        if not isinstance(self.steady_end, int) or self.steady_end <= max(self.periods):
            raise ValueError(f"steady_end={self.steady_end!r} is outside the allowed range "
                             f"(max(periods) = {max(self.periods)}, inf)")
        SensorTier("self-sensing", self.trace_samples, self.encoder_noise, self.force_noise)  # its own checks
        if not self.estimator_arch or not all(isinstance(n, int) and n >= 1 for n in self.estimator_arch):
            raise ValueError(f"estimator_arch={self.estimator_arch!r} must be positive layer sizes")
        if not 0.0 < self.learning_rate <= 1.0:
            raise ValueError(f"learning_rate={self.learning_rate!r} is outside the allowed range (0, 1]")


def tier_columns(layout: SensorLayout, tier: str, periods: int, actions: bool = True) -> np.ndarray:
    """Indices of the columns of ``layout`` (a ``self-sensing`` observation, ``layout.history`` >=
    ``periods`` deep) that make ``tier``'s own observation with ``history = periods``: what ``tier``
    measures of the newest ``periods`` periods, then (``actions``) their actions and the elapsed
    fraction."""
    if periods > layout.history:
        raise ValueError(f"periods={periods} is deeper than the observation's history {layout.history}")
    kept = set(SensorLayout.MEASURED) | (set(ActionMap.NAMES) if actions else set())
    if tier != "encoder":
        kept |= {name for name in layout.per_period if name.startswith("position_")}
    if tier == "self-sensing":
        kept |= set(SensorLayout.FORCES)
    columns = []
    for i, name in enumerate(layout.names):
        if name == "episode_fraction":
            if actions:
                columns.append(i)
            continue
        base, lag = name[:-1].split("[t-")
        if base in kept and int(lag) < periods:
            columns.append(i)
    return np.array(columns)


def full_observation_teacher(folder: str):
    """The policy at ``folder`` as the teacher drives play it: its act on the privileged observation
    (``collect``'s driver); a ``ValueError`` for a policy that does not see the full observation or does not
    act with the sensor env's action map."""
    from ..student.estimator import sensor_teacher_policy, teacher_layout

    teacher = sensor_teacher_policy(folder)
    if teacher_layout(teacher) is PrivilegedLayout:
        return lambda sensed, privileged: teacher.act(privileged)
    return lambda sensed, privileged: teacher.act(privileged[:, :-1])  # not told friction


def sensor_policy_player(folder: str, config: IdentifiabilityConfig):
    """The sensor policy at ``folder`` as the ``sensor-steady`` drive plays it: ``(its history, a
    function of the self-sensing layout that gives its act on that observation)``; a ``ValueError``
    for a policy that is not a sensor policy or senses other positions than ``config``'s."""
    from ..policy import load_policy

    policy = load_policy(folder)
    play = policy.play_kwargs
    tier = play.get("sensor_tier", "encoder")
    if play.get("observation") != "sensor":
        raise ValueError(f"sensor_policy={folder!r} is not a sensor policy (its run.json: observation="
                         f"{play.get('observation')!r})")
    if tier != "encoder" and (play.get("trace_samples"), play.get("encoder_noise")) != (
            config.trace_samples, config.encoder_noise):
        raise ValueError(f"sensor_policy={folder!r} senses {play.get('trace_samples')} positions per period with "
                         f"{play.get('encoder_noise')} m noise; the study's sensors take {config.trace_samples} with "
                         f"{config.encoder_noise} m")
    history = int(play.get("history", 6))

    def act_on(layout: SensorLayout):
        cols = tier_columns(layout, tier, history)
        return lambda sensed, privileged: policy.act(sensed[:, cols])

    return history, act_on


def _driver(drive: str, envs: list, policy_act):
    """``collect``'s driver of ``drive`` over ``envs`` (``policy_act``: the policy's, for the
    policy drives)."""
    from ..sensor_episodes import ProbeFirst, probe_actions

    trapezoid = np.tile(envs[0].unwrapped.trapezoid_action(), (len(envs), 1))
    constant = lambda sensed, privileged: trapezoid  # noqa: E731
    if drive.startswith("trapezoid"):
        return constant
    if drive == "probe":
        periods = envs[0].unwrapped.max_periods
        return ProbeFirst(constant, probe_actions(envs[0]), periods, periods)
    return policy_act


def episodes_of(config: IdentifiabilityConfig, drive: str) -> tuple[np.ndarray, np.ndarray, SensorLayout]:
    """The ``self-sensing`` observations of ``drive``'s episodes after their measured periods
    (``episodes + test_episodes`` draws; ``max(periods)`` deep, or the sensor policy's history if
    deeper), the true ``TARGETS`` (n, 6) and the observation's layout."""
    import gymnasium as gym

    from mdr_drive_env import SENSOR_DEFAULTS

    from ..protocol import SENSOR_ID
    from ..sensor_episodes import collect

    player = sensor_policy_player(config.sensor_policy, config) if drive.startswith("sensor") else None
    depth = max(max(config.periods), player[0] if player else 1)
    end = config.steady_end if drive.endswith("steady") else max(config.periods)
    n = config.episodes + config.test_episodes
    kwargs = {**SENSOR_DEFAULTS, "history": depth, "max_periods": end + 1, "sensor_tier": "self-sensing",
              "trace_samples": config.trace_samples, "encoder_noise": config.encoder_noise,
              "force_noise": config.force_noise}
    envs = [gym.make(SENSOR_ID, **kwargs) for _ in range(n)]
    first = np.array([env.reset(seed=config.seed + i)[0] for i, env in enumerate(envs)])
    if player:
        policy_act = player[1](envs[0].unwrapped.sensor.layout)
    else:
        policy_act = full_observation_teacher(config.teacher) if drive.startswith("teacher") else None
    sensed, privileged, _ = collect(envs, first, _driver(drive, envs, policy_act), friction=True)
    rows = slice(end * n, (end + 1) * n)  # the observations before period `end`: after the `end` periods measured
    names = PrivilegedLayout.NAMES
    truth = privileged[rows][:, [names.index(t) for t in TARGETS[:4]]].astype(np.float64)
    friction = np.array([[env.unwrapped.params.contact.friction_coefficient,
                          env.unwrapped.params.contact.base_friction_coefficient] for env in envs])
    return sensed[rows].astype(np.float64), np.column_stack([truth, friction]), envs[0].unwrapped.sensor.layout


def drive_errors(config: IdentifiabilityConfig, drive: str) -> dict:
    """The standardised test error of every ``TARGETS`` entry, for each tier and P, on ``drive``'s
    episodes: ``{tier: {str(P): [error per target]}}``, and the wall time (s)."""
    import torch

    from ..student.estimator import Estimator, standardised_error

    t0 = time.perf_counter()
    torch.set_num_threads(1)
    x, y, layout = episodes_of(config, drive)
    train, test = slice(0, config.episodes), slice(config.episodes, None)
    errors: dict = {}
    for tier in config.tiers:
        errors[tier] = {}
        for p in config.periods:
            cols = tier_columns(layout, tier, p, actions=False)
            est = Estimator(len(cols), config.estimator_arch, config.seed + FIT_SEED_OFFSET, n_out=len(TARGETS),
                            names=TARGETS)
            est.fit(x[train][:, cols], y[train], config.steps, config.batch, config.learning_rate,
                    config.seed + FIT_SEED_OFFSET, progress=False)
            errors[tier][str(p)] = standardised_error(est(x[test][:, cols]), y[test]).tolist()
    return {"errors": errors, "wall_time_s": round(time.perf_counter() - t0, 1)}


def _task(args: tuple[dict, str]) -> dict:
    """One drive's errors (``drive_errors``), from a picklable (config fields, drive)."""
    fields, drive = args
    return drive_errors(IdentifiabilityConfig(**fields), drive)


def run(config: IdentifiabilityConfig, out: str | Path, command: str = "", executor: Executor | None = None,
        resume: bool = False) -> dict:
    """The study into ``out`` (``identifiability.json``, ``identifiability.md``); returns what the
    JSON holds."""
    from ..run_record import versions

    out = Path(out)
    executor = executor or Executor()
    if any(drive.startswith("teacher") for drive in config.drives):  # these fail before any task runs
        full_observation_teacher(config.teacher)
    if any(drive.startswith("sensor") for drive in config.drives):
        sensor_policy_player(config.sensor_policy, config)
    store = TaskStore(task_folder(out, resume) / "drives")
    fields = asdict(config)
    results = executor.map(_task, [(fields, drive) for drive in config.drives], "identifiability: drives", store=store)
    res = {"config": fields, "command": command, "versions": versions(), "targets": list(TARGETS),
           "drives": {drive: r for drive, r in zip(config.drives, results)}}
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "identifiability.json", json.dumps(json_safe(res), indent=1))
    write_text(out / "identifiability.md", markdown(res))
    plot(res, out / "identifiability.png")
    shutil.rmtree(out / ".tasks", ignore_errors=True)  # every output is written: the per-drive results are spent
    return res


def markdown(res: dict) -> str:
    """The report's table: one row per drive, tier and P."""
    c = res["config"]
    lines = [f"# What the sensors can tell: seed {c['seed']}", "",
             f"Standardised error (root mean square error over the entry's spread; 0 exact, 1 no better than the mean) "
             f"of an MLP {tuple(c['estimator_arch'])} fitted on {c['episodes']} draws of MDRDriveSensor-v0's hidden "
             f"values and scored on {c['test_episodes']} others. Steady: the P periods that end at period "
             f"{c['steady_end']}. Trace: {c['trace_samples']} positions per period, {c['encoder_noise'] * 1e9:g} nm "
             f"noise; self-sensing: also the peak forces, {c['force_noise']:.0%} noise.", "",
             "| drive | tier | P | " + " | ".join(TARGET_LABELS) + " |",
             "|---|---|---|" + "---|" * len(TARGET_LABELS)]
    for drive, r in res["drives"].items():
        for tier, by_p in r["errors"].items():
            for p, errs in by_p.items():
                lines.append(f"| {drive} | {tier} | {p} | " + " | ".join(f"{e:.2f}" for e in errs) + " |")
    return "\n".join(lines) + "\n"


def plot(res: dict, path: str | Path) -> None:
    """Grouped bars of the standardised error of each target, one bar per drive, one panel per tier,
    at the largest P of ``res``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mdr_drive_env.files import save_figure

    p = str(max(res["config"]["periods"]))
    drives, tiers = list(res["drives"]), list(res["config"]["tiers"])
    width = 0.8 / len(drives)
    x = np.arange(len(TARGET_LABELS))
    fig, axes = plt.subplots(1, len(tiers), figsize=(4.6 * len(tiers), 3.8), sharey=True, squeeze=False)
    for ax, tier in zip(axes[0], tiers):
        for j, drive in enumerate(drives):
            ax.bar(x + (j - (len(drives) - 1) / 2) * width, res["drives"][drive]["errors"][tier][p], width,
                   label=drive, color=plt.cm.viridis(j / max(len(drives) - 1, 1)))
        ax.axhline(1.0, color="0.4", lw=0.8, ls="--")
        ax.set_xticks(x, TARGET_LABELS, rotation=30, ha="right")
        ax.set_title(f"{tier}: {p} periods")
    axes[0][0].set_ylabel("standardised error (1: no better than the mean)")
    axes[0][0].set_ylim(0, 1.3)
    axes[0][-1].legend(fontsize=8, title="drive played", title_fontsize=8)
    fig.suptitle(f"What the sensors can tell: seed {res['config']['seed']}, {res['config']['episodes']} training draws",
                 fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


__all__ = ["DRIVES", "IdentifiabilityConfig", "TARGETS", "drive_errors", "episodes_of", "full_observation_teacher",
           "markdown", "plot", "run", "sensor_policy_player", "tier_columns"]
