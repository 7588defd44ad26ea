"""A CMA-ES teacher for warm-starting policies: per-point optimal open-loop drives, cloned into the policy.

    python -m agents.teacher --points 160 --stall-points 192 --transition-points 64 --cycle-budget 2500 \
        --out runs/teacher.npz      # about 18 minutes on 2 cores
    python -m agents.teacher --refine runs/teacher4.npz --neighbours 8 --out runs/teacher6.npz  # exchange only

(The shipped recipe then adds points where the teacher's lookup fails: ``agents/lookup_refine.py``.)

CMA-ES finds the best open-loop drive at sampled (k, load) points: points of the training
distribution (a third of them without load, where the best waveform is far from the trapezoid),
points near the trapezoid's stall load (0.85-1.5 times its critical load) and, optionally, points
below it (0.6-0.9 times), where the best drive turns from a fixed waveform into a cycle. At loaded
points it searches both fixed actions and cycles of two actions played in turn (a "push" period
and a "clamp" period, which carry loads no fixed waveform moves) and keeps the better. Optionally
(``--neighbours``; off by default, as it made the trained policies worse, docs/results.md) every
point then tries its nearest points' drives and keeps the best (``exchange_with_neighbours``).
Each drive is rolled out in the batched env to record the observations it visits; ``clone_into``
then fits the policy's mean action (PPO's Gaussian mean or SAC's tanh-squashed one) to the
teacher's action on those observations (behaviour cloning; the observation holds the previous
action, so a policy can alternate), and the RL algorithm starts from there (``warm_start:
cma:<teacher.npz>`` in the config). ``teacher_regulariser`` keeps pulling the policy towards the
teacher during training (``teacher_steps_per_rollout`` in the config).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import mdr_drive_env  # noqa: F401  registers MDRDrive-v0
from mdr_drive_env.sweep import Executor, TaskStore, add_executor_arguments, executor_from

from .baselines import CMA_BUDGET, PUSH_CLAMP, cma_optimize
from .evaluate import open_loop_velocity, trapezoid_action

ENV_ID = "MDRDrive-v0"


#: CMA-ES evaluations of the two-action search per loaded point.
CYCLE_BUDGET = 2500
#: Loads of the stall points and of the transition points, as multiples of the trapezoid's critical load.
STALL_RANGE = (0.85, 1.5)
TRANSITION_RANGE = (0.6, 0.9)


def _reference_mass(env, k: float) -> float:
    """mu F_ref / g (kg) at k: the load scale of the env's ``load_ratio`` (``env``: an unwrapped MDRDrive)."""
    p0 = env.params_for(k, 0.0)
    return p0.contact.friction_coefficient * env.reference_force(p0) / p0.drive.gravity


def sample_points(n: int, k_range=(0.0, 0.6), ratio_range=(0.0, 0.6), no_load_share: float = 1 / 3, seed: int = 0):
    """(k, cargo mass) points: k uniform, load uniform as a fraction of mu F_ref, a share without load."""
    rng = np.random.default_rng(seed)
    env = gym.make(ENV_ID).unwrapped
    points = []
    for i in range(n):
        k = float(rng.uniform(*k_range))
        ratio = 0.0 if i < int(no_load_share * n) else float(rng.uniform(*ratio_range))
        points.append((k, ratio * _reference_mass(env, k)))
    return points


def sample_stall_points(n: int, k_range=(0.0, 0.6), factor_range=STALL_RANGE, seed: int = 1):
    """(k, cargo mass) points near stall: k uniform, load a uniform factor times the trapezoid's critical load."""
    from .benchmark import critical_loads_grid

    rng = np.random.default_rng(seed)
    ks = rng.uniform(*k_range, n)
    crit = critical_loads_grid(list(ks), lambda pts: open_loop_velocity(pts, trapezoid_action()))
    return [(float(k), float(rng.uniform(*factor_range) * crit[k])) for k in ks]


def _optimize(args):
    """Best open-loop drive at one point as a two-action cycle (a fixed action is repeated)."""
    (k, m), budget, cycle_budget = args
    fixed = cma_optimize(k, m, budget)
    best, velocity = np.tile(fixed.action, (2, 1)), fixed.velocity
    if m > 0.0 and cycle_budget > 0:
        cyc = cma_optimize(k, m, cycle_budget, popsize=16, sigma0=0.4, cycle=2, x0=PUSH_CLAMP)
        if cyc.velocity > velocity:
            best, velocity = cyc.action, cyc.velocity
    return best, velocity


def build(n: int = 160, periods: int = 50, seed: int = 0, workers: int | None = None, env_kwargs=None,
          budget: int = CMA_BUDGET, n_stall: int = 192, cycle_budget: int = CYCLE_BUDGET,
          n_transition: int = 0, executor=None, store=None) -> dict:
    """Teacher dataset: points, their drives (n, 2, 5) and steady velocities, and the (observation,
    action) pairs of their rollouts.

    Points: ``n`` of the training distribution, ``n_stall`` near the trapezoid's stall
    (``STALL_RANGE``) and ``n_transition`` below it (``TRANSITION_RANGE``: where the best drive
    changes from a fixed waveform to a cycle, so the policy learns where to switch). The searches run
    on ``executor`` (``mdr_drive_env.sweep``; default ``workers`` local processes), each kept in
    ``store`` as it finishes."""
    points = sample_points(n, seed=seed) + (sample_stall_points(n_stall, seed=seed + 1) if n_stall else [])
    if n_transition:
        points += sample_stall_points(n_transition, factor_range=TRANSITION_RANGE, seed=seed + 2)
    jobs = [(p, budget, cycle_budget) for p in points]
    found = (executor or Executor(workers=workers)).map(_optimize, jobs, "CMA-ES teacher", store=store)
    cycles = np.array([f[0] for f in found])
    data = {"points": np.array(points), "actions": cycles, "velocities": np.array([f[1] for f in found])}
    return record_rollouts(data, periods=periods, seed=seed, env_kwargs=env_kwargs)


def record_rollouts(data: dict, periods: int = 50, seed: int = 0, env_kwargs=None) -> dict:
    """``data`` with the observations its drives visit in the batched env and the teacher's action at
    each ("obs", "targets"; period t of point i is row t n + i)."""
    points, cycles = data["points"], data["actions"]
    kw = {key: v for key, v in (env_kwargs or {}).items() if key not in ("k", "cargo_mass", "load_ratio")}
    kw["max_periods"] = periods
    venv = gym.make_vec(ENV_ID, num_envs=len(points), vectorization_mode="vector_entry_point", **kw)
    obs, _ = venv.reset(seed=seed, options={"k": [p[0] for p in points], "cargo_mass": [p[1] for p in points]})
    all_obs, targets = [], []
    for t in range(periods):
        all_obs.append(obs.copy())
        targets.append(cycles[:, t % 2])
        obs, *_ = venv.step(cycles[:, t % 2].astype(np.float32))
    return {**data, "obs": np.concatenate(all_obs), "targets": np.concatenate(targets).astype(np.float32)}


#: Stalled points (the trapezoid does not move the load) judge a drive also at this multiple of their load.
LOAD_MARGIN = 1.15


def _scores(points, drives, stalled, load_margin):
    """Score of each drive at its point (m/s): the steady velocity, and at stalled points the smaller of
    it and the velocity at ``load_margin`` times the load. Returns (scores, velocities)."""
    v = open_loop_velocity([tuple(p) for p in points], drives)
    if not load_margin or not stalled.any():
        return v, v
    heavier = [(k, m * load_margin) for k, m in points[stalled]]
    scores = v.copy()
    scores[stalled] = np.minimum(v[stalled], open_loop_velocity(heavier, drives[stalled]))
    return scores, v


def exchange_with_neighbours(data: dict, neighbours: int = 8, load_margin: float | None = LOAD_MARGIN,
                             max_rounds: int = 20) -> tuple[dict, dict]:
    """Give every point the best drive among its own and its ``neighbours`` nearest points' (in the
    (k, load ratio) metric of ``agents.reward_scale``), judged at the point; repeated until no point
    improves (``max_rounds`` at most).

    The per-point CMA-ES runs are independent and a run may stall in a poor local optimum (a clamp
    period that barely moves the load) next to points whose drive does far better there; the
    policy is then cloned towards a teacher that is worse than itself. Where the trapezoid does not
    move the load, a drive is judged by the smaller of its velocity at the point's load and at
    ``load_margin`` times it: a drive that is fast at this load but stalls just above it (a fast
    clamp period) would spread over the points just above the trapezoid's stall and leave the
    policy to switch to the load-carrying cycle at a load of its own guessing, which is where its
    critical load is decided. Returns the new data (observations recorded again) and a summary."""
    from .reward_scale import teacher_coordinates

    points, actions = np.asarray(data["points"], dtype=np.float64), np.array(data["actions"], dtype=np.float64)
    n = len(points)
    stalled = open_loop_velocity([tuple(p) for p in points], trapezoid_action()) <= 0.0
    scores, velocities = _scores(points, actions, stalled, load_margin)
    xy = teacher_coordinates(data)
    near = np.argsort(np.linalg.norm(xy[:, None] - xy[None], axis=2), axis=1)[:, 1:neighbours + 1]
    before, rounds, improved = velocities.copy(), 0, np.zeros(n, bool)
    for rounds in range(1, max_rounds + 1):
        i_of, j_of = np.repeat(np.arange(n), neighbours), near.ravel()
        s, v = _scores(points[i_of], actions[j_of], stalled[i_of], load_margin)
        new_a, new_s, new_v = actions.copy(), scores.copy(), velocities.copy()
        for i, j, sij, vij in zip(i_of, j_of, s, v):
            if sij > new_s[i]:
                new_a[i], new_s[i], new_v[i] = actions[j], sij, vij
        changed = new_s > scores
        actions, scores, velocities = new_a, new_s, new_v
        improved |= changed
        if not changed.any():
            break
    gain = (velocities - before)[improved] * 1e3
    summary = {"neighbours": neighbours, "load_margin": load_margin, "rounds": rounds,
               "points_improved": int(improved.sum()), "stalled_points_improved": int((improved & stalled).sum()),
               "median_velocity_gain_mm_s": float(np.median(gain)) if gain.size else 0.0}
    refined = {key: data[key] for key in data if key not in ("obs", "targets")}
    refined.update(actions=actions, velocities=velocities)
    return record_rollouts(refined, periods=len(data["obs"]) // n), summary


#: SAC's action is tanh of a Gaussian sample: teacher actions on the box's edge are fitted this far inside.
SQUASH_LIMIT = 0.999


def _squashed(policy) -> bool:
    return hasattr(policy, "actor")  # SAC; PPO's ActorCriticPolicy has no actor


def policy_mean(policy, obs):
    """The deterministic action of an SB3 policy on (normalised) observations, as a torch tensor:
    PPO's Gaussian mean (SB3 clips it to the box when acting), SAC's tanh-squashed mean."""
    import torch

    if _squashed(policy):
        return torch.tanh(policy.actor.get_action_dist_params(obs)[0])
    return policy.get_distribution(obs).distribution.mean


def _targets(policy, data: dict):
    """The teacher's actions; for SAC clipped to +-``SQUASH_LIMIT``, which its tanh can reach.
    (Fitting SAC's mean before the tanh to atanh of the actions instead, so the gradient does not
    vanish at the box's edges, fitted worse and trained worse: docs/results.md, SAC.)"""
    import torch

    y = torch.as_tensor(data["targets"], dtype=torch.float32)
    return torch.clamp(y, -SQUASH_LIMIT, SQUASH_LIMIT) if _squashed(policy) else y


def _mean_parameters(policy) -> list:
    """The parameters the mean action depends on (not the log std, not a critic)."""
    if _squashed(policy):
        a = policy.actor
        return [*a.features_extractor.parameters(), *a.latent_pi.parameters(), *a.mu.parameters()]
    params = [*policy.mlp_extractor.policy_net.parameters(), *policy.action_net.parameters()]
    return params + ([*policy.features_extractor.parameters()] if hasattr(policy, "features_extractor") else [])


def _set_log_std(policy, log_std: float) -> None:
    """PPO: the state-independent log std. SAC: the log std head's output (before the tanh), made
    nearly state-independent."""
    if _squashed(policy):
        policy.actor.log_std.weight.mul_(0.01)
        policy.actor.log_std.bias.fill_(log_std)
    else:
        policy.log_std.fill_(log_std)


def clone_into(model, data: dict, venv, epochs: int = 60, batch: int = 512, lr: float = 1e-3, seed: int = 0,
               min_steps: int = 1500, log_std: float | None = None) -> float:
    """Fit the policy's mean action (PPO or SAC) to the teacher (MSE); set VecNormalize's observation
    statistics from the teacher's observations first, and the policy's log standard deviation to
    ``log_std`` after (if given: the RL algorithm then explores near the cloned drive instead of
    blurring it; the two-action cycles near stall only pay when played accurately). Returns the
    final mean squared error."""
    import torch

    obs = data["obs"].astype(np.float64)
    if hasattr(venv, "obs_rms"):
        venv.obs_rms.mean = obs.mean(axis=0)
        venv.obs_rms.var = obs.var(axis=0)
        venv.obs_rms.count = float(len(obs))
        obs = venv.normalize_obs(obs)
    x = torch.as_tensor(obs, dtype=torch.float32)
    policy = model.policy
    y = _targets(policy, data)
    opt = torch.optim.Adam(_mean_parameters(policy), lr=lr)
    gen = torch.Generator().manual_seed(seed)
    per_epoch = -(-len(x) // batch)
    for _ in range(max(epochs, -(-min_steps // per_epoch))):  # small data sets: still min_steps updates
        perm = torch.randperm(len(x), generator=gen)
        for i in range(0, len(x), batch):
            idx = perm[i:i + batch]
            loss = torch.mean((policy_mean(policy, x[idx]) - y[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
    with torch.no_grad():
        if log_std is not None:
            _set_log_std(policy, log_std)
        return float(torch.mean((policy_mean(policy, x) - y) ** 2))


def teacher_regulariser(data: dict, steps_per_rollout: int = 10, batch: int = 512, weight: float = 1.0,
                        seed: int = 0):
    """Callback for PPO or SAC: after every rollout, ``steps_per_rollout`` supervised steps that pull
    the policy's mean action towards the teacher's on the teacher's observations (normalised with the
    current VecNormalize statistics), with the algorithm's own policy (actor) optimiser; a
    demo-augmented policy gradient (DAPG, Rajeswaran et al. 2018) in its simplest form. SAC's
    rollout is one env step per env (``train_freq: 1``), so it wants fewer steps per rollout than PPO.

    PPO alone lets the drives near stall drift: their rewards are tiny next to the unloaded drives',
    so the return hardly notices a clamp period that is 0.1 off its optimum, but the critical load
    does. The mean is clipped to the action box before the squared error, so a teacher action on
    the box's edge does not hold PPO's mean at the edge. (Without the clip where the target lies
    inside the box, so that a mean outside it is pulled back, the policies did worse at k >= 0.4:
    docs/results.md.) Logs the last step's squared error as
    ``train/teacher_mse``."""
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    obs = data["obs"].astype(np.float64)
    gen = torch.Generator().manual_seed(seed)

    class TeacherRegulariser(BaseCallback):
        def _init_callback(self) -> None:
            self.targets = _targets(self.model.policy, data)

        def _on_rollout_end(self) -> None:
            env = self.model.get_env()
            normalise = env.normalize_obs if hasattr(env, "normalize_obs") else (lambda o: o)
            policy = self.model.policy
            optimizer = policy.actor.optimizer if _squashed(policy) else policy.optimizer
            y = self.targets
            policy.set_training_mode(True)
            for _ in range(steps_per_rollout):
                idx = torch.randint(len(obs), (batch,), generator=gen)
                x = torch.as_tensor(normalise(obs[idx.numpy()]), dtype=torch.float32)
                mean = torch.clamp(policy_mean(policy, x), -1.0, 1.0)
                loss = weight * torch.mean((mean - y[idx]) ** 2)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            self.logger.record("train/teacher_mse", float(loss.detach()) / weight)

        def _on_step(self) -> bool:
            return True

    return TeacherRegulariser()


def load_for_update(path: str | Path, command: str) -> tuple[dict, str, float]:
    """A teacher file to be changed by ``command``: (its data without "command" and "wall_time_s",
    its command chain with ``command`` appended, the wall time (s) spent on it so far)."""
    data = {key: v for key, v in np.load(path).items()}
    return data, f"{data.pop('command', '')} ; {command}", float(data.pop("wall_time_s", 0.0))


def save(path: str | Path, data: dict, command: str, wall_time_s: float) -> None:
    """Write a teacher file with the command chain that made it and its total wall time (s)."""
    data = {**data, "wall_time_s": np.array(wall_time_s), "command": np.array(command)}
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **data)
    print(f"wrote {path}: {len(data['points'])} points, {len(data['obs'])} observation-action pairs, "
          f"{wall_time_s:.0f} s in all")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=160, help="(k, load) points (-)")
    ap.add_argument("--stall-points", type=int, default=192,
                    help="extra points at 0.85-1.5 times the trapezoid's critical load (-)")
    ap.add_argument("--transition-points", type=int, default=0,
                    help="extra points at 0.6-0.9 times the trapezoid's critical load, where the best drive "
                         "turns from a fixed waveform into a cycle (-)")
    ap.add_argument("--cycle-budget", type=int, default=CYCLE_BUDGET,
                    help="CMA-ES evaluations of the two-action search per loaded point (-)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the point sample (-)")
    ap.add_argument("--neighbours", type=int, default=0,
                    help="after CMA-ES, each point also tries its nearest points' drives and keeps the best, "
                         "until none improves (0: off, the default) (-)")
    ap.add_argument("--load-margin", type=float, default=LOAD_MARGIN,
                    help="in the exchange, points the trapezoid does not move judge a drive by its velocity at "
                         "the load and at this multiple of it, whichever is smaller (0: the load only) (-)")
    ap.add_argument("--refine", default=None, metavar="TEACHER.npz",
                    help="skip CMA-ES: apply the --neighbours exchange to an existing teacher")
    ap.add_argument("--out", default="runs/teacher.npz", help="output .npz")
    add_executor_arguments(ap)
    a = ap.parse_args(argv)
    if a.refine and a.neighbours <= 0:
        ap.error("--refine applies the exchange: give --neighbours N with N > 0")
    import json
    import time

    t0 = time.perf_counter()
    command = " ".join(["python -m agents.teacher", *(argv if argv is not None else sys.argv[1:])])
    if a.refine:
        data, command, earlier = load_for_update(a.refine, command)
    else:
        store = TaskStore(Path(a.out).parent / ".tasks" / Path(a.out).stem)
        if not a.resume:
            store.clear()
        try:
            executor = executor_from(a)
        except ValueError as e:
            ap.error(str(e))
        data = build(a.points, seed=a.seed, n_stall=a.stall_points, cycle_budget=a.cycle_budget,
                     n_transition=a.transition_points, executor=executor, store=store)
        earlier = 0.0
    if a.neighbours > 0:
        t1 = time.perf_counter()
        data, summary = exchange_with_neighbours(data, a.neighbours, a.load_margin or None)
        summary["wall_time_s"] = time.perf_counter() - t1
        data["exchange"] = np.array(json.dumps(summary))
        print("neighbour exchange:", json.dumps(summary))
    save(a.out, data, command, earlier + time.perf_counter() - t0)
    if not a.refine:
        store.clear()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
