#!/usr/bin/env python
"""Decision tool (not shipped): a teacher with another teacher's drives written back at given nodes.

    python results/blind/steep_family_probe/writeback.py runs/s5/teacher_field.npz runs/s3_teacher_field.npz \
        0.75 0.2 0.225 0.25 0.275 runs/s5_steep_s3_teacher.npz

On the load line FRACTION (of the trapezoid's critical load) at each k given, the node's drive and
velocity become the reference teacher's; then the phases are written over the grid again
(``DriveField.align_grid``, retired since: run it at git 6b0fa6c-c3774fd). Prints the nodes
written back.
"""
import sys

import numpy as np

from mdr_drive_agents.drive_field import DriveField

src, ref_path, fraction, *ks, dst = sys.argv[1:]
field, ref = DriveField.load(src), DriveField.load(ref_path)
assert np.allclose(field.ks, ref.ks) and np.allclose(field.fractions, ref.fractions)
j = int(np.argmin(np.abs(field.fractions - float(fraction))))
back = []
for k in map(float, ks):
    i = int(np.argmin(np.abs(field.ks - k)))
    field.drives[i, j], field.velocities[i, j] = ref.drives[i, j], ref.velocities[i, j]
    back.append((round(float(field.ks[i]), 3), round(float(field.fractions[j]), 2)))
swapped = field.align_grid()
field.meta["written_back"] = {"reference": ref_path, "nodes": back}
field.save(dst)
print(f"{len(back)} nodes written back from {ref_path}: {back}; {swapped} swapped over the grid")
