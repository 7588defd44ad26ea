#!/usr/bin/env python
"""Policies against the recipe's teacher on many blind-domain points, without per-point searches.

    python scripts/teacher_check.py --n 192 --seed 7717 --field results/recipe/teacher_field.npz \
        agents/pretrained/ppo_generalist runs/recipe/policy

A cheaper check than ``mdr-drive benchmark --blind`` for deciding between recipe variants: N points
drawn as the blind benchmark draws them (k uniform in [0, 0.6], load up to 1.25 times the
trapezoid's critical load), and as the reference at each point, instead of a CMA-ES search, the
best of the teacher's grid drives around it (``DriveField.best`` with a radius of 3: the
interpolation and the 6 x 6 nearest grid drives, played at the point) or any drive here that beats
it. Per policy, with the blind benchmark's statistics: points below the trapezoid by more than
0.05 mm/s (where either moves), the fraction of that reference where it moves >= 2 mm/s (mean,
minimum, points under 0.85), and the critical load at ``--scan-ks`` values of k (the midpoints of
equal cells of [0, 0.6], so none is a k of the blind benchmark's 25-value scan) over the teacher's
own (``teacher_data.teacher_drives`` with the recipe's settings, as the recipe's student was taught) and over the trapezoid's
(``--scan-range`` cuts another k interval into the cells; ``--scan-seed`` draws one uniform k in each
cell instead of its midpoint), with the k under 0.97 of the teacher's listed. The
reference is weaker than the benchmark's search, so fractions read higher here; use it to compare
policies, and report on ``mdr-drive benchmark --blind``.

``--worst`` lists each policy's points under 0.85 of the reference or below the trapezoid, worst
first, with every drive's velocity there (to find a build's bands, then ``scripts/load_line.py``).

``--cycle-scan`` adds the blind benchmark's reference for the critical load at the same k values:
the best two-action cycle's (``agents.baselines.cycle_critical_load``, its budget; about 6 minutes
for 24 k on 2 cores), and prints the teacher's and each policy's critical load over it, so one can
tell whether a shortfall against the benchmark's target is the teacher's or the student's;
``--cycle-scan-file`` keeps that scan, so another policy is judged on it without searching again:

    python scripts/teacher_check.py --n 1 --seed 1 --scan-ks 20 --scan-range 0 0.15 --scan-seed 7373 --cycle-scan \
        --cycle-scan-file results/blind/polish_stall_decision/cycle_scan_low_k_seed7373.json agents/pretrained/ppo_generalist
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, folder_with, input_file, int_range

    p = Parser(description=__doc__)
    p.add_argument("policies", nargs="+", type=folder_with("model.zip"), help="policy folders (with model.zip)")
    p.add_argument("--n", type=int_range(1), default=192, help="blind-domain points (-)")
    p.add_argument("--seed", type=int, required=True, help="seed of the points (-): a decision seed, not a report seed")
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--scan-ks", type=int_range(1), default=24, help="k values of the critical-load scan (-)")
    p.add_argument("--scan-range", type=float, nargs=2, default=(0.0, 0.6), metavar=("LOW", "HIGH"),  # blind.K_RANGE
                   help="k interval of the critical-load scan, cut into --scan-ks equal cells (-)")
    p.add_argument("--scan-seed", type=int, default=None,
                   help="draw the scan's k uniformly in each cell with this seed (a decision seed) instead of "
                        "taking the cells' midpoints")
    p.add_argument("--cycle-scan-file", type=Path, default=None, metavar="JSON",
                   help="with --cycle-scan: read the best cycle's scan from this file if it exists (it must hold "
                        "these k), else compute it and write it there")
    p.add_argument("--cycle-scan", action="store_true",
                   help="also the best two-action cycle's critical load at those k (CMA-ES bisection, as "
                        "the blind benchmark's), and the teacher's and each policy's over it")
    p.add_argument("--searched", type=input_file, default=None, metavar="BLIND.json",
                   help="also the teacher (the recipe's neighbourhood) at the points of an earlier blind "
                        "benchmark, as a fraction of that benchmark's per-point search where it moves >= 2 mm/s "
                        "(written by mdr-drive benchmark --blind; its seed must be a decision seed too)")
    p.add_argument("--worst", action="store_true",
                   help="also list, per policy, its points under 0.85 of the reference or below the trapezoid, "
                        "worst first, with the trapezoid's, the teacher's and every policy's velocity (mm/s)")
    p.add_argument("--workers", type=int_range(1), default=None,
                   help="local processes of the cycle scan (default: the cores available)")
    args = p.parse_args(argv)
    from mdr_drive_agents.blind import K_RANGE

    low, high = args.scan_range
    if not K_RANGE[0] <= low < high <= K_RANGE[1]:
        p.error(f"--scan-range {low:g} {high:g}: need {K_RANGE[0]:g} <= LOW < HIGH <= {K_RANGE[1]:g} "
                "(the training domain's k)")
    if args.cycle_scan_file is not None and not args.cycle_scan:
        p.error("--cycle-scan-file keeps the best cycle's scan: give --cycle-scan too")

    from mdr_drive_agents.blind import (CRITICAL_LOAD_TARGET, MOVING_THRESHOLD, draw_points, in_k_cells,
                                        trapezoid_critical, velocity_statistics)
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import (
        critical_loads_grid,
        load_policy,
        open_loop_velocity,
        policy_velocity,
        trapezoid_action,
    )
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    teacher_config = load_recipe(DEFAULT_CONFIG)["distill"]

    points, point_crit = draw_points(args.n, args.seed)
    trap = open_loop_velocity(points, trapezoid_action())
    field = DriveField.load(args.field)
    _, teacher = field.best(points, radius=3)
    policies = {path: load_policy(path) for path in args.policies}
    learned = {path: policy_velocity(policy, points) for path, policy in policies.items()}
    reference = np.fmax(np.fmax(trap, teacher), np.max(list(learned.values()), axis=0))
    scored = reference >= MOVING_THRESHOLD
    offsets = (np.full(args.scan_ks, 0.5) if args.scan_seed is None
               else np.random.default_rng(args.scan_seed).uniform(size=args.scan_ks))
    scan_ks = [float(round(k, 6)) for k in in_k_cells(offsets, (low, high))]
    crit_trap = trapezoid_critical(scan_ks)
    crit_teacher = critical_loads_grid(scan_ks, lambda pts: teacher_drives(field, pts, teacher_config)[1])
    print(f"{args.n} points of seed {args.seed}; reference: the teacher's 6 x 6 neighbourhood ({args.field}) "
          f"or any better drive; {int(scored.sum())} points where it moves >= 2 mm/s")
    print("| policy | below the trapezoid (worst, mm/s) | fraction of the reference: mean / min | under 0.85 | "
          f"critical load / teacher's: min (k), k values >= {CRITICAL_LOAD_TARGET:g} of {len(scan_ks)} | critical load / trapezoid's: min |")
    print("|---|---|---|---|---|---|")
    def velocity_cells(v: np.ndarray) -> str:
        """The row's velocity columns: the blind benchmark's statistics against this reference."""
        stats = velocity_statistics(trap, reference, v)
        return (f"{stats['points_below_trapezoid']} ({stats['worst_difference_to_trapezoid_mm_s']:.2f}) | "
                f"{stats['fraction_of_best_mean']:.3f} / {stats['fraction_of_best_min']:.3f} | "
                f"{stats['points_under_fraction_target']}")

    crits, to_teachers = {}, {}
    for path, v in learned.items():
        crit = crits[path] = critical_loads_grid(scan_ks, lambda pts, pol=policies[path]: policy_velocity(pol, pts))
        to_teacher = to_teachers[path] = np.array([crit[k] / max(crit_teacher[k], 1e-12) for k in scan_ks])
        to_trapezoid = np.array([crit[k] / c for k, c in zip(scan_ks, crit_trap)])
        worst = int(np.argmin(to_teacher))
        print(f"| {path} | {velocity_cells(v)} | {to_teacher[worst]:.2f} ({scan_ks[worst]:.4g}), "
              f"{int((to_teacher >= CRITICAL_LOAD_TARGET).sum())} | {to_trapezoid.min():.2f} |")
    for path, to_teacher in to_teachers.items():
        print_under(f"{path}: critical load under {CRITICAL_LOAD_TARGET:g} of the teacher's", scan_ks, to_teacher)
    if args.cycle_scan:
        print_cycle_scan(scan_ks, crit_trap, {"the teacher": crit_teacher, **crits}, args.workers, args.cycle_scan_file)
    if args.searched:
        print_teacher_against_search(field, args.searched, teacher_config)
    if len(learned) > 1:  # not a policy: whether the policies fail at the same points or each at its own
        print(f"| the best of these policies at each point (not a policy) | "
              f"{velocity_cells(np.max(list(learned.values()), axis=0))} | - | - |")
    if args.worst:
        print_worst(points, point_crit, trap, teacher, reference, learned)
    return 0


def print_teacher_against_search(field, blind_json, teacher_config, worst: int = 6) -> None:
    """The teacher's velocity at an earlier blind benchmark's points over that benchmark's best drive
    found there, where it moves >= 2 mm/s: mean, minimum, points under 0.85, and the ``worst`` points
    (k, load over the trapezoid's critical load, teacher's / best mm/s); and, where the file has a
    critical-load scan, the teacher's critical load at its k over the best cycle's stored there."""
    import json

    from mdr_drive_agents.blind import (CRITICAL_LOAD_TARGET, FRACTION_TARGET, MOVING_THRESHOLD, critical_load_on_scan,
                                        format_under, stored_scan, trapezoid_critical)
    from mdr_drive_agents.teacher_data import teacher_drives

    res = json.loads(Path(blind_json).read_text())
    points = [(float(k), float(m)) for k, m in res["points"]]
    best = np.array([b["velocity"] for b in res["best"]], dtype=np.float64)
    _, teacher = teacher_drives(field, points, teacher_config)
    scored = np.flatnonzero(best >= MOVING_THRESHOLD)
    frac = teacher[scored] / best[scored]
    crit = trapezoid_critical([k for k, _ in points])
    print(f"\nThe teacher against the per-point search of {blind_json} (seed {res['seed']}, {len(points)} points, "
          f"{len(scored)} where the search moves >= 2 mm/s): fraction mean {frac.mean():.3f}, min {frac.min():.3f}, "
          f"{int((frac < FRACTION_TARGET).sum())} under {FRACTION_TARGET:g}")
    for i in scored[np.argsort(frac)[:worst]]:
        print(f"  k = {points[i][0]:.4f}, load / trapezoid's critical = {points[i][1] / crit[i]:.2f}: "
              f"{teacher[i] * 1e3:.1f} of {best[i] * 1e3:.1f} mm/s")
    scan = stored_scan(res)
    if scan is not None:
        r = critical_load_on_scan(lambda pts: teacher_drives(field, pts, teacher_config)[1], scan)
        under = format_under(r["under"])
        print(f"The teacher's critical load over that benchmark's best cycle's ({len(scan['k'])} k): "
              f"min {r['min']:.3f}, {r['at_target']} at >= {CRITICAL_LOAD_TARGET:g}; under it: {under}")


def print_worst(points, crit: np.ndarray, trap: np.ndarray, teacher: np.ndarray, reference: np.ndarray,
                learned: dict) -> None:
    """Per policy, its points under ``FRACTION_TARGET`` of the reference (where that moves >= 2 mm/s)
    or below the trapezoid (``blind.below_trapezoid``), worst fraction first: k, load (kg and over
    the trapezoid's critical load ``crit`` there), the trapezoid's, the teacher's and every policy's
    velocity."""
    from mdr_drive_agents.blind import FRACTION_TARGET, MOVING_THRESHOLD, below_trapezoid

    for path, v in learned.items():
        with np.errstate(invalid="ignore", divide="ignore"):
            fraction = v / reference
        bad = np.flatnonzero(((reference >= MOVING_THRESHOLD) & (fraction < FRACTION_TARGET)) | below_trapezoid(trap, v)[0])
        print(f"\n{path}: {len(bad)} points under {FRACTION_TARGET:g} of the reference or below the trapezoid (mm/s)")
        for i in bad[np.argsort(fraction[bad])]:
            k, m = points[i]
            print(f"  k = {k:.4f}, {m:.5f} kg ({m / crit[i]:.3f} of the trapezoid's critical load): trapezoid "
                  f"{trap[i] * 1e3:.2f}, teacher {teacher[i] * 1e3:.2f}, "
                  + ", ".join(f"{name} {w[i] * 1e3:.2f}" for name, w in learned.items()))


def print_under(title: str, scan_ks, ratio: np.ndarray) -> None:
    """One line: ``title``, then each k of ``scan_ks`` whose ``ratio`` is under the target, with it."""
    from mdr_drive_agents.blind import CRITICAL_LOAD_TARGET, format_under

    print(f"{title}: {format_under({k: r for k, r in zip(scan_ks, ratio) if r < CRITICAL_LOAD_TARGET})}")


def print_cycle_scan(scan_ks, crit_trap, crits: dict, workers, scan_file: Path | None = None) -> None:
    """The best two-action cycle's critical load at ``scan_ks`` (the blind benchmark's search and
    budget; read from ``scan_file`` if it holds these k, else computed and written there), and each
    entry of ``crits`` ({name: {k: kg}}) over it: its minimum, the k values at >= 0.97 of it and
    those under."""
    import json

    from mdr_drive_agents.baselines import CYCLE_SEARCH
    from mdr_drive_agents.blind import CRITICAL_LOAD_TARGET, CYCLE_BISECTIONS, cycle_scan_task
    from mdr_drive_env.files import write_text
    from mdr_drive_env.sweep import Executor

    stored = json.loads(scan_file.read_text()) if scan_file is not None and scan_file.exists() else {}
    if stored and stored.get("k") != list(scan_ks):
        raise SystemExit(f"teacher_check.py: --cycle-scan-file {scan_file} holds another scan's k values; name a new file")
    if stored:
        cycle = np.array(stored["best_cycle_kg"])
        print(f"\nthe best cycle's critical loads read from {scan_file}")
    else:
        cycle = np.array(Executor(workers=workers).map(
            cycle_scan_task, [(k, m, CYCLE_BISECTIONS, CYCLE_SEARCH["budget"]) for k, m in zip(scan_ks, crit_trap)],
            "critical load of the best cycle per k"))
        if scan_file is not None:
            write_text(scan_file, json.dumps({"k": list(scan_ks), "trapezoid_kg": [float(c) for c in crit_trap],
                                              "best_cycle_kg": [float(c) for c in cycle],
                                              "search": {"bisections": CYCLE_BISECTIONS, **CYCLE_SEARCH}}, indent=1))
    print(f"\nCritical load over the best two-action cycle's ({len(scan_ks)} k; "
          f"the cycle's over the trapezoid's: {np.min(cycle / crit_trap):.2f}-{np.max(cycle / crit_trap):.2f})")
    print(f"| drive | min (k) | k values >= {CRITICAL_LOAD_TARGET:g} of {len(scan_ks)} |")
    print("|---|---|---|")
    ratios = {name: np.array([crit[k] for k in scan_ks]) / np.maximum(cycle, 1e-12) for name, crit in crits.items()}
    for name, ratio in ratios.items():
        worst = int(np.argmin(ratio))
        print(f"| {name} | {ratio[worst]:.3f} ({scan_ks[worst]:.4g}) | {int((ratio >= CRITICAL_LOAD_TARGET).sum())} |")
    for name, ratio in ratios.items():
        print_under(f"{name}: under {CRITICAL_LOAD_TARGET:g} of the best cycle's", scan_ks, ratio)


if __name__ == "__main__":
    raise SystemExit(main())
