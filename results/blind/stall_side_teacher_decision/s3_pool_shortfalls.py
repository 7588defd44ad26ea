"""Where the shipped policy (S3) is under 0.85 of the stored blind searches, pooled, and what its
teacher (and the k <= 0.25 stall-search variant, if given) plays there: whose shortfall each is.

    python results/blind/stall_side_teacher_decision/s3_pool_shortfalls.py runs/stall_side_k025_teacher.npz
"""
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from pooled_blind import pooled_points, stored_searches  # noqa: E402

from mdr_drive_agents.blind import MOVING_THRESHOLD, trapezoid_critical  # noqa: E402
from mdr_drive_agents.drive_field import DriveField  # noqa: E402
from mdr_drive_agents.evaluate import load_policy, policy_velocity  # noqa: E402
from mdr_drive_agents.recipe import load_recipe  # noqa: E402
from mdr_drive_agents.teacher_data import teacher_drives  # noqa: E402

distill = load_recipe(ROOT / "agents/configs/recipe.yaml")["distill"]
fields = {"teacher": DriveField.load(ROOT / "results/recipe/teacher_field.npz")}
if len(sys.argv) > 1:
    fields["variant"] = DriveField.load(sys.argv[1])
searches = stored_searches(sorted((ROOT / "results/blind").glob("*/blind.json")))
points, seeds, best, _ = pooled_points(searches)
student = np.asarray(policy_velocity(load_policy(ROOT / "agents/pretrained/ppo_generalist"), points))
scored = best >= MOVING_THRESHOLD
under = np.flatnonzero(scored & (student < 0.85 * best))
sub = [points[i] for i in under]
crit = trapezoid_critical([k for k, _ in sub])
played = {name: teacher_drives(f, sub, distill)[1] for name, f in fields.items()}
print(f"{len(under)} of {int(scored.sum())} pooled points where the search moves >= 2 mm/s: S3 under 0.85 of it")
print("| seed | k | load / trapezoid's critical | search mm/s | S3 | " + " | ".join(played) + " |")
print("|---|---|---|---|---|" + "---|" * len(played))
for m in np.argsort([k for k, _ in sub]):  # by k; m indexes sub, crit and played
    i = under[m]
    cells = " | ".join(f"{played[name][m] / best[i]:.3f}" for name in played)
    print(f"| {seeds[i]} | {points[i][0]:.4f} | {sub[m][1] / crit[m]:.3f} | {best[i] * 1e3:.2f} | "
          f"{student[i] / best[i]:.3f} | {cells} |")
