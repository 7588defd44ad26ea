#!/usr/bin/env python
"""Are the teacher's jumps between drives crossable? Blends, and bridges searched, at each jump.

    python scripts/jump_bridges.py --samples 24 --intermediates 1 --iterations 15 --popsize 16
    python scripts/jump_bridges.py --samples 10 --intermediates 3 --iterations 60 --popsize 24

The student is a smooth function of (k, load); where the teacher's drive jumps between two drives
it plays something between them over a band. This asks whether anything between them drives:

1. round 0 of the recipe's distillation (``agents/configs/recipe.yaml``, ``--seed``): its random
   points, the teacher's drives there and the bisection of its jumps (``teacher_data.jump_brackets``),
   down to the last level's brackets (two points 1/2^levels of round 0's spacing apart whose drives
   differ by more than ``jump_threshold``);
2. at each bracket's midpoint, the two drives (in their closest cycle phase), their even blends at
   t = 0.25, 0.5, 0.75, and the trapezoid: a bracket is **harmful** where a blend is below the
   trapezoid by more than 0.05 mm/s;
3. at ``--samples`` harmful brackets (drawn with ``--seed``), CMA-ES (``--iterations`` x
   ``--popsize``, bounds the action box) over ``--intermediates`` drives M1 ... Mn between them,
   maximising the slowest of: each Mi, and the points at 1/3 and 2/3 of every segment of the path
   drive A, M1, ..., Mn, drive B. A **bridge** is a path whose slowest point is at least the
   trapezoid's velocity and 0.85 of the slower end drive's. A teacher whose drive changed along a
   bridge across the jump would let a smooth student blend safely.

Prints the counts and one row per searched bracket (velocities in mm/s); ``--out FILE.md`` writes the
same report (refused if the file exists, unless ``--force``). One process: 62 s for the first
command above, 127 s for the second (round 0's teacher episodes take about 50 s of each).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

#: Blend weights tested at each bracket's midpoint.
BLEND_T = (0.25, 0.5, 0.75)
#: Points per path segment the bridge search scores (besides its ends).
SEGMENT_T = (1 / 3, 2 / 3)


def round0_brackets(field, config, seed: int):
    """Round 0's points and teacher drives (as ``distill.distill`` draws them with ``seed``) and the
    brackets its bisection ends with: (a, b) (n, 2) and their drives (n, 2, 5), b's in a's phase."""
    from mdr_drive_agents.teacher_data import draw_points, jump_brackets, teacher_drives
    from mdr_drive_agents.cycles import align_phase

    rng = np.random.default_rng(seed)
    points = draw_points(field, config.points, rng, config)
    drives, _ = teacher_drives(field, points, config)
    _, _, (a, b, da, db) = jump_brackets(field, points, drives, config)
    return a, b, da, align_phase(db.reshape(-1, 2, 5), da.reshape(-1, 2, 5))


def path_velocities(point, ends: tuple[np.ndarray, np.ndarray], inner: np.ndarray) -> np.ndarray:
    """The slowest velocity (m/s) along each path (ends[0], inner[j, 0], ..., ends[1]) at ``point``:
    over its inner drives and the points at ``SEGMENT_T`` of every segment. ``inner`` (p, n, 2, 5)."""
    from mdr_drive_agents.evaluate import open_loop_velocity

    drives = []
    for path in inner:
        nodes = [ends[0], *path, ends[1]]
        drives += [(1 - t) * u + t * w for u, w in zip(nodes[:-1], nodes[1:]) for t in SEGMENT_T] + list(path)
    v = open_loop_velocity([point] * len(drives), np.array(drives))
    return v.reshape(len(inner), -1).min(axis=1)


def search_bridge(point, ends, n_inner: int, iterations: int, popsize: int, seed: int) -> float:
    """The best slowest-point velocity (m/s) CMA-ES finds over paths with ``n_inner`` inner drives,
    started on the straight line between the ends."""
    import cma

    start = np.concatenate([((1 - t) * ends[0] + t * ends[1]).ravel()
                            for t in np.linspace(0, 1, n_inner + 2)[1:-1]])
    es = cma.CMAEvolutionStrategy(start, 0.3, {"bounds": [-1, 1], "popsize": popsize, "verbose": -9, "seed": seed})
    best = -np.inf
    for _ in range(iterations):
        x = es.ask()
        v = path_velocities(point, ends, np.clip(np.array(x), -1, 1).reshape(len(x), n_inner, 2, 5))
        es.tell(x, list(-v))
        best = max(best, float(v.max()))
    return best


def main(argv=None) -> int:
    from mdr_drive_env.cli_args import Parser, input_file, int_range, output_file

    p = Parser(description=__doc__)
    p.add_argument("--field", type=input_file, default="results/recipe/teacher_field.npz",
                   help="the teacher's drive field (.npz, written by the recipe)")
    p.add_argument("--config", type=input_file, default="agents/configs/recipe.yaml",
                   help="the recipe whose distill section sets round 0 and the bisection")
    p.add_argument("--seed", type=int_range(0), default=0, help="round 0's seed (the recipe's: 0) and the draw's")
    p.add_argument("--samples", type=int_range(0), default=24, help="harmful brackets to search a bridge at (-)")
    p.add_argument("--intermediates", type=int_range(1, 8), default=1, help="inner drives of each path (-)")
    p.add_argument("--iterations", type=int_range(1), default=15, help="CMA-ES generations per bracket (-)")
    p.add_argument("--popsize", type=int_range(2), default=16, help="CMA-ES population (-)")
    p.add_argument("--out", type=output_file(".md"), help="also write the report to this Markdown file")
    p.add_argument("--force", action="store_true", help="overwrite --out")
    args = p.parse_args(argv)
    if args.out and Path(args.out).exists() and not args.force:
        p.error(f"--out {args.out} exists; pass --force to overwrite it")

    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import open_loop_velocity, trapezoid_action
    from mdr_drive_agents.recipe import load_recipe
    from mdr_drive_env.files import write_text

    field = DriveField.load(args.field)
    config = load_recipe(args.config)["distill"]
    a, b, da, db = round0_brackets(field, config, args.seed)
    if not len(a):
        print(f"Round 0 (`{args.config}`, seed {args.seed}) leaves no bracket: the teacher's drive does not jump.")
        return 0
    mids = [tuple(map(float, m)) for m in 0.5 * (a + b)]
    blends = np.array([(1 - t) * da + t * db for t in (0.0, *BLEND_T, 1.0)]).transpose(1, 0, 2, 3)
    v = open_loop_velocity([m for m in mids for _ in range(blends.shape[1])], blends.reshape(-1, 2, 5))
    v = v.reshape(len(mids), -1)
    v_trap = open_loop_velocity(mids, trapezoid_action())
    slower_end = v[:, [0, -1]].min(axis=1)
    harmful = v[:, 1:-1].min(axis=1) < v_trap - 0.05e-3
    lines = [f"Jump brackets of round 0 (`{args.config}`, seed {args.seed}, teacher `{args.field}`): {len(mids)}; "
             f"an even blend below the trapezoid at the midpoint: {int(harmful.sum())}; under 0.85 of the slower "
             f"drive: {int((v[:, 1:-1].min(axis=1) < 0.85 * slower_end).sum())}.", ""]
    rng = np.random.default_rng(args.seed)
    picked = rng.choice(np.flatnonzero(harmful), min(args.samples, int(harmful.sum())), replace=False)
    lines += [f"Bridges searched at {len(picked)} harmful brackets: {args.intermediates} inner drive(s), "
              f"CMA-ES {args.iterations} x {args.popsize}; velocities in mm/s.", "",
              "| k | load (kg) | slower drive | straight blend (slowest) | trapezoid | bridge (slowest) | bridge? |",
              "|---|---|---|---|---|---|---|"]
    found = 0
    for n, i in enumerate(picked):
        best = search_bridge(mids[i], (da[i], db[i]), args.intermediates, args.iterations, args.popsize, args.seed + n)
        ok = best >= v_trap[i] and best >= 0.85 * slower_end[i]
        found += ok
        lines.append(f"| {mids[i][0]:.3f} | {mids[i][1]:.4f} | {slower_end[i] * 1e3:.2f} | "
                     f"{v[i, 1:-1].min() * 1e3:.2f} | {v_trap[i] * 1e3:.2f} | {best * 1e3:.2f} | {'yes' if ok else 'no'} |")
    lines += ["", f"Bridges found: {found} of {len(picked)}."]
    report = "\n".join(lines) + "\n"
    print(report, end="")
    if args.out:
        write_text(args.out, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
