"""Ship a trained policy: copy model, VecNormalize statistics and run record, and write its model card.

    mdr-drive model-card runs/recipe/policy agents/pretrained/ppo_generalist [BLIND.json ...]
    mdr-drive model-card runs/sensor/policy agents/pretrained/ppo_sensor ADAPTATION.json

The card's evaluation table is computed here, from the shipped files, with the benchmark protocol.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from mdr_drive_env.files import write_text

from ..policy import load_policy, policy_files, same_weights
from ..protocol import (
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    TIME_QUANTUM,
    format_velocity,
    open_loop_velocity,
    policy_velocity,
    trapezoid_action,
)
from ..student.distill import FOCUS_KEYS
from .record import blind_record

CARD_KS = (0.0, 0.2, 0.4, 0.6)
CARD_MASSES = (0.0, 0.05, 0.1, 0.2, 0.4)


def evaluation_table(policy_dir: str | Path) -> str:
    points = [(k, m) for k in CARD_KS for m in CARD_MASSES]
    learned = policy_velocity(load_policy(policy_dir), points, mark_runaway=True)
    trap = open_loop_velocity(points, trapezoid_action(), mark_runaway=True)
    lines = ["| k | " + " | ".join(f"m = {m:g} kg" for m in CARD_MASSES) + " |", "|---|" + "---|" * len(CARD_MASSES)]
    for i, k in enumerate(CARD_KS):
        cells = [f"{format_velocity(learned[i * len(CARD_MASSES) + j])} "
                 f"({format_velocity(trap[i * len(CARD_MASSES) + j])})" for j in range(len(CARD_MASSES))]
        lines.append(f"| {k:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def jump_note(distilled: dict) -> str:
    """The first round's bisection of the teacher's jumps, its focus episodes and the labels' quantum
    centres, where used."""
    d = distilled["distill"]
    notes = []
    if d.get("jump_levels"):
        added = next((r.get("jump_points") for r in distilled.get("history") or [] if r.get("round") == 0), None)
        notes.append(f"{added:,} more" if added is not None else "more")
        notes[-1] += f" bisecting where its drive jumps ({d['jump_levels']} levels)"
    for points, band in FOCUS_KEYS:
        if d.get(points):
            low, high = d[band]
            notes.append(f"{d[points]:,} more at k = {low:g}-{high:g}")
    if d.get("quantum_centres"):
        notes.append("labels at the centres of their time quanta")
    return f" and {', '.join(notes)}" if notes else ""


def stall_note(distill: dict) -> str:
    """The hole rounds' probes around the teacher's stall load (``DistillConfig.stall_probes``), if any."""
    if not distill.get("stall_probes"):
        return ""
    low, high = distill["stall_band"]
    return f", each with {distill['stall_probes']:,} probes at {low:g}-{high:g} of the teacher's stall load"


def fit_loss_note(distill: dict) -> str:
    """The loss the student was fitted with (``DistillConfig``'s settings as saved in run.json)."""
    if distill.get("action_codebook"):
        return "cross-entropy over the teacher grid's actions" + (" (raw logits)" if distill.get("raw_logits") else "")
    return f"Huber loss, delta {distill['huber_delta']:g}" if distill.get("huber_delta") else "squared error"


def training_note(run: dict) -> str:
    """How the policy was made: distilled from a teacher (``agents.recipe``) or trained by PPO/SAC."""
    distilled = run.get("distilled_from")
    if distilled:
        d = distilled["distill"]
        loss = next((r["loss"] for r in reversed(distilled.get("history") or []) if r.get("loss") is not None),
                    float("nan"))  # a hole round that found no hole did not fit
        return (f"distilled (`mdr_drive_agents.student.distill`) from the drive-field teacher "
                f"`{distilled['teacher']}` (`mdr_drive_agents.teacher`), recipe `{distilled['recipe']}`: a {'x'.join(map(str, d['net_arch']))} "
                f"{d['activation']} network fitted for {d['steps']:,} steps ("
                f"{fit_loss_note(d)}) to the teacher's actions on "
                f"{d['points']:,} random episodes{jump_note(distilled)} (the teacher's neighbourhood radius "
                f"{d.get('teacher_radius', 1)}; "
                f"DAgger rounds after it: {d['rounds']}; hole rounds: {d.get('hole_rounds', 0)}{stall_note(d)}); final fit loss "
                f"{loss:.2e}. No PPO update yet ({run['total_timesteps']:,} environment "
                f"steps): `mdr-drive train --resume` fine-tunes it with the PPO settings below (docs/results.md: "
                f"it did not make it better)")
    return (f"{run['algo'].upper()}, {run['total_timesteps']:,} environment steps (drive periods), "
            f"warm start {run['hyperparameters'].get('warm_start', 'none')}")


LOAD_POLICY = """```python
import numpy as np
from mdr_drive_agents import load_policy

policy = load_policy("{dir}")   # from any working directory
env = policy.make_env({overrides}, max_periods=30)   # the env it was trained for (run.json)
obs, info = env.reset(seed=0)
velocities = []
for period in range(30):
    obs, reward, terminated, truncated, info = env.step(policy.predict(obs))
    velocities.append(info["mean_velocity"])
print(f"steady velocity {{np.mean(velocities[20:]) * 1e3:.2f}} mm/s")
```"""

SNIPPET = """```python
import gymnasium as gym
import numpy as np
from {module} import {cls}
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import mdr_drive_env  # registers {env_id}
from mdr_drive_agents.policy import package_path

folder = package_path("{dir}")   # its files, from any working directory
{comment}make = lambda: gym.make({make_args})
venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([make]))
venv.training, venv.norm_reward = False, False      # play: statistics frozen, raw rewards
model = {cls}.load(str(folder / "model.zip"), device="cpu")
{seed}obs, velocities = venv.reset(), []
{memory}for period in range(30):
    {predict}
    obs, reward, done, info = venv.step(action)
    velocities.append(info[0]["mean_velocity"])
print(f"steady velocity {{np.mean(velocities[20:]) * 1e3:.2f}} mm/s")
```"""


#: The recipe ``make train`` runs (``train.recipe.DEFAULT_CONFIG``; read here as a file, the benchmarks
#: sit beside the training programs, not on them).
RECIPE_YAML = Path(__file__).parents[1] / "configs" / "recipe.yaml"


def recipe_note(run: dict, recipe_yaml: Path = RECIPE_YAML) -> str:
    """Where a distilled policy's student settings (its run.json's ``distilled_from.distill``) differ from
    today's ``agents/configs/recipe.yaml`` (``recipe_yaml``): the keys, or that today's recipe builds
    another kind of student, since ``make train`` then builds another policy."""
    from ..student.distill import DistillConfig
    from ..yaml_config import build, read_yaml

    saved = (run.get("distilled_from") or {}).get("distill")
    if not saved:
        return ""
    recipe = read_yaml(recipe_yaml)
    if recipe.get("student", "distill") != "distill":
        return (f" (today's `agents/configs/recipe.yaml` builds another kind of student, one that predicts the worth "
                "of each of the teacher's drives: `make train` builds another policy, docs/results.md)")
    config = build(DistillConfig, recipe.get("distill", {}), f"{recipe_yaml.name}'s distill")
    today = json.loads(json.dumps({key: getattr(config, key) for key in config.__dataclass_fields__}))
    differ = sorted(key for key in set(saved) | set(today)  # a key one side lacks counts where the other sets it
                    if saved.get(key) != today.get(key) and (saved.get(key) or today.get(key)))
    if not differ:
        return ""
    return (f" (today's `agents/configs/recipe.yaml` sets other student settings, {', '.join(f'`{k}`' for k in differ)}: "
            "`make train` builds another policy, docs/results.md)")


def tier_arguments(run: dict) -> str:
    """The sensor tier's keywords of a sensor policy's env (``sensor_tier=..., trace_samples=...,
    encoder_noise=..., ``), or "" for the default ``encoder`` tier."""
    kw = run["env_kwargs"]
    if kw.get("sensor_tier", "encoder") == "encoder":
        return ""
    return (f'sensor_tier="{kw["sensor_tier"]}", trace_samples={kw["trace_samples"]}, '
            f'encoder_noise={kw["encoder_noise"]:g}, ')


#: What each sensor tier measures, as a sensor policy's model card says it.
TIER_TEXT = {
    "encoder": "what a position encoder reports per period: the slider's displacement, mean and end velocity",
    "trace": "the slider's position at {n} evenly spaced times of each period, each with {noise:g} nm of Gaussian noise "
             "(a laboratory interferometer or capacitive sensor at about {rate:g} kHz), and the per-period displacement, "
             "mean and end velocity",
    "self-sensing": "the position trace of the `trace` tier ({n} samples a period, {noise:g} nm noise) and the peak "
                    "contact forces the piezo senses from its own charge ({force:g} % noise)",
}


def tier_text(run: dict) -> str:
    """What the sensor policy of ``run`` measures (``TIER_TEXT``), with its tier's numbers."""
    kw = run["env_kwargs"]
    tier = kw.get("sensor_tier", "encoder")
    n = kw.get("trace_samples", 40)
    period = kw.get("period", 2e-3)
    return TIER_TEXT[tier].format(n=n, noise=kw.get("encoder_noise", 2e-9) * 1e9, rate=n / period / 1e3,
                                  force=kw.get("force_noise", 0.02) * 100)


def _periods(x) -> str:
    return "-" if x is None else f"{x:g}"


def below_note(summary: dict, n: int) -> str:
    """Where an adaptation report's drive ``summary`` fell below the trapezoid on its ``n`` draws."""
    below = summary["points_below_trapezoid"]
    if not below:
        return f"this policy at none of {n} blind points; the dense check finds such points"
    return (f"this policy at {below} of {n} blind points, by up to "
            f"{-min(summary['worst_difference_to_trapezoid_mm_s'], 0.0):.2f} mm/s; the dense check finds more")


def sensor_drive_label(res: dict, src: str | Path) -> str:
    """The drive of an adaptation report ``res`` that is the sensor policy in ``src`` (its folder
    among the report's sensor policies; the only one where the report has one)."""
    folders = res["sensor_policy"] if isinstance(res["sensor_policy"], list) else [res["sensor_policy"]]
    drives = res.get("drives", ["sensor policy"])
    for folder, drive in zip(folders, drives):
        if Path(folder).resolve() == Path(src).resolve() or len(folders) == 1:
            return drive
    raise ValueError(f"{src} is none of the sensor policies the adaptation report played: {folders}")


def load_snippet(dst: Path, run: dict) -> str:
    """The card's tested ``load_policy`` snippet for the policy in ``dst``."""
    overrides = "k=0.2, cargo_mass=0.1"
    if run["env_id"] == "MDRDriveSensor-v0":
        overrides += ", friction_coefficient=0.3, base_friction_coefficient=0.1"
    return LOAD_POLICY.format(dir=dst.as_posix(), overrides=overrides)


#: The plain-SB3 snippet's class, and how it predicts, by algorithm: (module, class, memory set-up,
#: prediction); a recurrent policy carries its LSTM state from one period to the next.
PREDICT = "action, _ = model.predict(obs, deterministic=True)"
PLAY_BY_ALGO = {
    "ppo": ("stable_baselines3", "PPO", "", PREDICT),
    "sac": ("stable_baselines3", "SAC", "", PREDICT),
    "td3": ("stable_baselines3", "TD3", "", PREDICT),
    "recurrent_ppo": ("sb3_contrib", "RecurrentPPO", "state, start = None, np.ones(1, dtype=bool)     # the LSTM's "
                      "memory, empty at the start\n",
                      "action, state = model.predict(obs, state=state, episode_start=start, deterministic=True)\n"
                      "    start = np.zeros(1, dtype=bool)"),
}


#: How a policy of two-period cycle actions (``action_cycle: 2``) plays: both halves, in turn.
CYCLE_PREDICT = ("if period % 2 == 0:                                # one action sets two periods\n"
                 "        pair, _ = model.predict(obs, deterministic=True)\n"
                 "    action = pair[:, :5] if period % 2 == 0 else pair[:, 5:]")


def snippet(dst: Path, run: dict) -> str:
    """The card's tested plain-SB3 loading snippet for the policy in ``dst`` (full or sensor observation)."""
    module, cls, memory, predict = PLAY_BY_ALGO[run.get("algo", "ppo")]
    if run.get("hyperparameters", {}).get("action_cycle", 1) == 2:
        if memory:
            raise ValueError("a recurrent policy of two-period cycle actions has no plain-SB3 snippet")
        predict = CYCLE_PREDICT
    play = dict(module=module, cls=cls, memory=memory, predict=predict)
    if run["env_id"] == "MDRDriveSensor-v0":
        table = run["env_kwargs"].get("action_codebook")
        return SNIPPET.format(**play, env_id="MDRDriveSensor-v0", dir=dst.as_posix(),
                              seed="venv.seed(0)                                        # the sensor noise's stream, "
                                   "as reset(seed=0) seeds it\n",
                              comment="# k, the load and friction are hidden from the policy: drawn per episode, or fixed "
                                      "here to try one drive" + ("; action i plays row i of its table of drives"
                                                                  if table else "") + "\n",
                              make_args=f'"MDRDriveSensor-v0", history={run["env_kwargs"]["history"]}, '
                                        f"{tier_arguments(run)}max_periods=30, "
                                        "k=0.2, cargo_mass=0.1,\n                        friction_coefficient=0.3, "
                                        "base_friction_coefficient=0.1"
                                        + (f',\n                        action_codebook=str(folder / "{table}")'
                                           if table else ""))
    # its actions mean what they mean in an env with its seam of the z phase and its time quantum
    origin = run["env_kwargs"].get("z_phase_origin", 0.0)
    quantum = run["env_kwargs"].get("time_quantum", TIME_QUANTUM)
    args, notes = [], []
    if origin:
        args.append(f"z_phase_origin={origin:g}")
        notes.append(f"z_phase_origin={origin:g} (phase 0 at action {2 * ((1 - origin) % 1) - 1:g})")
    if quantum != TIME_QUANTUM:
        args.append(f"time_quantum={quantum:g}")
        notes.append(f"time_quantum={quantum:g} (rises and the z phase in {quantum * 1e6:g} us steps)")
    if run["env_kwargs"].get("action_codebook"):
        args.append(f'action_codebook=str(folder / "{run["env_kwargs"]["action_codebook"]}")')
        notes.append("its table of actions (Discrete: action i plays row i)")
    comment = f"# {' and '.join(notes)}: the env it was trained in, as in its run.json\n" if notes else ""
    return SNIPPET.format(**play, env_id="MDRDrive-v0", dir=dst.as_posix(), comment=comment, seed="",
                          make_args=", ".join(['"MDRDrive-v0", k=0.2, cargo_mass=0.1, max_periods=30', *args]))


def blind_key(blind_jsons, src: str | Path, dst: str | Path, ran_from: str | Path | None = None) -> str:
    """The name the blind results ``blind_jsons`` give the policy shipped from ``src`` to ``dst``: the
    folder they ran it from, ``src`` or ``dst``, or ``ran_from`` if given (a copy of the same network,
    e.g. the build a record ran before ``make train`` rebuilt it: ``ValueError`` unless
    :func:`same_weights`); ``ValueError`` if every file does not name it."""
    names = [Path(src).as_posix(), Path(dst).as_posix()]
    if ran_from is not None:
        if not same_weights(src, ran_from):
            raise ValueError(f"{Path(ran_from).as_posix()} is not the same network as {names[0]}: its results "
                             "are not this policy's")
        names = [Path(ran_from).as_posix()]
    stats = [json.loads(Path(f).read_text())["statistics"] for f in blind_jsons]
    for name in names:
        if all(name in s for s in stats):
            return name
    raise ValueError(f"the blind results do not all name the policy as {' or '.join(names)}")


def copy_policy(src: str | Path, dst: str | Path) -> tuple[Path, dict]:
    """Copy ``FILES`` of the policy in ``src`` to ``dst`` (nothing if they are the same folder);
    returns ``dst`` and its run record."""
    src, dst = Path(src), Path(dst)
    dst.mkdir(parents=True, exist_ok=True)
    if src.resolve() != dst.resolve():
        for name in policy_files(src):
            shutil.copy2(src / name, dst / name)
    return dst, json.loads((dst / "run.json").read_text())


#: The card's limits of a policy that regresses its action (a Box).
REGRESSION_LIMITS = """* Where the steady velocity is steep in the drive, a small imitation error costs much: the network can
  fall under 0.85 of the teacher over bands of load even where the teacher's drive does not change.
* Where the teacher's best drive jumps from one optimum to another, the network must switch between
  them within a narrow band of k and load; there it can fall between them and stall or go backwards at
  isolated (k, load) points, or, started there, stay in a slower drive (docs/results.md, Limits).
"""
#: The card's limits of a policy that picks its action from a table (Discrete).
CODEBOOK_LIMITS = """* It plays only its teacher's grid drives (the network picks which, each period): never a drive between
  two of them, so at a point it is at best as good as the best grid drive there; fine-tuning
  (`--resume`) changes which it picks, not the drives.
* Where the teacher's best drive jumps from one grid drive to another, the network must switch its pick
  within a narrow band of k and load; a pick of the neighbouring drive there can be slower, and near
  stall the velocity is steep in the drive (docs/results.md, Limits).
"""


def ship(src: str | Path, dst: str | Path, blind_json=None, ran_from: str | Path | None = None) -> Path:
    """Copy the policy in ``src`` (``model.zip``, ``vecnormalize.pkl``, ``run.json``) to ``dst``
    (nothing to copy if they are the same folder) and write its card; with ``blind_json`` (a path or
    a list of them, one per report seed), the card quotes the policy's blind results from each, which
    ran it from ``src``, ``dst`` or ``ran_from`` (:func:`blind_key`)."""
    blind_jsons = [] if blind_json is None else [blind_json] if isinstance(blind_json, (str, Path)) else list(blind_json)
    key = blind_key(blind_jsons, src, dst, ran_from) if blind_jsons else None  # before anything is copied
    dst, run = copy_policy(src, dst)
    size_kb = sum((dst / n).stat().st_size for n in policy_files(dst)) / 1024
    table = run["env_kwargs"].get("action_codebook")
    n_actions = len(np.load(dst / table)) if table else 0
    hyper = {k: v for k, v in run["hyperparameters"].items() if k != "policy_kwargs"}
    card = f"""# {dst.name}: a waveform policy for MDRDrive-v0

One plain Stable-Baselines3 PPO policy for every grading exponent and load in its training range:
it observes k and the load (observation entries 10-12) with the rest of the env's 14 observations
and {f"picks each period's waveform among the {n_actions:,} drives of its teacher's grid (its action is an index, `Discrete({n_actions})`; the table ships as `{table}`, which the env takes as `action_codebook`)" if table else "sets each period's waveform within the paper's actuator limits"}. Nothing but the network acts.

## Load it

{load_snippet(dst, run)}

With Stable-Baselines3 alone:

{snippet(dst, run)}

(`tests/agents/test_pretrained.py` runs both snippets, from another directory.) Or: `mdr-drive evaluate --policy {dst.as_posix()}
--k 0.2 --cargo-mass 0.1 --json`; `mdr-drive train --resume {dst.as_posix()}` fine-tunes it with PPO (copy
the folder first: a resumed run writes into it; the observation statistics stay as distilled).

## How it was made

* Command: `{run['command']}`{recipe_note(run)}
* Training: {training_note(run)}
* Training range (env kwargs): `{json.dumps(run['env_kwargs'])}`
* PPO settings: `{json.dumps(hyper)}`, policy `{json.dumps(run['hyperparameters'].get('policy_kwargs', {}))}`
* Versions: `{json.dumps(run['versions'])}`
* Files: `model.zip` (SB3), `vecnormalize.npz` (observation normalisation, needed to run it, as numbers:
  what `load_policy` reads), `vecnormalize.pkl` (the same for plain SB3: a pickle, which runs code when
  read, so load it only from a source you trust), `run.json`{f", `{table}` (its actions)" if table else ""};
  {size_kb:.0f} KiB in all.

## Limits

* Trained for the ranges above with the paper's friction (mu = 0.3, mu1 = 0.1) and material; `mdr-drive
  evaluate` warns outside the trained k and loads and at other friction coefficients.
* It observes k and the load: a drive that knows neither needs a sensor-only policy (`MDRDriveSensor-v0`).
* Its drives are the teacher's: a grid search with a stated budget, polished from each node's
  neighbours (docs/results.md), not a proven optimum; near stall it can be well short of a per-point
  search, and the network with it (the blind misses in docs/results.md).
{REGRESSION_LIMITS if not table else CODEBOOK_LIMITS}* `mdr-drive dense --policy {dst.as_posix()} --out DIR` maps where it is below the trapezoid on a
  dense grid of the whole domain (no search needed; about a minute); check a working point with
  `mdr-drive evaluate` before relying on it. Builds of one recipe differ with their seeds: a build
  with another `student_seed` is another policy, to be judged again (docs/results.md).

## Evaluation

Steady slider velocity in mm/s, policy (trapezoid), mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS} of a
fresh drive, computed by `mdr-drive model-card {Path(src).as_posix()} {dst.as_posix()}` from the shipped files.
"runaway": the load accelerates the slider backwards without bound.

{evaluation_table(dst)}

{blind_record(blind_jsons, key) if blind_jsons else ''}"""
    write_text(dst / "MODEL_CARD.md", card)
    return dst / "MODEL_CARD.md"


def library_note(table: dict) -> str:
    """Where a sensor table's candidates came from besides the searches at hidden draws: with a library
    (``teacher.drive_table.build``), the recipe's teacher field's drives."""
    if not table.get("library"):
        return "that "
    return (f"from the {table['library']} drives of the recipe's teacher field (told k and the load, at the nominal "
            "friction) and those that ")


def reused_note(command: str) -> str:
    """What a sensor build's wall time leaves out when its command took earlier work (``--reuse``, ``--resume``)."""
    return ("; without the drive table and values it took from `--reuse` or `--resume`"
            if "--reuse" in command or "--resume" in command else "")


def switch_note(sensor: dict) -> str:
    """How a sensor policy's pick prices leaving its drive (``student.pick_rows``), from its settings."""
    text = f" ({sensor['continuation']} x the squared distance from its previous action to the row's partner"
    cost = sensor.get("play_switch_cost", 0.0)
    if cost:
        text += f", and {cost} for any row that does not continue the drive, added to the written policy after the rounds"
    return text + ")"


def ship_sensor(src: str | Path, dst: str | Path, adaptation_json: str | Path) -> Path:
    """Copy the sensor policy in ``src`` to ``dst`` (as :func:`ship`) and write its card, which
    quotes its results from ``adaptation_json`` (``mdr-drive adaptation``)."""
    res = json.loads(Path(adaptation_json).read_text())
    label = sensor_drive_label(res, src)
    dst, run = copy_policy(src, dst)
    picks = run["picks_from"]
    s_sensor = res["statistics"][label]
    size_kb = sum((dst / n).stat().st_size for n in policy_files(dst)) / 1024
    reachable = "load_step_candidates" in res  # the report bounds which steps any drive could recover
    lines = ["| drive | below trapezoid | fraction of best: mean | min | load steps recovered within 5 periods "
             + ("(of those some drive could recover) |" if reachable else "(upward steps) |"), "|---|---|---|---|---|"]
    for drive, st in res["statistics"].items():
        rec = res["load_step_recovery"][drive]
        part = (f"{rec['recoverable_recovered_within']} of {rec['recoverable_scored']}" if reachable
                else f"{rec['upward_recovered_within']} of {rec['upward_steps_scored']}")
        lines.append(f"| {drive} | {st['points_below_trapezoid']} | {st['fraction_of_best_mean']:.3f} | "
                     f"{st['fraction_of_best_min']:.3f} | {rec['recovered_within']} of {rec['episodes_scored']} "
                     f"({part}) |")
    tier = run["env_kwargs"].get("sensor_tier", "encoder")
    table = picks["drive_table"]
    last = picks["history"][-1] if picks["history"] else {}
    recovery = res["load_step_recovery"][label]
    card = f"""# {dst.name}: a waveform policy that does not know its load (MDRDriveSensor-v0, `{tier}` tier)

One plain Stable-Baselines3 PPO policy that drives the slider from what its sensors measure
(the `{tier}` sensor tier: {tier_text(run)}) over the last {run['env_kwargs']['history']} periods,
and the actions that produced them. It is not told k, the load or the friction coefficients
(docs/adaptation.md).

## Load it

{load_snippet(dst, run)}

With Stable-Baselines3 alone:

{snippet(dst, run)}

(`tests/agents/test_pretrained.py` runs both snippets, from another directory.) Or: `mdr-drive evaluate --policy {dst.as_posix()}
--k 0.2 --cargo-mass 0.1 --friction-coefficient 0.25 --load-step 15:0.05 --json` (it plays in its own tier; without
`--friction-coefficient` at the paper's mu 0.3 and mu1 0.1).

## How it was made

* Command: `{run['command']}` (`mdr_drive_agents.train.sensor`, {run['wall_time_s']:.0f} s{reused_note(run['command'])})
* Its actions: {picks['drives']} whole drives (fixed actions and two-action cycles, {picks['rows']} rows in
  `action_codebook.npy`; a cycle plays its two rows in turn) {library_note(table)}CMA-ES found at {table['config']['points']} draws
  of the hidden parameters, picked to cover them: the best of them reaches on average
  {table['coverage']['mean_fraction_of_best_candidate']:.3f} (at worst {table['coverage']['min_fraction_of_best_candidate']:.3f})
  of the best drive found at {table['coverage']['points_moving']} draws where that moves (`teacher.DriveTable`).
* Its network predicts, from the sensor history, what each row is worth at the hidden point (its
  steady velocity as a fraction of the table's best there, penalised below {picks['sensor']['knee']} of it and below
  the trapezoid) and plays the row of the highest prediction, less the cost of leaving the drive it
  plays{switch_note(picks['sensor'])}: the best pick under what the sensor cannot
  tell. Fitted by squared error on {picks['sensor']['episodes']} training draws, by DAgger: round 0 driven by the
  table's best drive told the hidden values, rounds 1-{picks['sensor']['rounds']} by the network itself
  (`student.DriveValueNetwork`). A second head estimates k, the load over mu F_ref, the load and mu1 / mu
  (`estimator.npz`, for plots; standardised errors on the validation draws
  {', '.join(f"{k[10:]} {v:.2f}" for k, v in last.items() if k.startswith('val_error_'))}).
* Settings: `{json.dumps(picks['sensor'])}`
* Training range: the hidden parameters of `MDRDriveSensor-v0` (k 0-0.6, load up to 0.4 of mu F_ref,
  mu 0.2-0.4, mu1 0.07-0.13), half of the episodes with a load step.
* Versions: `{json.dumps(run['versions'])}`
* Files: `model.zip` (SB3), `vecnormalize.npz` (observation normalisation as numbers, what
  `load_policy` reads), `vecnormalize.pkl` (the same for plain SB3: a pickle, which runs code when read),
  `action_codebook.npy` (its rows), `estimator.npz`, `run.json`; {size_kb:.0f} KiB in all.

## Results on blind draws (`mdr-drive adaptation --seed {res['seed']}`)

{res['n']} hidden-parameter draws and {res['load_steps']} load-step episodes of a seed not used to build or
select the policy; fraction of the per-point best drive where it moves >= 2 mm/s. This policy is the
row "{label}".

{chr(10).join(lines)}

## Limits

* It needs its tier's sensor: played on another sensor, or with more noise than it was trained
  with, it is untested.
* It plays only the table's drives, so at a point it is at best as good as the table's best drive
  there; where the sensor cannot tell two hidden points apart it plays a drive good at both, which
  can be slower than the best at either, and it can fall below the trapezoid
  ({below_note(s_sensor, res['n'])}). Check a working point with `mdr-drive evaluate` first.
* Before it has seen a few periods it plays an average drive: the first periods after a reset or a load
  step are slower than a drive told the load (median {_periods(recovery['median_periods_to_recover'])}
  periods to 0.9 of its new steady velocity after a load step).
* Outside the training ranges above it is untested.
"""
    write_text(dst / "MODEL_CARD.md", card)
    return dst / "MODEL_CARD.md"


__all__ = ["CODEBOOK_LIMITS", "REGRESSION_LIMITS", "blind_key", "copy_policy", "evaluation_table", "load_snippet", "ship",
           "ship_sensor", "snippet"]
