"""F1s1's student from its round-0 checkpoint: as it stands, or with a critical-load scan in its hole
round and teacher episodes placed in the pockets the scan finds. A probe (FINDINGS.md), not a recipe
stage; run from the repository's root with the shipped recipe and teacher.

    python results/blind/pocket_probe/probe_student.py none CKPT OUT      # round 0 as a policy
    python results/blind/pocket_probe/probe_student.py pocket CKPT OUT --scan-ks 240 --scan-seed 4646 [--passes 2]

CKPT: ``OUT/.tasks/student_round0.pkl`` of a ``python -m mdr_drive_agents.recipe`` run, copied out
before the run ends (the recipe deletes it).
"""
import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

TEACHER = "results/recipe/teacher_field.npz"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mode", choices=["none", "pocket"], help="none: round 0 as it stands; pocket: the hole round with a scan")
    p.add_argument("checkpoint", help="round-0 checkpoint (.pkl)")
    p.add_argument("out", help="policy folder to write")
    p.add_argument("--scan-ks", type=int, default=240, help="k values of the pocket scan (-)")
    p.add_argument("--scan-seed", type=int, default=None, help="seed of the scan's k, one drawn in each equal cell")
    p.add_argument("--copies", type=int, default=4, help="teacher episodes per pocket point (-)")
    p.add_argument("--passes", type=int, default=1, help="after the first, scan again (seed + i) and fit again")
    p.add_argument("--pass-steps", type=int, default=2000, help="Adam steps of each later pass (-)")
    p.add_argument("--pass-lr", type=float, default=1e-4, help="learning rate of each later pass (-)")
    a = p.parse_args()
    import torch

    from mdr_drive_agents import checkpoint
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe, student_record
    from mdr_drive_agents.student import make_student, save_student

    recipe = load_recipe(DEFAULT_CONFIG)
    cfg = recipe["distill"]
    field = DriveField.load(TEACHER)
    torch.set_num_threads(cfg.torch_threads)
    seed = recipe["student_seed"]
    student = make_student(cfg, seed, recipe["env_kwargs"], recipe["ppo"])
    rng = np.random.default_rng(seed)
    obs_all, drive_all, record = checkpoint.restore(pickle.loads(Path(a.checkpoint).read_bytes()), student, rng)
    student.history.append(record)
    t0 = time.perf_counter()
    if a.mode == "pocket":
        rec = pocket_round(student, field, cfg, rng, seed, obs_all, drive_all, a.scan_ks, a.scan_seed, a.copies)
        for i in range(1, a.passes):
            student.history.append(rec)
            print(rec, flush=True)
            rec = pocket_pass(student, field, cfg, seed, obs_all, drive_all, a.scan_ks, a.scan_seed + i, a.copies,
                              a.pass_steps, a.pass_lr)
        student.history.append(rec)
        print(rec, flush=True)
    save_student(student, Path(a.out), student_record(seed, recipe["env_kwargs"], recipe["ppo"], cfg, student,
                                                      round(time.perf_counter() - t0, 1), " ".join(sys.argv),
                                                      {"teacher": TEACHER, "recipe": str(DEFAULT_CONFIG)}))


def scan_pockets(student, field, cfg, scan_ks, scan_seed):
    """The student's critical load over the teacher's at ``scan_ks`` drawn k; the k under 0.97, and
    points just above the student's first stall there (k +- 0.0005, load 1.001-1.01 times it)."""
    from mdr_drive_agents.blind import in_k_cells
    from mdr_drive_agents.distill import student_velocity
    from mdr_drive_agents.evaluate import critical_loads_grid
    from mdr_drive_agents.teacher_data import teacher_drives

    ks = [float(round(k, 6)) for k in in_k_cells(np.random.default_rng(scan_seed).uniform(size=scan_ks), (0.0, 0.6))]
    crit_s = critical_loads_grid(ks, lambda pts: student_velocity(student, pts))
    crit_t = critical_loads_grid(ks, lambda pts: teacher_drives(field, pts, cfg)[1])
    pockets = [(k, crit_s[k], crit_s[k] / crit_t[k]) for k in ks if crit_s[k] < 0.97 * crit_t[k]]
    print(f"pocket scan (seed {scan_seed}): {len(pockets)} of {len(ks)} k under 0.97: "
          + ", ".join(f"{k:.4f} ({r:.3f})" for k, _, r in pockets), flush=True)
    points = [(float(np.clip(k + dk, 0.0, 0.6)), m * f) for k, m, _ in pockets
              for dk in (-0.0005, 0.0, 0.0005) for f in (1.001, 1.003, 1.006, 1.01)]
    return pockets, points


def pocket_round(student, field, cfg, rng, seed, obs_all, drive_all, scan_ks, scan_seed, copies):
    """The recipe's hole round (``distill.hole_round``: the same probes, holes, episodes and fit)
    with the pocket scan's points added to its episodes, ``copies`` times each, without the holes'
    wide jitter."""
    from mdr_drive_agents.distill import find_holes, fit
    from mdr_drive_agents.teacher_data import around, labelled_episodes

    t0 = time.perf_counter()
    pockets, pocket_points = scan_pockets(student, field, cfg, scan_ks, scan_seed)
    t_scan = time.perf_counter() - t0
    holes, probe = find_holes(student, field, cfg, rng)
    k_range = (float(field.ks[0]), float(field.ks[-1]))
    pts = around(holes, cfg.hole_neighbours, rng, k_range) + pocket_points * copies
    obs, sample_drives = labelled_episodes(field, pts, None, cfg, seed + 101, student.z_phase_origin, student.time_quantum)
    obs_all.append(obs)
    drive_all.append(sample_drives)
    loss = fit(student, np.concatenate(obs_all), np.concatenate(drive_all), cfg.hole_steps, cfg, seed + 101, True,
               learning_rate=cfg.hole_learning_rate)
    return {"hole_round": 1, **probe, "pockets": [[k, r] for k, _, r in pockets], "pocket_points": len(pocket_points),
            "scan_s": round(t_scan, 1), "samples": int(sum(len(o) for o in obs_all)), "loss": loss,
            "wall_time_s": round(time.perf_counter() - t0, 1)}


def pocket_pass(student, field, cfg, seed, obs_all, drive_all, scan_ks, scan_seed, copies, steps, lr):
    """A later pass: scan again, the pocket points' teacher episodes added, ``steps`` Adam steps at ``lr``."""
    from mdr_drive_agents.distill import fit
    from mdr_drive_agents.teacher_data import labelled_episodes

    t0 = time.perf_counter()
    pockets, points = scan_pockets(student, field, cfg, scan_ks, scan_seed)
    t_scan = time.perf_counter() - t0
    loss = None
    if points:
        obs, sample_drives = labelled_episodes(field, points * copies, None, cfg, seed + scan_seed,
                                               student.z_phase_origin, student.time_quantum)
        obs_all.append(obs)
        drive_all.append(sample_drives)
        loss = fit(student, np.concatenate(obs_all), np.concatenate(drive_all), steps, cfg, seed + scan_seed, True,
                   learning_rate=lr)
    return {"pocket_pass_seed": scan_seed, "pockets": [[k, r] for k, _, r in pockets], "pocket_points": len(points),
            "scan_s": round(t_scan, 1), "samples": int(sum(len(o) for o in obs_all)), "loss": loss,
            "wall_time_s": round(time.perf_counter() - t0, 1)}


if __name__ == "__main__":
    main()
