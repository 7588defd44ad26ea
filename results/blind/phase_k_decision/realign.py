#!/usr/bin/env python
"""Decision tool (not shipped): S4's teacher with S3's phases wherever its cycles are S3's.

    python results/blind/phase_k_decision/realign.py runs/s4/teacher_field.npz S3_TEACHER.npz runs/s4_phase_teacher.npz

``DriveField.align`` writes each k line's cycles in the phase closest to the lighter node's, so the
new drive at 0.75 on S4's k lines 0.25 and 0.275 flipped the phase of every heavier node there (the
same cycles as S3's teacher, their two actions swapped), while their k neighbours kept theirs. Here
every node whose drive is the reference teacher's with its actions swapped is written in the
reference's phase; nothing else changes (a cycle and its swap are one cycle: same velocity; only the
action an episode starts with differs). Prints the nodes written back.
"""
import sys

import numpy as np

from mdr_drive_agents.drive_field import DriveField

src, ref_path, dst = sys.argv[1:4]
field, ref = DriveField.load(src), DriveField.load(ref_path)
assert np.allclose(field.ks, ref.ks) and np.allclose(field.fractions, ref.fractions)
back = []
for i in range(len(field.ks)):
    for j in range(len(field.fractions)):
        d, r = field.drives[i, j], ref.drives[i, j]
        if not np.array_equal(d, r) and np.array_equal(d[::-1], r):
            field.drives[i, j] = r
            back.append((round(float(field.ks[i]), 3), round(float(field.fractions[j]), 2)))
field.meta["phase_from"] = {"reference": ref_path, "nodes": len(back)}
field.save(dst)
print(f"{len(back)} nodes written in the reference's phase:", back)
