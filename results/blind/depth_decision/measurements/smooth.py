import sys, numpy as np
from scipy.spatial import cKDTree
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import open_loop_velocity
from mdr_drive_agents.teacher_data import draw_points, drive_difference
from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe

def differ(a, b, thr=0.3):
    return drive_difference(a[None], b[None])[0] > thr

def smooth(field, tol, v_min, passes=6):
    nk, ns = field.velocities.shape
    v0 = field.velocities.copy()
    changed = 0
    for p in range(passes):
        pass_changes = 0
        for parity in (0, 1):
            owner, drives = [], []
            for i in range(nk):
                for j in range(ns):
                    if (i + j) % 2 != parity or v0[i, j] < v_min:
                        continue
                    for a, b in field._grid_neighbours(i, j):
                        if differ(field.drives[i, j], field.drives[a, b]):
                            owner.append((i, j)); drives.append(field.drives[a, b].copy())
            if not owner:
                continue
            vel = open_loop_velocity([field.point(i, j) for i, j in owner], np.array(drives))
            best = {}
            for (i, j), d, v in zip(owner, drives, vel):
                if v < (1 - tol) * v0[i, j]:
                    continue
                nb = [field.drives[a, b] for a, b in field._grid_neighbours(i, j)]
                gain = sum(not differ(d, e) for e in nb) - sum(not differ(field.drives[i, j], e) for e in nb)
                if gain > 0 and (best.get((i, j)) is None or (gain, v) > best[(i, j)][:2]):
                    best[(i, j)] = (gain, v, d)
            for (i, j), (g, v, d) in best.items():
                field.drives[i, j] = align_phase(d, field.drives[i, j]); field.velocities[i, j] = v
                pass_changes += 1
        changed += pass_changes
        print(f"pass {p}: {pass_changes} nodes changed", flush=True)
        if not pass_changes:
            break
    return changed

def jump_stats(field, pts, pairs, base=None):
    d, v = field.best(pts, radius=2)
    jumped = drive_difference(d[pairs[:, 0]], d[pairs[:, 1]]) > 0.3
    out = f"jump pairs {jumped.sum()} of {len(pairs)}"
    if base is not None:
        m = base >= 2e-3; r = v[m] / base[m]
        out += f"; velocity / original teacher: mean {r.mean():.4f} min {r.min():.3f} under0.9 {(r<0.9).sum()} under0.95 {(r<0.95).sum()}"
    return out, v

field = DriveField.load("results/recipe/teacher_field.npz")
cfg = load_recipe(DEFAULT_CONFIG)["distill"]
pts = draw_points(field, 4096, np.random.default_rng(0), cfg)
P = np.array(pts); crit = np.interp(P[:, 0], field.ks, field.trapezoid_critical)
coords = np.c_[P[:, 0] / 0.6, P[:, 1] / np.maximum(crit * cfg.load_factor, 1e-12)]
_, idx = cKDTree(coords).query(coords, k=7)
pairs = np.unique(np.sort(np.c_[np.repeat(np.arange(len(P)), 6), idx[:, 1:].ravel()], axis=1), axis=0)
nk, ns = field.velocities.shape
def node_jumps(f):
    return sum(differ(f.drives[i, j], f.drives[a, b]) for i in range(nk) for j in range(ns) for a, b in f._grid_neighbours(i, j) if (a, b) > (i, j))
print("original: node jumps", node_jumps(field))
s, base = jump_stats(field, pts, pairs); print("original:", s)
tol, vmin = float(sys.argv[1]), float(sys.argv[2])
n = smooth(field, tol, vmin)
print(f"tol {tol} vmin {vmin}: {n} changes; node jumps", node_jumps(field))
s, _ = jump_stats(field, pts, pairs, base); print("smoothed:", s)
if len(sys.argv) > 3:
    field.save(sys.argv[3])
