"""A student that picks a bin per action entry instead of regressing it (a probe; decides nothing).

Each action entry's range [-1, 1] is cut into ``--bins`` equal bins; the network (the shipped
student's trunk, five hidden layers of 448) gives per entry a logit and an offset within the bin for
every bin, and acts with the arg-max bin's centre plus its offset. Where the teacher's drive jumps
between two families, a regression network plays a blend of the two for a narrow band of (k, load)
(results/blind/pocket_probe/FINDINGS.md); this one plays one family's entry or the other's. Fitted on
F1s1's round-0 episodes (its checkpoint) with the recipe's epoch (previous actions perturbed, the
slider's entries shuffled, ``cycle_action`` labels), steps, batch and learning rate; cross-entropy on
the label's bin plus the squared error of its offset. No hole round: compare with round 0.

    python results/blind/binned_probe/binned_student.py fit CKPT NET.pt [--bins 32] [--steps 60000]
    python results/blind/binned_probe/binned_student.py line NET.pt LOW HIGH --ks 40       # critical load / teacher's
    python results/blind/binned_probe/binned_student.py scan NET.pt --ks 480 --scan-seed S
    python results/blind/binned_probe/binned_student.py points NET.pt --n 2000 --seed S     # velocity / teacher's
    python results/blind/binned_probe/binned_student.py stored NET.pt BLIND.json ... [--scans]  # at stored blind points

Run from the repository's root; CKPT is ``OUT/.tasks/student_round0.pkl`` of a recipe run, copied out
(``runs/r0diag/student_round0.pkl``: F1s1's).
"""
import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

TEACHER = "results/recipe/teacher_field.npz"


class BinnedNet:
    """The trunk and the two heads (torch), the bins, and the observation statistics."""

    def __init__(self, n_obs: int, bins: int, net_arch, seed: int, offsets: bool = True):
        import torch

        torch.manual_seed(seed)
        layers, width = [], n_obs
        for h in net_arch:
            layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
            width = h
        layers.append(torch.nn.Linear(width, 5 * bins * (2 if offsets else 1)))
        self.net = torch.nn.Sequential(*layers)
        self.bins, self.offsets = bins, offsets
        if offsets:  # bins of equal width, each with an offset
            self.width = 2.0 / bins
            self.centres = -1.0 + (np.arange(bins) + 0.5) * self.width
        else:  # levels from -1 to +1 (401: each z phase quantum of 5 us one level, each rise quantum at least one)
            self.width = 2.0 / (bins - 1)
            self.centres = np.linspace(-1.0, 1.0, bins)
        self.obs_mean = self.obs_var = None

    def bin_of(self, y: np.ndarray) -> np.ndarray:
        """The bin (offsets) or nearest level (no offsets) of each action entry."""
        if self.offsets:
            return np.minimum(np.floor((y + 1.0) / self.width).astype(np.int64), self.bins - 1)
        return np.rint((y + 1.0) / self.width).astype(np.int64)

    def heads(self, x):
        """Logits and offsets (bin widths; zeros without offsets), each (n, 5, bins)."""
        if not self.offsets:
            logits = self.net(x).reshape(-1, 5, self.bins)
            return logits, logits.new_zeros(logits.shape)
        out = self.net(x).reshape(-1, 5, 2, self.bins)
        return out[:, :, 0], out[:, :, 1]

    def normalise(self, obs: np.ndarray) -> np.ndarray:
        return np.clip((obs - self.obs_mean) / np.sqrt(self.obs_var + 1e-8), -10.0, 10.0)

    def act(self, obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            logits, offsets = self.heads(torch.as_tensor(self.normalise(obs.astype(np.float64)), dtype=torch.float32))
            b = logits.argmax(-1)
            off = torch.gather(offsets, -1, b[..., None])[..., 0].clamp(-0.5, 0.5)
        return np.clip(self.centres[b.numpy()] + self.width * off.numpy(), -1.0, 1.0)

    def save(self, path: Path, record: dict) -> None:
        import torch

        torch.save({"state": self.net.state_dict(), "bins": self.bins, "offsets": self.offsets, "obs_mean": self.obs_mean,
                    "obs_var": self.obs_var, "net_arch": record["net_arch"], "record": record}, path)

    @classmethod
    def load(cls, path: Path):
        import torch

        d = torch.load(path, weights_only=False)
        n_obs = len(d["obs_mean"])
        self = cls(n_obs, d["bins"], d["net_arch"], 0, d.get("offsets", True))
        self.net.load_state_dict(d["state"])
        self.obs_mean, self.obs_var = d["obs_mean"], d["obs_var"]
        return self


def load_net(path: Path):
    """A BinnedNet, or a ``codebook_student.CodebookNet`` (its file says which)."""
    import torch

    if torch.load(path, weights_only=False).get("kind") == "codebook":
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from codebook_student import CodebookNet

        return CodebookNet.load(path)
    return BinnedNet.load(path)


def fit_binned(a) -> None:
    import torch

    from mdr_drive_agents import checkpoint
    from mdr_drive_agents.distill import epoch_samples
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.student import adam_fit, make_student

    recipe = load_recipe(DEFAULT_CONFIG)
    cfg = recipe["distill"]
    torch.set_num_threads(cfg.torch_threads)
    seed = recipe["student_seed"]
    student = make_student(cfg, seed, recipe["env_kwargs"], recipe["ppo"])
    obs_all, drive_all, record = checkpoint.restore(pickle.loads(Path(a.checkpoint).read_bytes()), student,
                                                    np.random.default_rng(seed))
    obs, drives = np.concatenate(obs_all), np.concatenate(drive_all)
    print(f"round-0 samples: {len(obs)}", flush=True)
    model = BinnedNet(obs.shape[1], a.bins, cfg.net_arch, seed, offsets=not a.no_offsets)
    model.obs_mean, model.obs_var = student.venv.obs_rms.mean.copy(), student.venv.obs_rms.var.copy()
    rng = np.random.default_rng(seed)

    def epoch():
        x, y = epoch_samples(obs, drives, rng, cfg.perturbed_share)
        y = np.clip(y, -1.0, 1.0)
        b = model.bin_of(y)
        t = (y - model.centres[b]) / model.width  # offset targets (unused without offsets)
        x = torch.as_tensor(model.normalise(x.astype(np.float64)), dtype=torch.float32)
        b, t = torch.as_tensor(b), torch.as_tensor(t, dtype=torch.float32)

        def loss_of(idx):
            logits, offsets = model.heads(x[idx])
            ce = torch.nn.functional.cross_entropy(logits.reshape(-1, a.bins), b[idx].reshape(-1))
            off = torch.gather(offsets, -1, b[idx][..., None])[..., 0]
            return ce + (0.0 if a.no_offsets else a.offset_weight * torch.mean((off - t[idx]) ** 2))
        return len(x), loss_of

    t0 = time.perf_counter()
    loss = adam_fit(model.net.parameters(), epoch, a.steps, cfg.batch, cfg.learning_rate, seed, "binned: fit")
    rec = {"checkpoint": a.checkpoint, "bins": a.bins, "offsets": not a.no_offsets, "steps": a.steps, "offset_weight": a.offset_weight,
           "net_arch": list(cfg.net_arch), "loss": loss, "samples": len(obs),
           "fit_s": round(time.perf_counter() - t0, 1), "command": " ".join(sys.argv)}
    print(rec, flush=True)
    model.save(Path(a.net), rec)


def velocity_fn(model: "BinnedNet"):
    """``points -> steady velocities`` of ``model`` closed loop, as the recipe measures its student
    (``distill.student_velocity``), in the recipe's env."""
    from types import SimpleNamespace

    from mdr_drive_agents.distill import student_velocity
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe

    env_kwargs = load_recipe(DEFAULT_CONFIG)["env_kwargs"]
    player = SimpleNamespace(act=model.act, z_phase_origin=float(env_kwargs.get("z_phase_origin", 0.0)),
                             time_quantum=float(env_kwargs["time_quantum"]))
    return lambda points: student_velocity(player, points)


def critical_against_teacher(model, ks, label: str) -> None:
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import critical_loads_grid
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.teacher_data import teacher_drives

    cfg = load_recipe(DEFAULT_CONFIG)["distill"]
    field = DriveField.load(TEACHER)
    t0 = time.perf_counter()
    crit_s = critical_loads_grid(ks, velocity_fn(model))
    crit_t = critical_loads_grid(ks, lambda pts: teacher_drives(field, pts, cfg)[1])
    ratio = np.array([crit_s[k] / crit_t[k] if crit_t[k] > 0 else 1.0 for k in ks])
    under = [(k, r) for k, r in zip(ks, ratio) if r < 0.97]
    print(f"{label}: {len(ks) - len(under)} of {len(ks)} k at >= 0.97 of the teacher's critical load; "
          f"min {ratio.min():.3f}; under: " + (", ".join(f"{k:.4f} ({r:.3f})" for k, r in under) or "none")
          + f"  [{time.perf_counter() - t0:.0f} s]", flush=True)


def points_against_teacher(model, n: int, seed: int) -> None:
    from mdr_drive_agents.blind import MOVING_THRESHOLD, draw_points
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import open_loop_velocity, trapezoid_action

    points, _ = draw_points(n, seed)
    trap = open_loop_velocity(points, trapezoid_action())
    _, teacher = DriveField.load(TEACHER).best(points, radius=3)
    v = velocity_fn(model)(points)
    ref = np.fmax(np.fmax(trap, teacher), v)
    scored = ref >= MOVING_THRESHOLD
    frac = v[scored] / ref[scored]
    below = v < trap - 0.05e-3
    print(f"{n} points of seed {seed}: below the trapezoid {int(below.sum())} (worst "
          f"{1e3 * float(np.min(v - trap)):.2f} mm/s); fraction of max(teacher r3, trapezoid, it): mean "
          f"{frac.mean():.3f}, min {frac.min():.3f}, under 0.85 {int((frac < 0.85).sum())} of {int(scored.sum())}",
          flush=True)
    worst = np.argsort(np.where(scored, v / np.maximum(ref, 1e-12), np.inf))[:8]
    for i in worst:
        print(f"  k {points[i][0]:.4f} m {points[i][1]:.4f} kg: it {1e3 * v[i]:.2f}, teacher {1e3 * teacher[i]:.2f}, "
              f"trapezoid {1e3 * trap[i]:.2f} mm/s", flush=True)


def against_stored_search(model, files, scans: bool = False) -> None:
    """The blind benchmark's velocity statistics (``blind.velocity_statistics``: against the stored
    trapezoid and search's best drive) of ``model`` at the points of stored ``blind.json`` files,
    beside those of the policies stored there; with ``scans``, also its critical load over the stored
    best cycle's at the stored scan's k."""
    import json

    from mdr_drive_agents.blind import velocity_statistics

    keys = ("points_below_trapezoid", "points_scored", "fraction_of_best_mean", "fraction_of_best_min",
            "points_under_fraction_target")
    for name in files:
        d = json.loads(Path(name).read_text())
        points = [tuple(p) for p in d["points"]]
        trap = np.array(d["trapezoid"], dtype=float)
        best = np.array([b["velocity"] for b in d["best"]])
        stats = velocity_statistics(trap, best, velocity_fn(model)(points))
        print(f"{name}: it " + ", ".join(f"{k} {stats[k]:.4g}" if isinstance(stats[k], float) else f"{k} {stats[k]}"
                                          for k in keys), flush=True)
        for policy, st in d["statistics"].items():
            print(f"  stored {policy}: " + ", ".join(f"{k} {st[k]:.4g}" if isinstance(st[k], float) else f"{k} {st[k]}"
                                                    for k in keys), flush=True)
        if scans:
            from mdr_drive_agents.blind import CRITICAL_LOAD_TARGET, critical_load_on_scan, stored_scan

            scan = stored_scan(d)
            mine = critical_load_on_scan(velocity_fn(model), scan)
            print(f"  critical load over the best cycle's at its {mine['scanned']} k: it min {mine['min']:.3f}, "
                  f"{mine['at_target']} at >= {CRITICAL_LOAD_TARGET}; stored: "
                  + ", ".join(f"{policy} min {st['critical_load_over_best_cycle_min']:.3f}"
                              for policy, st in d["statistics"].items()), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fit", help="fit on a round-0 checkpoint's episodes")
    f.add_argument("checkpoint")
    f.add_argument("net", help="file to write (.pt)")
    f.add_argument("--bins", type=int, default=32, help="bins per action entry (-)")
    f.add_argument("--steps", type=int, default=60000, help="Adam steps (-)")
    f.add_argument("--offset-weight", type=float, default=1.0, help="weight of the offset's squared error (-)")
    f.add_argument("--no-offsets", action="store_true",
                   help="no offset head: act with the arg-max bin's centre (what a MultiDiscrete SB3 policy could do)")
    ln = sub.add_parser("line", help="critical load over the teacher's at the midpoints of --ks equal cells of [LOW, HIGH]")
    ln.add_argument("net")
    ln.add_argument("low", type=float)
    ln.add_argument("high", type=float)
    ln.add_argument("--ks", type=int, default=40)
    sc = sub.add_parser("scan", help="critical load over the teacher's at drawn k")
    sc.add_argument("net")
    sc.add_argument("--ks", type=int, default=480)
    sc.add_argument("--scan-seed", type=int, required=True)
    pt = sub.add_parser("points", help="velocity over the teacher's at drawn points")
    pt.add_argument("net")
    pt.add_argument("--n", type=int, default=2000)
    pt.add_argument("--seed", type=int, required=True)
    st = sub.add_parser("stored", help="velocity statistics at the points of stored blind benchmarks")
    st.add_argument("net")
    st.add_argument("files", nargs="+", help="blind.json files (mdr-drive benchmark --blind)")
    st.add_argument("--scans", action="store_true", help="also the critical load at each file's scanned k")
    a = p.parse_args()
    if a.cmd == "fit":
        return fit_binned(a)
    import torch

    torch.set_num_threads(1)
    model = load_net(Path(a.net))
    from mdr_drive_agents.blind import in_k_cells

    if a.cmd == "line":
        ks = [float(round(k, 6)) for k in in_k_cells(np.full(a.ks, 0.5), (a.low, a.high))]  # as teacher_check --scan-range
        critical_against_teacher(model, ks, f"line {a.low}-{a.high}, {a.ks} k")
    elif a.cmd == "scan":
        ks = [float(round(k, 6)) for k in in_k_cells(np.random.default_rng(a.scan_seed).uniform(size=a.ks), (0.0, 0.6))]
        critical_against_teacher(model, ks, f"scan seed {a.scan_seed}, {a.ks} k")
    elif a.cmd == "stored":
        against_stored_search(model, a.files, a.scans)
    else:
        points_against_teacher(model, a.n, a.seed)


if __name__ == "__main__":
    main()
