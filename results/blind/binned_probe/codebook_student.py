"""A student that picks a whole action from the teacher grid's own actions (a codebook) instead of
regressing one (a probe; decides nothing).

The codebook: the distinct actions of the committed teacher's grid drives, at their time quanta's
centres (``quantum_centre``). The teacher: the recipe's candidates around a point without the
interpolation (``node_teacher.node_best``; at 2,000 points it keeps 0.997 of the recipe teacher's
velocity on average, FINDINGS.md). Round 0 of the recipe on it (the same points, focus band, jump
bisection and teacher episodes, with that teacher), and a classifier (the shipped trunk, a softmax
over the codebook) fitted with the recipe's epoch (previous actions perturbed, the slider's entries
shuffled, ``cycle_action`` labels), steps, batch and learning rate, by cross-entropy. It acts with
the arg-max action: where the teacher's drive jumps it plays one whole drive or the other, never a
blend of the two and never a mix of their entries (``binned_student.py``'s per-entry bins did that).

    python results/blind/binned_probe/codebook_student.py fit NET.pt [--steps 60000] [--seed S]
    python results/blind/binned_probe/binned_student.py line NET.pt LOW HIGH --ks 40   # the same checks

Run from the repository's root.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

TEACHER = "results/recipe/teacher_field.npz"


class CodebookNet:
    """Trunk and softmax head (torch) over ``codebook`` (N, 5), and the observation statistics."""

    kind = "codebook"

    def __init__(self, n_obs: int, codebook: np.ndarray, net_arch, seed: int):
        import torch

        torch.manual_seed(seed)
        layers, width = [], n_obs
        for h in net_arch:
            layers += [torch.nn.Linear(width, h), torch.nn.ReLU()]
            width = h
        layers.append(torch.nn.Linear(width, len(codebook)))
        self.net = torch.nn.Sequential(*layers)
        self.codebook = np.asarray(codebook, dtype=np.float64)
        self.index = {row.tobytes(): i for i, row in enumerate(self.codebook)}
        self.obs_mean = self.obs_var = None

    def classes(self, actions: np.ndarray) -> np.ndarray:
        return np.array([self.index[row.tobytes()] for row in np.ascontiguousarray(actions, dtype=np.float64)])

    def normalise(self, obs: np.ndarray) -> np.ndarray:
        return np.clip((obs - self.obs_mean) / np.sqrt(self.obs_var + 1e-8), -10.0, 10.0)

    def act(self, obs: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            logits = self.net(torch.as_tensor(self.normalise(obs.astype(np.float64)), dtype=torch.float32))
        return self.codebook[logits.argmax(-1).numpy()]

    def save(self, path: Path, record: dict) -> None:
        import torch

        torch.save({"kind": self.kind, "state": self.net.state_dict(), "codebook": self.codebook,
                    "obs_mean": self.obs_mean, "obs_var": self.obs_var, "net_arch": record["net_arch"],
                    "record": record}, path)

    @classmethod
    def load(cls, path: Path):
        import torch

        d = torch.load(path, weights_only=False)
        self = cls(len(d["obs_mean"]), d["codebook"], d["net_arch"], 0)
        self.net.load_state_dict(d["state"])
        self.obs_mean, self.obs_var = d["obs_mean"], d["obs_var"]
        return self


def round0_episodes(field, cfg, seed: int, time_quantum: float):
    """Round 0's points (random, focus band, jump bisection) and the node teacher's episodes there: the
    recipe's ``round_points`` with ``action_codebook`` (its teacher plays the grid's own drives, as
    ``node_teacher.node_best``)."""
    import dataclasses

    from mdr_drive_agents.distill import round_points
    from mdr_drive_agents.teacher_data import labelled_episodes

    cfg = dataclasses.replace(cfg, action_codebook=True, quantum_centres=True)
    points, drives, n_jump = round_points(field, cfg, np.random.default_rng(seed))
    obs, sample_drives = labelled_episodes(field, points, None, cfg, seed, 0.0, time_quantum, drives=drives)
    return obs, sample_drives, n_jump


def fit_codebook(a) -> None:
    import torch

    from mdr_drive_agents.evaluate import ACTION_MAP
    from mdr_drive_agents.distill import epoch_samples
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe
    from mdr_drive_agents.student import adam_fit

    recipe = load_recipe(DEFAULT_CONFIG)
    cfg = recipe["distill"]
    torch.set_num_threads(cfg.torch_threads)
    seed = recipe["student_seed"] if a.seed is None else a.seed
    field = DriveField.load(TEACHER)
    codebook = np.unique(ACTION_MAP.quantum_centre(field.drives.reshape(-1, 5)), axis=0)
    t0 = time.perf_counter()
    obs, drives, n_jump = round0_episodes(field, cfg, seed, float(recipe["env_kwargs"]["time_quantum"]))
    t_data = time.perf_counter() - t0
    print(f"codebook: {len(codebook)} actions; round-0 samples {len(obs)} ({n_jump} jump points) [{t_data:.0f} s]",
          flush=True)
    model = CodebookNet(obs.shape[1], codebook, cfg.net_arch, seed)
    obs64 = obs.astype(np.float64)
    model.obs_mean, model.obs_var = obs64.mean(axis=0), obs64.var(axis=0)
    rng = np.random.default_rng(seed)

    def epoch():
        x, y = epoch_samples(obs, drives, rng, cfg.perturbed_share)
        y = torch.as_tensor(model.classes(y))
        x = torch.as_tensor(model.normalise(x.astype(np.float64)), dtype=torch.float32)
        return len(x), lambda idx: torch.nn.functional.cross_entropy(model.net(x[idx]), y[idx])

    t1 = time.perf_counter()
    loss = adam_fit(model.net.parameters(), epoch, a.steps, cfg.batch, cfg.learning_rate, seed, "codebook: fit")
    rec = {"codebook_actions": len(codebook), "seed": seed, "steps": a.steps, "net_arch": list(cfg.net_arch), "loss": loss,
           "samples": len(obs), "jump_points": n_jump, "data_s": round(t_data, 1),
           "fit_s": round(time.perf_counter() - t1, 1), "command": " ".join(sys.argv)}
    print(rec, flush=True)
    model.save(Path(a.net), rec)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fit", help="round 0 on the node teacher, and the classifier's fit")
    f.add_argument("net", help="file to write (.pt)")
    f.add_argument("--steps", type=int, default=60000, help="Adam steps (-)")
    f.add_argument("--seed", type=int, default=None, help="the student's seed (default: the recipe's student_seed)")
    a = p.parse_args()
    fit_codebook(a)


if __name__ == "__main__":
    main()
