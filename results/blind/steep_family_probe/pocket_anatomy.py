#!/usr/bin/env python
"""Decision tool (not shipped): what a student plays in a stall pocket, against its teacher.

    python results/blind/steep_family_probe/pocket_anatomy.py --k 0.23875 --from 1.18 --to 1.26 --loads 9 \
        --field runs/s5/teacher_field.npz runs/s5/policy

Per load (times the trapezoid's critical load at K): the teacher's velocity (its drive played open
loop, the recipe's teacher), the policy's (closed loop, 30 periods), the policy's last two actions
played open loop as a cycle (does its cycle itself stall, or only the way it got there?), and the
largest entry of the difference between that cycle and the teacher's drive (closer phase; action
units). mm/s.
"""
import argparse

import numpy as np

from mdr_drive_agents.blind import trapezoid_critical
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.distill import DistillConfig
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import load_policy, open_loop_velocity, policy_rollout, steady_velocity_of
from mdr_drive_agents.recipe import load_recipe
from mdr_drive_agents.teacher_data import teacher_drives

p = argparse.ArgumentParser()
p.add_argument("--k", type=float, required=True)
p.add_argument("--from", dest="low", type=float, required=True)
p.add_argument("--to", dest="high", type=float, required=True)
p.add_argument("--loads", type=int, default=9)
p.add_argument("--field", required=True)
p.add_argument("--recipe", default="results/blind/steep_budget_decision/recipe_steep1500.yaml")
p.add_argument("policy")
a = p.parse_args()
field = DriveField.load(a.field)
config: DistillConfig = load_recipe(a.recipe)["distill"]
crit = trapezoid_critical([a.k])[0]
fractions = np.linspace(a.low, a.high, a.loads)
points = [(a.k, float(f * crit)) for f in fractions]
drives, v_teacher = teacher_drives(field, points, config)
disp, acts, runaway = policy_rollout(load_policy(a.policy), points)
v_policy = steady_velocity_of(disp, runaway=runaway)
cycles = np.stack([acts[-2], acts[-1]], axis=1).astype(np.float64)  # (n, 2, 5): its steady cycle
v_cycle = open_loop_velocity(points, cycles)
gap = [np.abs(align_phase(c, d) - d).max() for c, d in zip(cycles, drives)]
print(f"k = {a.k}; {a.policy} against {a.field}; velocities in mm/s")
print("| load / trapezoid's critical | teacher | policy (closed loop) | policy's last cycle, open loop | largest entry of cycle - teacher's drive |")
print("|---|---|---|---|---|")
for f, vt, vp, vc, g in zip(fractions, v_teacher, v_policy, v_cycle, gap):
    print(f"| {f:.3f} | {1e3 * vt:.3f} | {1e3 * vp:.3f} | {1e3 * vc:.3f} | {g:.4f} |")
