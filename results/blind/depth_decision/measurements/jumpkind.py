import numpy as np, collections
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.drive_field import DriveField
f = DriveField.load("results/recipe/teacher_field.npz")
nk, ns = f.velocities.shape
kinds = collections.Counter(); ncomp = collections.Counter()
for i in range(nk):
    for j in range(ns):
        for a, b in f._grid_neighbours(i, j):
            if (a, b) <= (i, j): continue
            A = f.drives[i, j]; B = align_phase(f.drives[a, b], A)
            d = np.abs(B - A)
            if d.max() > 0.3:
                comps = tuple(sorted(set(int(c) for c in np.argwhere(d > 0.3)[:, 1])))
                kinds[comps] += 1; ncomp[len(comps)] += 1
print(ncomp); print(kinds.most_common(12))
print("names: 0 xamp 1 xrise 2 zamp 3 zrise 4 phase")
