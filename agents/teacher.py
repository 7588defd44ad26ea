"""A CMA-ES teacher for warm-starting policies: per-point optimal fixed waveforms, cloned into the policy.

    python -m agents.teacher --points 160 --out runs/teacher.npz     # about 3 minutes on 2 cores

CMA-ES finds the best fixed action at sampled (k, load) points of the training distribution
(a third of them without load, where the best waveform is far from the trapezoid). Each action is
rolled out in the batched env to record the observations it visits; ``clone_into`` then fits the
policy's mean action to the teacher's action on those observations (behaviour cloning), and PPO
starts from there (``warm_start: cma`` in the config).
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import mdr_drive_env  # noqa: F401  registers MDRDrive-v0

from .baselines import CMA_BUDGET, cma_optimize

ENV_ID = "MDRDrive-v0"


def sample_points(n: int, k_range=(0.0, 0.6), ratio_range=(0.0, 0.6), no_load_share: float = 1 / 3, seed: int = 0):
    """(k, cargo mass) points: k uniform, load uniform as a fraction of mu F_ref, a share without load."""
    rng = np.random.default_rng(seed)
    env = gym.make(ENV_ID).unwrapped
    points = []
    for i in range(n):
        k = float(rng.uniform(*k_range))
        ratio = 0.0 if i < int(no_load_share * n) else float(rng.uniform(*ratio_range))
        p0 = env.params_for(k, 0.0)
        points.append((k, ratio * p0.contact.friction_coefficient * env.reference_force(p0) / p0.drive.gravity))
    return points


def _optimize(args):
    (k, m), budget = args
    return cma_optimize(k, m, budget).action


def build(n: int = 160, periods: int = 50, seed: int = 0, workers: int | None = None, env_kwargs=None,
          budget: int = CMA_BUDGET) -> dict:
    """Teacher dataset: points, actions, and the (observation, action) pairs of their rollouts."""
    points = sample_points(n, seed=seed)
    workers = workers or len(os.sched_getaffinity(0))
    jobs = [(p, budget) for p in points]
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            actions = np.array(list(tqdm(pool.map(_optimize, jobs), total=n, desc="CMA-ES teacher", unit="point")))
    else:
        actions = np.array([_optimize(j) for j in jobs])
    kw = {key: v for key, v in (env_kwargs or {}).items() if key not in ("k", "cargo_mass", "load_ratio")}
    kw["max_periods"] = periods
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    obs, _ = venv.reset(seed=seed, options={"k": [p[0] for p in points], "cargo_mass": [p[1] for p in points]})
    all_obs = []
    for _ in range(periods):
        all_obs.append(obs.copy())
        obs, *_ = venv.step(actions.astype(np.float32))
    obs = np.concatenate(all_obs)
    return {"points": np.array(points), "actions": actions, "obs": obs,
            "targets": np.tile(actions, (periods, 1)).astype(np.float32)}


def clone_into(model, data: dict, venv, epochs: int = 60, batch: int = 512, lr: float = 1e-3, seed: int = 0) -> float:
    """Fit the policy's mean action to the teacher (MSE); set VecNormalize's observation statistics
    from the teacher's observations first. Returns the final mean squared error."""
    import torch

    obs = data["obs"].astype(np.float64)
    if hasattr(venv, "obs_rms"):
        venv.obs_rms.mean = obs.mean(axis=0)
        venv.obs_rms.var = obs.var(axis=0)
        venv.obs_rms.count = float(len(obs))
        obs = venv.normalize_obs(obs)
    x = torch.as_tensor(obs, dtype=torch.float32)
    y = torch.as_tensor(data["targets"], dtype=torch.float32)
    policy = model.policy
    params = list(policy.mlp_extractor.policy_net.parameters()) + list(policy.action_net.parameters())
    if hasattr(policy, "features_extractor"):
        params += list(policy.features_extractor.parameters())
    opt = torch.optim.Adam(params, lr=lr)
    gen = torch.Generator().manual_seed(seed)
    loss = torch.tensor(0.0)
    for _ in range(epochs):
        perm = torch.randperm(len(x), generator=gen)
        for i in range(0, len(x), batch):
            idx = perm[i:i + batch]
            dist = policy.get_distribution(x[idx])
            loss = torch.mean((dist.distribution.mean - y[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
    with torch.no_grad():
        return float(torch.mean((policy.get_distribution(x).distribution.mean - y) ** 2))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=160, help="(k, load) points (-)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the point sample (-)")
    ap.add_argument("--out", default="runs/teacher.npz", help="output .npz")
    a = ap.parse_args(argv)
    import time

    t0 = time.perf_counter()
    data = build(a.points, seed=a.seed)
    data["wall_time_s"] = np.array(time.perf_counter() - t0)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(a.out, **data)
    print(f"wrote {a.out}: {len(data['points'])} points, {len(data['obs'])} observation-action pairs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
