"""How a sensor policy drives when k, the load and friction are hidden, and when the load steps.

    mdr-drive adaptation --seed 20261125 --out results/adaptation    # make adaptation

Two experiments on draws of ``MDRDriveSensor-v0``'s hidden parameters (k in [0, 0.6], the load
from 0 to 0.4 of mu F_ref, mu in [0.2, 0.4], mu1 in [0.07, 0.13]) from ``--seed``:

1. **blind points** (``--blind N``): the steady velocity (mean of periods 21-30) of each sensor
   policy (one per sensor tier, each in its own tier), and of their baselines at the same hidden values: the trapezoid; the *tuned-once* fixed
   waveform (CMA-ES at the middle of the ranges: k = 0.3, load 0.2 of mu F_ref, mu = 0.3,
   mu1 = 0.1; what an engineer would tune once); the full-observation policy (told k, the load and
   friction: an upper bound); and the best drive found at the point: the search's
   (``benchmarks.point_search.best_drive``: CMA-ES over fixed actions and two-action cycles at that point's
   friction) or any of the drives above where one beats it. Statistics as the blind benchmark's
   (``benchmarks.targets.velocity_statistics``).
2. **load steps** (``--load-steps M``): 40-period episodes whose cargo changes before period 20 to
   another draw of the same range; per drive, the velocity per period, and whether it is back to
   ``RECOVERY_FRACTION`` of its own steady velocity at the new load (mean of the last 10 periods)
   within ``RECOVERY_PERIODS`` periods: the mean of the two periods after them (20 + 5 and 20 + 6)
   reaches it. Scored where that steady velocity is at least 2 mm/s; and, of those steps, the ones
   some drive could recover (``load_steps.fastest_recovery``: a drive of the sensor policy's table,
   played from the step, or any drive of the report, reaches that fraction of the drive's steady
   velocity by then).

Writes ``adaptation.json``, ``adaptation.md``, ``points.csv``, ``load_steps.csv`` and the plots
``adaptation_load_steps.png`` and ``adaptation_tracking.png``. The per-point searches run on the
sweep executor (``--workers``, ``--ray-address``) and are kept as they finish (``--resume``);
``--reuse-search ADAPTATION.json`` takes them from an earlier run of the same seed, sizes and
budgets, so that several sensor policies are compared on one search (only the drives run).
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np

from mdr_drive_env.files import json_safe, save_figure, write_csv, write_text
from mdr_drive_env.gym_envs.spaces import PrivilegedLayout
from mdr_drive_env.sweep import Executor, TaskStore, task_folder

from ..drive import PAPER_DRIVE, DriveDescription
from ..policy import load_policy
from ..protocol import (AVERAGE_PERIODS, EVAL_PERIODS, draw_hidden, drive_of, env_rollout, format_velocity, hidden_point,
                        play_drive, steady_velocity_of)
from ..search import CMA_BUDGET, CYCLE_SEARCH, cma_optimize
from .blind import QUICK
from .load_steps import (RECOVERY_FRACTION, RECOVERY_PERIODS, STEP_EPISODE_PERIODS, STEP_PERIOD, candidate_drives,
                         fastest_recovery, recovery, recovery_record, recovery_window)
from .point_search import PointTask, best_drive
from .targets import velocity_statistics

SENSOR_POLICY = "agents/pretrained/ppo_sensor"
FULL_POLICY = "agents/pretrained/ppo_sensor/teacher"  # told k, the load and mu1/mu: the upper bound the sensor policies approximate
#: The issue's floor on a sensor drive's fraction of the per-point best drive ("under 0.75" in the tables).
FRACTION_FLOOR = 0.75
#: The drives of a report with one sensor policy; a report's own are ``res["drives"]`` (``drive_labels``).
DRIVES = ("sensor policy", "full-observation policy", "trapezoid", "tuned once")
BASELINES = DRIVES[1:]


def drive_labels(sensor_policies: list) -> list[str]:
    """The report's drives: one label per sensor policy (``"sensor policy"`` alone; with several,
    ``"sensor policy (TIER)"`` by the tier its run.json names, then by folder where tiers repeat), then
    ``BASELINES``."""
    if len(sensor_policies) == 1:
        return list(DRIVES)
    tiers = [p.play_kwargs.get("sensor_tier", "encoder") for p in sensor_policies]
    labels = [f"sensor policy ({t})" if tiers.count(t) == 1 else f"sensor policy ({t}, {Path(p.folder).name})"
              for t, p in zip(tiers, sensor_policies)]
    if len(set(labels)) < len(labels):
        raise ValueError(f"the sensor policies {[str(p.folder) for p in sensor_policies]} are not told apart by "
                         "tier and folder name")
    return [*labels, *BASELINES]


def action_map_of(res: dict):
    """The action map of the drive a report's policies played on (its ``drive``; the paper's without one)."""
    return (PAPER_DRIVE if res.get("drive") is None else DriveDescription.from_record(res["drive"])).action_map()


def tuned_once_point(drive: DriveDescription = PAPER_DRIVE) -> dict:
    """The tuned-once waveform's point: the middle of the sensor env's ranges on ``drive`` (k, load ratio,
    mu, mu1; ``DriveDescription.sensor_env_kwargs``): k 0.3, 0.2, 0.3 and 0.1 on the paper's drive."""
    ranges = drive.sensor_env_kwargs()
    return {key: round((ranges[key][0] + ranges[key][1]) / 2.0, 12)
            for key in ("k", "load_ratio", "friction_coefficient", "base_friction_coefficient")}


def tuned_once_action(budget: int = CMA_BUDGET, drive: DriveDescription = PAPER_DRIVE) -> np.ndarray:
    """The best fixed action CMA-ES finds at ``tuned_once_point(drive)``."""
    p = tuned_once_point(drive)
    env = gym.make("MDRDrive-v0", **{**drive.env_kwargs, **p})
    _, info = env.reset(seed=0)
    return cma_optimize(p["k"], info["cargo_mass"], budget,
                        friction=(p["friction_coefficient"], p["base_friction_coefficient"]), drive=drive).action


class FixedAction:
    """``obs -> action``: the same action every period, on ``drive`` (its ``play_kwargs``)."""

    def __init__(self, action, drive: DriveDescription = PAPER_DRIVE):
        self.action = np.asarray(action, dtype=np.float32)
        self.play_kwargs = drive.env_kwargs

    def __call__(self, obs):
        return np.tile(self.action, (len(obs), 1))


def play(drive: str, policies: dict, d: dict, periods: int, load_step=None, on: DriveDescription = PAPER_DRIVE):
    """One run of ``drive`` at the hidden values ``d`` on the drive ``on`` (the trapezoid's; a policy plays
    on its own): (velocity per period (periods,) m/s, actions, runaway)."""
    friction = {"friction_coefficient": d["friction_coefficient"],
                "base_friction_coefficient": d["base_friction_coefficient"]}
    return env_rollout(policies[drive], d["k"], d["cargo_mass"], periods, load_step, drive=on, **friction)


def estimator_of(policy):
    """A sensor policy's own estimator (its ``estimator.npz``), or None for a policy without one."""
    from ..policy import ESTIMATOR_FILE
    from ..student.estimator import Estimator

    if policy is None or policy.folder is None or not (Path(policy.folder) / ESTIMATOR_FILE).is_file():
        return None
    return Estimator.load(Path(policy.folder) / ESTIMATOR_FILE)


def estimates_through(policy, est, d: dict, periods: int, load_step=None) -> dict:
    """The estimates of a sensor policy's estimator ``est`` (``estimator_of``) of the hidden entries
    through one run of the policy at the hidden values ``d``, beside the truth: ``{"names",
    "estimate", "truth"}`` ((periods, n) each, in the privileged observation's units)."""
    env = policy.make_env(k=d["k"], cargo_mass=d["cargo_mass"], friction_coefficient=d["friction_coefficient"],
                          base_friction_coefficient=d["base_friction_coefficient"], max_periods=periods)
    obs, _ = env.reset(seed=0, options={"load_step": load_step} if load_step else None)
    names = [str(n) for n in est.names]
    index = [PrivilegedLayout.NAMES.index(n) for n in names]
    policy.reset()
    estimate, truth = [], []
    for _ in range(periods):
        truth.append(env.unwrapped.privileged_observation(friction=True)[index])
        estimate.append(est(obs[None])[0])
        obs, *_ = env.step(policy.predict(obs))
    return {"names": names, "estimate": np.array(estimate), "truth": np.array(truth)}


def reusable_search(path: str | Path, seed: int, n: int, search: dict) -> list[dict]:
    """The per-point searches of the earlier ``adaptation.json`` at ``path`` if it drew and searched
    as this run asks (``seed``, ``n`` blind points, ``search`` budgets), else ``ValueError`` saying
    what differs."""
    previous = json.loads(Path(path).read_text())
    for key, value in (("seed", seed), ("n", n), ("search", search)):
        if previous.get(key) != value:
            raise ValueError(f"--reuse-search {path}: its {key} {previous.get(key)!r} is not this run's {value!r}")
    return previous["best_search"]


def run(sensor_policy, full_policy: str, n: int, n_steps: int, seed: int, out: str | Path, quick: bool = False,
        executor: Executor | None = None, resume: bool = False, reuse: str | Path | None = None) -> dict:
    """Both experiments (module docstring) into ``out``; returns what ``adaptation.json`` holds.
    ``sensor_policy``: a policy folder or a list of them (one per tier, ``drive_labels``). ``reuse``:
    an earlier ``adaptation.json`` whose per-point searches are taken (``reusable_search``)."""
    out = Path(out)
    executor = executor or Executor()
    fixed_budget = QUICK["fixed_budget"] if quick else CMA_BUDGET
    cycle_budget = QUICK["cycle_budget"] if quick else CYCLE_SEARCH["budget"]
    folders = [sensor_policy] if isinstance(sensor_policy, (str, Path)) else list(sensor_policy)
    sensors = [load_policy(f) for f in folders]
    on = play_drive(sensors)  # the drive they were built for, and its hidden ranges
    full = load_policy(full_policy)
    if drive_of(full, on).stage_settings != on.stage_settings:
        raise ValueError(f"--full-policy {full_policy} was built for another drive than the sensor policies' ({on.name})")
    drives = drive_labels(sensors)
    policies = {**dict(zip(drives, sensors)), "full-observation policy": full,
                "trapezoid": None, "tuned once": FixedAction(tuned_once_action(fixed_budget, on), on)}
    search = {"fixed_budget": fixed_budget, "cycle_budget": cycle_budget}
    points = draw_hidden(n, seed, drive=on)
    tasks = [PointTask(d["k"], d["cargo_mass"], fixed_budget, cycle_budget,
                       (d["friction_coefficient"], d["base_friction_coefficient"]), drive=on) for d in points]
    store = TaskStore(task_folder(out, resume) / "best")
    if reuse:
        best_runs = reusable_search(reuse, seed, n, search)
    else:
        best_runs = executor.map(best_drive, tasks, "adaptation: best drive per point", store=store)
    steady, actions = {}, {}
    for drive in drives:
        runs = [play(drive, policies, d, EVAL_PERIODS, on=on) for d in points]
        steady[drive] = steady_velocity_of(np.array([r[0] for r in runs]).T * on.period, period=on.period,
                                           runaway=[r[2] for r in runs])
        actions[drive] = np.array([r[1][-AVERAGE_PERIODS:] for r in runs])
    # the best drive found at each point: the search's, or any drive's that beat it
    best = np.nanmax(np.array([[r["velocity"] for r in best_runs], *steady.values()]), axis=0)
    stats = {drive: velocity_statistics(steady["trapezoid"], best, steady[drive]) for drive in drives}

    steps = draw_hidden(n_steps, seed + 1, step_period=STEP_PERIOD, drive=on)
    series, step_actions = {}, {}
    for drive in drives:
        runs = [play(drive, policies, d, STEP_EPISODE_PERIODS, (STEP_PERIOD, d["step_cargo_mass"]), on) for d in steps]
        series[drive] = np.array([r[0] for r in runs])
        step_actions[drive] = np.array([r[1] for r in runs])
    codebook = next((p.codebook for p in sensors if p.codebook is not None), None)
    candidates = candidate_drives(codebook)
    reach = np.array([max(fastest_recovery(candidates, policies["full-observation policy"], d),
                          *(recovery_window(series[drive][e]) for drive in drives)) for e, d in enumerate(steps)])
    recovered = {drive: recovery_record(series[drive], steps, reach) for drive in drives}
    est = estimator_of(sensors[0])  # the first sensor policy's own estimates, where it has an estimator
    tracked = [] if est is None else [
        estimates_through(sensors[0], est, d, STEP_EPISODE_PERIODS, (STEP_PERIOD, d["step_cargo_mass"])) for d in steps]
    res = {"seed": seed, "n": n, "load_steps": n_steps, "quick": quick, "drives": drives,
           "load_step_estimates": None if est is None else {
               "drive": drives[0], "names": tracked[0]["names"] if tracked else [],
               "estimate": [t["estimate"] for t in tracked], "truth": [t["truth"] for t in tracked]},
           "sensor_policy": str(folders[0]) if len(folders) == 1 else [str(f) for f in folders],
           "sensor_tiers": {d: p.play_kwargs.get("sensor_tier", "encoder") for d, p in zip(drives, sensors)},
           "full_policy": str(full_policy), "tuned_once_point": tuned_once_point(on),
           "drive": None if on.is_paper else on.to_record(),
           "tuned_once_action": policies["tuned once"].action.tolist(),
           "search": search, "search_reused_from": None if reuse is None else str(reuse),
           "protocol": f"steady velocity: mean of periods {EVAL_PERIODS - AVERAGE_PERIODS + 1}-{EVAL_PERIODS}; "
                       f"load steps before period {STEP_PERIOD} of {STEP_EPISODE_PERIODS}, recovery within "
                       f"{RECOVERY_PERIODS} periods to {RECOVERY_FRACTION} of the steady velocity at the new load",
           "points": points, "best_search": best_runs, "best_velocity_m_s": best, "steady_velocity_m_s": {d: steady[d] for d in drives},
           "statistics": stats, "load_step_episodes": steps,
           "load_step_velocity_m_s": {d: series[d] for d in drives}, "load_step_recovery": recovered,
           "load_step_reachable_m_s": reach, "load_step_candidates": len(candidates),
           "steady_actions": {d: actions[d] for d in drives}, "load_step_actions": {d: step_actions[d] for d in drives}}
    write_outputs(res, out)
    store.clear()
    return res


def drives_of(res: dict) -> list[str]:
    """The drives of a report (``res["drives"]``; ``DRIVES`` in a report written before it had them)."""
    return list(res.get("drives", DRIVES))


def markdown(res: dict) -> str:
    drives = drives_of(res)
    lines = [f"# Adaptation: seed {res['seed']}{' (quick)' if res['quick'] else ''}", "",
             f"{res['n']} blind points and {res['load_steps']} load-step episodes of MDRDriveSensor-v0's hidden "
             f"parameters" + (f" on drive {res['drive']['name']}" if res.get("drive") else "") + f"; {res['protocol']}.",
             "",
             "| drive | below trapezoid | worst vs trapezoid (mm/s) | fraction of best: mean | min | scored |",
             "|---|---|---|---|---|---|"]
    for drive, s in res["statistics"].items():
        lines.append(f"| {drive} | {s['points_below_trapezoid']} | {_f(s['worst_difference_to_trapezoid_mm_s'])} | "
                     f"{_f(s['fraction_of_best_mean'])} | {_f(s['fraction_of_best_min'])} | {s['points_scored']} |")
    reachable = "load_step_candidates" in res  # a report written before the bound has no such column
    lines += ["", "Load steps, where the drive's steady velocity at the new load is >= 2 mm/s"
              + (f" (recoverable: where one of {res['load_step_candidates']} drives of the sensor policy's table, "
                 "played from the step, or a drive of this report reaches 0.9 of it within 5 periods):"
                 if reachable else ":"), "",
              "| drive | recovered within 5 periods | " + ("of the recoverable | " if reachable else "")
              + "of them upward steps | median periods to 0.9 | stalled after the step |",
              "|---|---|---|---|---|" + ("---|" if reachable else "")]
    for drive, r in res["load_step_recovery"].items():
        recoverable = f"{r['recoverable_recovered_within']} of {r['recoverable_scored']} | " if reachable else ""
        lines.append(f"| {drive} | {r['recovered_within']} of {r['episodes_scored']} | {recoverable}"
                     f"{r['upward_recovered_within']} of {r['upward_steps_scored']} | "
                     f"{_f(r['median_periods_to_recover'])} | {r['stalled_after_step']} of {res['load_steps']} |")
    lines += ["", "Steady velocities (mm/s); best: the best drive found (the search's, or a drive's that beat it).", "",
              "| k | load ratio | mu | mu1 | best | " + " | ".join(drives) + " |",
              "|---|---|---|---|---|" + "---|" * len(drives)]
    for i, d in enumerate(res["points"]):
        cells = [format_velocity(res["steady_velocity_m_s"][drive][i], digits=2) for drive in drives]
        lines.append(f"| {d['k']:.3f} | {d['load_ratio']:.3f} | {d['friction_coefficient']:.3f} | "
                     f"{d['base_friction_coefficient']:.3f} | {format_velocity(res['best_velocity_m_s'][i], digits=2)} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _f(x) -> str:
    return "-" if x is None else f"{x:.3f}"


def write_outputs(res: dict, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    drives = drives_of(res)
    write_text(out / "adaptation.json", json.dumps(json_safe(res)))  # compact: every period of every episode
    write_text(out / "adaptation.md", markdown(res))
    header = ["k", "cargo_mass_kg", "friction_coefficient", "base_friction_coefficient", "load_ratio",
              "best_m_s", *[f"{column_name(d)}_m_s" for d in drives]]
    write_csv(out / "points.csv", header, [
        [d["k"], d["cargo_mass"], d["friction_coefficient"], d["base_friction_coefficient"], d["load_ratio"],
         res["best_velocity_m_s"][i], *[res["steady_velocity_m_s"][drive][i] for drive in drives]]
        for i, d in enumerate(res["points"])])
    write_csv(out / "load_steps.csv", ["episode", "drive", "period", "velocity_m_s"], [
        [e, drive, t, v] for drive in drives for e, row in enumerate(res["load_step_velocity_m_s"][drive])
        for t, v in enumerate(row)])
    plot(res, out)


def column_name(drive: str) -> str:
    """``drive`` as a CSV column name (``sensor policy (trace)`` -> ``sensor_policy_trace``)."""
    return "_".join("".join(c if c.isalnum() else " " for c in drive).split())


def plot(res: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = res["load_step_episodes"]
    amap = action_map_of(res)
    change = np.array([d["step_cargo_mass"] - d["cargo_mass"] for d in steps])
    picks = [("load stepped up", int(np.argmax(change))), ("load stepped down", int(np.argmin(change)))]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    drives = drives_of(res)
    sensors = drives[:-len(BASELINES)]
    colors = {**dict(zip(sensors, ("C0", "C2", "C4", "C5", "C6"))), **dict(zip(BASELINES, ("C1", "0.4", "C3")))}
    for col, (title, e) in enumerate(picks):
        d = steps[e]
        t = np.arange(1, STEP_EPISODE_PERIODS + 1)
        for drive in drives:
            axes[0, col].plot(t, np.asarray(res["load_step_velocity_m_s"][drive][e]) * 1e3, color=colors[drive],
                              label=drive, lw=1.5 if "policy" in drive else 1.0)
            if "policy" in drive:
                x_amp = [amap.to_params(a).x_amplitude * 1e6 for a in res["load_step_actions"][drive][e]]
                axes[1, col].plot(t, x_amp, color=colors[drive], label=drive)
        for ax in axes[:, col]:
            ax.axvline(STEP_PERIOD + 0.5, color="k", ls=":", lw=0.8)
        axes[0, col].set_title(f"{title}: k = {d['k']:.2f}, mu = {d['friction_coefficient']:.2f}, "
                               f"{d['cargo_mass'] * 1e3:.0f} -> {d['step_cargo_mass'] * 1e3:.0f} g", fontsize=9)
        axes[1, col].set_xlabel("period")
        axes[1, col].set_ylim(0.0, 1.05 * amap.x_amplitude_max * 1e6)  # the whole stroke, on both panels
    axes[0, 0].set_ylabel("mean velocity per period (mm/s)")
    axes[1, 0].set_ylabel("x amplitude played (µm)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"blind load steps (seed {res['seed']}): the hidden cargo changes before period {STEP_PERIOD + 1}; "
                 "velocity (top) and the x stroke each policy plays (bottom)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out / "adaptation_load_steps.png")
    plt.close(fig)

    if res.get("load_step_estimates"):
        plot_estimates(res, picks, out)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    ratio = np.array([d["load_ratio"] for d in res["points"]])
    ks = np.array([d["k"] for d in res["points"]])
    panels = ((lambda ep: min(amap.to_params(a).x_amplitude for a in ep) * 1e6,
               "smallest x amplitude, periods 21-30 (µm)"),
              (lambda ep: amap.to_params(ep[-1]).z_phase, "z phase of period 30 (-)"))
    for ax, (value_of, label) in zip(axes, panels):
        for drive, marker, alpha in (("full-observation policy", "o", 0.35), *((s, m, 1.0) for s, m in
                                                                          zip(sensors, "x+1234"))):
            values = [value_of(ep) for ep in np.asarray(res["steady_actions"][drive])]
            sc = ax.scatter(ratio, values, c=ks, cmap="viridis", vmin=0, vmax=0.6, marker=marker, label=drive,
                            alpha=alpha)
        ax.set_xlabel("hidden load / (mu F_ref)")
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    fig.colorbar(sc, ax=axes, label="hidden k")
    fig.suptitle(f"what each policy plays once settled, at the {len(ks)} blind draws (seed {res['seed']}), against "
                 "the hidden load; colour: the hidden k", fontsize=10)
    save_figure(fig, out / "adaptation_tracking.png")
    plt.close(fig)


#: How the estimate plot labels each hidden entry (the privileged observation's names and units).
ESTIMATE_LABELS = {"k": "k (-)", "load_over_friction": "load / (mu F_ref) (-)", "load_over_10N": "load / 10 N (-)",
                   "friction_ratio": "mu1 / mu (-)"}


def plot_estimates(res: dict, picks: list[tuple[str, int]], out: Path) -> None:
    """``adaptation_estimates.png``: the first sensor policy's estimate of each hidden entry per
    period (solid) against the truth (dashed) through the load-step episodes ``picks``."""
    import matplotlib.pyplot as plt

    tracked = res["load_step_estimates"]
    names = tracked["names"]
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.9 * len(names) + 0.6), sharex=True, squeeze=False)
    t = np.arange(1, STEP_EPISODE_PERIODS + 1)
    for (title, e), color in zip(picks, ("C0", "C3")):
        estimate, truth = np.asarray(tracked["estimate"][e]), np.asarray(tracked["truth"][e])
        for j, name in enumerate(names):
            ax = axes[j, 0]
            ax.plot(t, estimate[:, j], color=color, lw=1.5, label=f"{title}: estimate")
            ax.plot(t, truth[:, j], color=color, lw=1.0, ls="--", label=f"{title}: hidden value")
            ax.axvline(STEP_PERIOD + 0.5, color="k", ls=":", lw=0.8)
            ax.set_ylabel(ESTIMATE_LABELS.get(name, name), fontsize=8)
    axes[0, 0].set_title(f"{tracked['drive']}: what it reads from its sensor, through a load step", fontsize=9)
    axes[0, 0].legend(fontsize=7, ncol=2)
    axes[-1, 0].set_xlabel("period")
    fig.tight_layout()
    save_figure(fig, out / "adaptation_estimates.png")
    plt.close(fig)


__all__ = ["BASELINES", "DRIVES", "ESTIMATE_LABELS", "FixedAction", "action_map_of", "tuned_once_point", "estimates_through", "estimator_of", "plot_estimates", "column_name", "drive_labels", "drives_of", "draw_hidden", "hidden_point", "markdown", "plot", "recovery", "run", "tuned_once_action"]
