"""The outputs of ``mdr-drive rl-baselines``: ``benchmark.md`` (one table, as the RL Zoo's), the
learning curves (``curves.png``), ``results.json`` (every run's curve and every aggregate) and the
tuned hyperparameters as RL-Zoo YAML files (``hyperparameters/<algo>.yaml``, which
``mdr-drive train --config`` reads)."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import yaml

from mdr_drive_env import ENV_ID
from mdr_drive_env.files import json_safe, write_text

from ..benchmarks.score import aggregate
from ..train.hyperparameters import load_config
from .config import BaselinesConfig
from .runner import Plan, slug

#: Bootstrap resamples of each point of a learning curve and of each band (the main table's use the default).
CURVE_REPS = 2000
#: Bands of the load, as a fraction of the trapezoid's critical load at the point's k.
LOAD_BANDS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25)


def run_scores(plan: Plan, run: dict, index: int = -1) -> tuple[list, list, list]:
    """(scores, fractions of the best, velocities) of one run's evaluation ``index``, per report record."""
    _, parts = plan.split(run["velocities"][index])
    return ([ref.scores(v) for ref, v in zip(plan.reports, parts)],
            [ref.fractions_of_best(v) for ref, v in zip(plan.reports, parts)], parts)


def agent_summary(plan: Plan, runs: list[dict]) -> dict:
    """The aggregates of one agent's final runs on the report records: strata are (seed, record)."""
    scores, fractions, below = [], [], []
    for run in runs:
        s, f, parts = run_scores(plan, run)
        scores += s
        fractions += f
        below.append(sum(ref.statistics(v)["points_below_trapezoid"] for ref, v in zip(plan.reports, parts)))
    validation = [float(np.nanmean(plan.validation.scores(plan.split(r["velocities"][-1])[0]))) for r in runs]
    return {"score": aggregate(scores), "fraction_of_best": aggregate(fractions),
            "points_below_trapezoid_per_run": below, "validation_mean_score": validation,
            "steps": [r["total_timesteps"] for r in runs], "wall_time_s": [r["wall_time_s"] for r in runs],
            "train_seconds": [r["train_seconds"][-1] for r in runs]}


def reference_rows(plan: Plan) -> dict:
    """The fraction of the best drive of the trapezoid (its score is 0 by definition), and the score
    and fraction of the policies every report record judged (their ``learned``, e.g. the distilled
    generalist: not plain RL), as measured by those benchmarks."""
    rows = {"trapezoid": {"fraction_of_best": aggregate([r.fractions_of_best(r.trapezoid) for r in plan.reports])}}
    common = set.intersection(*(set(r.learned) for r in plan.reports))
    for policy in sorted(common):
        rows[policy] = {"score": aggregate([r.scores(r.learned[policy]) for r in plan.reports]),
                        "fraction_of_best": aggregate([r.fractions_of_best(r.learned[policy]) for r in plan.reports])}
    return rows


def band_scores(plan: Plan, found: dict) -> dict:
    """The IQM score of every agent's final runs and of the records' own policies in each load band
    (``LOAD_BANDS``), over seeds and points: where along the load each falls short."""
    fractions = [ref.load_fractions() for ref in plan.reports]
    edges = np.array(LOAD_BANDS[1:-1])
    bands = [np.digitize(f, edges) for f in fractions]

    def per_band(score_sets):  # score_sets: one array per (run, record), the record's points
        return [aggregate([s[bands[j % len(bands)] == b] for j, s in enumerate(score_sets)], reps=CURVE_REPS)
                for b in range(len(LOAD_BANDS) - 1)]

    rows = {name: per_band([s for run in runs for s in run_scores(plan, run)[0]]) for name, runs in found["runs"].items()}
    for policy in sorted(set.intersection(*(set(r.learned) for r in plan.reports))):
        rows[f"`{policy}`"] = per_band([r.scores(r.learned[policy]) for r in plan.reports])
    return rows


def band_table(rows: dict) -> str:
    """The load bands' table of ``band_scores``: IQM and its interval, scored points in brackets."""
    heads = [f"{lo:g}-{hi:g}" for lo, hi in zip(LOAD_BANDS[:-1], LOAD_BANDS[1:])]
    lines = ["| agent | " + " | ".join(f"load {h} x critical" for h in heads) + " |", "|---|" + "---|" * len(heads)]
    for name, cells in rows.items():
        lines.append(f"| {name} | " + " | ".join(f"{_cell(c, 'iqm')} ({c['scores']})" if c.get("iqm") is not None
                                                 else "-" for c in cells) + " |")
    return "\n".join(lines)


def curve_aggregates(plan: Plan, runs: list[dict]) -> list[dict]:
    """The IQM score with its interval at each evaluation of a learning curve (runs of one agent
    evaluated at the same steps)."""
    out = []
    for i in range(min(len(r["velocities"]) for r in runs)):
        strata = [s for r in runs for s in run_scores(plan, r, i)[0]]
        out.append({"steps": int(np.median([r["steps"][i] for r in runs])),
                    "train_seconds": float(np.median([r["train_seconds"][i] for r in runs])),
                    **aggregate(strata, reps=CURVE_REPS)})
    return out


def hyperparameter_yaml(agent, tuned: dict, time_quantum: float) -> str:
    """The RL-Zoo YAML of an agent (``config.Agent``): its config's block with the searched and its
    own hyperparameters, its steps, its env keywords and the time quantum the references' drives act
    at, and its warm start (``mdr-drive train --config`` reads it)."""
    hyper, env_kwargs = load_config(agent.algo, agent.config)
    hyper.pop("warm_start", None)
    block = {**hyper, **tuned, **(agent.hyperparameters or {}), "n_timesteps": agent.steps,
             "env_kwargs": {**env_kwargs, **(agent.env_kwargs or {}), "time_quantum": time_quantum}}
    return yaml.safe_dump({ENV_ID: json_safe(block), "warm_start": agent.warm_start}, sort_keys=False)


def _cell(agg: dict, key: str) -> str:
    if not agg or agg.get(key) is None:
        return "-"
    v, lo, hi = agg[key]
    return f"{v:.3f} [{lo:.3f}, {hi:.3f}]"


def table(config: BaselinesConfig, plan: Plan, summaries: dict, searches: dict, refs: dict, bands: dict) -> str:
    """benchmark.md: one row per algorithm and the trapezoid's."""
    points = sum(len(r.points) for r in plan.reports)
    lines = [
        f"# Plain RL on {ENV_ID}", "",
        f"Written by `mdr-drive rl-baselines` (`make rl-baselines`). Scored on the {points} points of the blind "
        f"record(s) {', '.join(r.name for r in plan.reports)}; hyperparameters searched on those of "
        f"{plan.validation.name} (never reported). Score: (V - V_trapezoid) / (V_best - V_trapezoid) per point "
        "where the best drive beats the trapezoid by 2 mm/s; fraction of the best drive where it moves at least "
        "2 mm/s. IQM and mean with 95 % stratified-bootstrap intervals over training seeds and points "
        f"(seeds {', '.join(map(str, config.seeds))}). Every run from scratch (no teacher, no action table, no "
        "warm start) unless its row's name says otherwise.", "",
        "| agent | env steps per run | search (trials x steps) | score IQM | score mean | fraction of the best: "
        "mean | points below the trapezoid per run | training s per run |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for agent in config.agents:
        s = summaries[agent.label]
        search = f"{agent.tune_trials} x {agent.tune_steps:,}" if agent.tune_trials else "none"
        below = s["points_below_trapezoid_per_run"]
        lines.append(f"| {agent.label} | {agent.steps:,} | {search} | {_cell(s['score'], 'iqm')} | "
                     f"{_cell(s['score'], 'mean')} | {_cell(s['fraction_of_best'], 'mean')} | "
                     f"{int(np.median(below))} (median of {len(below)}; {min(below)}-{max(below)}) | "
                     f"{np.median(s['train_seconds']):.0f} |")
    lines.append(f"| trapezoid (the paper's waveform) | - | - | 0 | 0 | {_cell(refs['trapezoid']['fraction_of_best'], 'mean')}"
                 " | 0 | - |")
    for policy, row in refs.items():
        if policy != "trapezoid":
            lines.append(f"| `{policy}` (as its records measured it; not plain RL) | - | - | {_cell(row['score'], 'iqm')} | "
                         f"{_cell(row['score'], 'mean')} | {_cell(row['fraction_of_best'], 'mean')} | - | - |")
    scored = next(iter(summaries.values()))["score"]["scores"]
    lines += ["", f"Each algorithm's aggregates are over {scored:,} scores (seeds x scored points).", ""]
    for agent in config.agents:
        found = searches[agent.label]
        if found.get("trials"):
            lines.append(f"- {agent.label}: best of {len(found['trials'])} trials, validation mean score "
                         f"{found['best_validation_mean_score']:.3f}.")
    lines.append("- Each agent's hyperparameters, as `mdr-drive train --config` reads them: "
                 "`hyperparameters/<agent>.yaml`.")
    cycles = [a.label for a in config.agents if (a.hyperparameters or {}).get("action_cycle", 1) == 2]
    if cycles:
        lines.append(f"- {', '.join(cycles)}: one step plays a two-period cycle, so a run plays twice its steps in "
                     "drive periods.")
    lines += ["", "Score IQM by load (the cargo over the trapezoid's critical load at the point's k; scores in "
              "brackets):", "", band_table(bands)]
    return "\n".join(lines) + "\n"


def plot_curves(path: Path, config: BaselinesConfig, curves: dict) -> None:
    """The IQM score against environment steps and against training seconds, with intervals; the
    legend below both panels, where it hides no curve."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
    for agent in config.agents:
        c = [p for p in curves[agent.label] if p.get("iqm") is not None]
        if not c:
            continue
        iqm = np.array([p["iqm"] for p in c])
        for ax, x in zip(axes, (np.array([p["steps"] for p in c]), np.array([p["train_seconds"] for p in c]))):
            ax.plot(x, iqm[:, 0], marker="o", ms=3, label=agent.label)
            ax.fill_between(x, iqm[:, 1], iqm[:, 2], alpha=0.25)
    plain = FuncFormatter(lambda x, _: f"{x / 1e6:g}M" if x >= 1e6 else f"{x / 1e3:g}k" if x >= 1e3 else f"{x:g}")
    for ax, label in zip(axes, ("environment steps (drive periods)", "training time per run (s, 1 core)")):
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # 1, 2, 5 per decade, as plain numbers
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(label)
        ax.axhline(0.0, color="k", lw=0.8, ls="--")
        ax.axhline(1.0, color="0.5", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("normalised score, IQM (0 trapezoid, 1 best drive)")
    handles, labels = axes[0].get_legend_handles_labels()
    rows = -(-len(labels) // 3)
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=9)
    fig.suptitle(f"Plain RL on {ENV_ID}: IQM score with 95 % bootstrap intervals over seeds and points")
    fig.tight_layout(rect=(0.0, 0.05 + 0.045 * rows, 1.0, 1.0))  # room for the legend below
    from mdr_drive_env.files import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)


def write_report(out: str | Path, config: BaselinesConfig, found: dict) -> dict:
    """Write benchmark.md, curves.png, results.json and hyperparameters/ into ``out``; returns the
    summaries."""
    out = Path(out)
    plan: Plan = found["plan"]
    summaries = {name: agent_summary(plan, runs) for name, runs in found["runs"].items()}
    curves = {name: curve_aggregates(plan, runs) for name, runs in found["runs"].items()}
    refs = reference_rows(plan)
    bands = band_scores(plan, found)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "benchmark.md", table(config, plan, summaries, found["searches"], refs, bands))
    plot_curves(out / "curves.png", config, curves)
    for agent in config.agents:
        tuned = found["searches"][agent.label]["hyperparameters"]
        (out / "hyperparameters").mkdir(exist_ok=True)
        write_text(out / "hyperparameters" / f"{slug(agent)}.yaml", hyperparameter_yaml(agent, tuned, plan.time_quantum))
    results = {"config": asdict(config), "validation": plan.validation.name, "reports": [r.name for r in plan.reports],
               "time_quantum_s": plan.time_quantum, "summaries": summaries, "curves": curves, "references": refs,
               "searches": found["searches"], "load_bands": {"edges": LOAD_BANDS, "iqm_score": bands}, "runs": found["runs"]}
    write_text(out / "results.json", json.dumps(json_safe(results)))  # compact: every run's whole curve
    return summaries


__all__ = ["agent_summary", "curve_aggregates", "hyperparameter_yaml", "plot_curves", "table", "write_report"]
