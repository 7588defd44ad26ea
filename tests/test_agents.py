"""agents/: training, resume, evaluation and the baselines of the waveform benchmark."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("cma")

from agents.baselines import cma_optimize  # noqa: E402
from agents.evaluate import (  # noqa: E402
    AVERAGE_PERIODS,
    EVAL_PERIODS,
    Policy,
    open_loop_velocity,
    policy_rollout,
    trapezoid_action,
)
from agents.train import train  # noqa: E402
from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform  # noqa: E402
from mdr_drive_env.gym_envs.spaces import ActionMap  # noqa: E402


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_writes_model_stats_tensorboard_and_resumes(algo, tmp_path):
    out = tmp_path / algo
    kw = dict(n_envs=4, eval_freq=200, checkpoint_freq=200, progress_bar=False)
    first = train(algo, steps=256, seed=0, out=out, **kw)
    assert first["total_timesteps"] >= 256
    for name in ("model.zip", "vecnormalize.pkl", "run.json", "evaluations.npz"):
        assert (out / name).exists(), name
    assert list((out / "tb").rglob("events.out.tfevents*"))
    assert list((out / "checkpoints").glob("*vecnormalize*.pkl"))
    record = json.loads((out / "run.json").read_text())
    assert record["seed"] == 0 and record["versions"]["torch"].startswith("2.13") and record["wall_time_s"] > 0
    resumed = train(resume=out, steps=128, **kw)
    assert resumed["total_timesteps"] >= first["total_timesteps"] + 128
    assert resumed["resumes"] == 1
    policy = Policy(out)
    v = open_loop_velocity([(0.2, 0.1)], policy(np.zeros((1, 14), dtype=np.float32)))
    assert np.isfinite(v).all()


def test_evaluate_cli_prints_finite_velocities(tmp_path):
    out = tmp_path / "ppo"
    train("ppo", steps=128, seed=1, out=out, n_envs=4, eval_freq=10_000, progress_bar=False)
    res = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "evaluate", "--policy", str(out), "--k", "0.2",
                          "--cargo-mass", "0.1", "--json"], capture_output=True, text=True, check=True)
    data = json.loads(res.stdout)
    assert np.isfinite(data["learned_mean_velocity"]) and np.isfinite(data["trapezoid_mean_velocity"])
    assert set(data["learned_waveform_last_period"]) >= {"x_amplitude", "z_amplitude", "z_phase"}


def test_trapezoid_baseline_equals_the_simulator_with_the_paper_waveform():
    points = [(0.0, 0.1), (0.2, 0.1), (0.5, 0.0)]
    v = open_loop_velocity(points, trapezoid_action())
    for (k, m), vb in zip(points, v):
        sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), "fast")
        d = [r.displacement for r in sim.run(Waveform.paper(), EVAL_PERIODS)]
        assert vb == pytest.approx(np.mean(d[-AVERAGE_PERIODS:]) / 2e-3, rel=1e-12, abs=1e-15)


def test_cma_es_on_a_tiny_budget_stays_in_the_box_and_beats_nothing_it_did_not_see():
    r = cma_optimize(0.2, 0.1, budget=24, popsize=6, seed=3)
    assert r.action.shape == (5,) and np.all(r.action >= -1.0) and np.all(r.action <= 1.0)
    assert r.evaluations <= 31  # the trapezoid + at most 5 populations of 6
    assert r.velocity == pytest.approx(open_loop_velocity([(0.2, 0.1)], r.action)[0], rel=1e-12)


def test_a_cycle_of_two_actions_alternates_the_waveforms_period_by_period():
    a = trapezoid_action()
    b = np.array([-0.8, -0.9, 1.0, -0.9, 0.8])
    points = [(0.1, 0.2), (0.3, 0.05)]
    # a cycle of one action repeated is that fixed action
    np.testing.assert_array_equal(open_loop_velocity(points, np.tile(a, (2, 2, 1))), open_loop_velocity(points, a))
    # (a, b) in turn is the simulator run with a, b, a, b, ...
    v = open_loop_velocity(points, np.stack([a, b])[None].repeat(2, axis=0))
    amap = ActionMap()
    for (k, m), vb in zip(points, v):
        sim = DriveSimulator(DriveParams.paper(k=k, cargo_mass=m), "fast")
        d = [sim.step(amap.to_waveform((a, b)[t % 2])).displacement for t in range(EVAL_PERIODS)]
        assert vb == pytest.approx(np.mean(d[-AVERAGE_PERIODS:]) / 2e-3, rel=1e-12, abs=1e-15)


def test_cma_es_over_two_action_cycles_stays_in_the_box():
    r = cma_optimize(0.3, 0.08, budget=40, popsize=8, seed=1, cycle=2, x0=np.zeros((2, 5)))
    assert r.action.shape == (2, 5) and np.all(np.abs(r.action) <= 1.0)
    assert r.velocity == pytest.approx(open_loop_velocity([(0.3, 0.08)], r.action[None])[0], rel=1e-12)


def test_policy_rollout_uses_each_points_own_load():
    class Constant:
        def __call__(self, obs):
            return np.tile(np.array([1.0, 1.0, 1.0, 0.7777778, -1.0], dtype=np.float32), (len(obs), 1))

    disp, acts, _ = policy_rollout(Constant(), [(0.0, 0.0), (0.0, 0.6)], periods=6)
    assert disp.shape == (6, 2) and acts.shape == (6, 2, 5)
    assert disp[-1, 0] > disp[-1, 1]  # the heavier load moves less


def test_rl_zoo_trains_with_the_shipped_config(tmp_path):
    pytest.importorskip("rl_zoo3")

    conf = Path(__file__).parents[1] / "agents" / "configs" / "ppo.yaml"
    res = subprocess.run([sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "MDRDrive-v0",
                          "--gym-packages", "mdr_drive_env", "-n", "300", "-conf", str(conf), "--log-folder",
                          str(tmp_path), "--eval-freq", "-1", "--env-kwargs", "k:(0.0,0.6)", "load_ratio:(0.0,0.6)",
                          "reward_floor:-2.0"], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert list(tmp_path.rglob("MDRDrive-v0.zip")) and list(tmp_path.rglob("vecnormalize.pkl"))


def test_cma_teacher_is_cloned_into_the_policy(tmp_path):
    from agents.teacher import build

    data = build(n=3, periods=4, workers=1, budget=24, n_stall=2, cycle_budget=32)
    assert data["obs"].shape == (20, 14) and data["targets"].shape == (20, 5)
    assert data["actions"].shape == (5, 2, 5) and np.all(np.abs(data["actions"]) <= 1.0)
    # the rollouts play each point's two actions in turn
    np.testing.assert_array_equal(data["targets"][5:10], data["actions"][:, 1].astype(np.float32))
    np.savez(tmp_path / "teacher.npz", **data)
    out = tmp_path / "ppo_bc"
    record = train("ppo", steps=64, seed=0, out=out, n_envs=4, eval_freq=10_000, progress_bar=False,
                   warm_start=f"cma:{tmp_path / 'teacher.npz'}")
    assert record["hyperparameters"]["warm_start_mse"] < 0.02  # the policy's mean reproduces the teacher
    assert record["hyperparameters"]["teacher_steps_per_rollout"] == 10  # the shipped config's regulariser
    resumed = train(resume=out, steps=64, n_envs=4, eval_freq=10_000, progress_bar=False)
    assert resumed["hyperparameters"]["teacher_steps_per_rollout"] == 10  # a resumed run keeps its recipe
    assert resumed["hyperparameters"]["warm_start"] == record["hyperparameters"]["warm_start"]
    config = tmp_path / "ppo_scaled.yaml"  # the optional per-episode reward scale trains and resumes too
    config.write_text((Path(__file__).parents[1] / "agents/configs/ppo.yaml").read_text()
                      + "teacher_velocity_floor: 2.5e-4\n")
    scaled = train("ppo", steps=64, seed=0, out=tmp_path / "ppo_scaled", n_envs=4, eval_freq=10_000, config=config,
                   progress_bar=False, warm_start=f"cma:{tmp_path / 'teacher.npz'}")
    assert scaled["hyperparameters"]["teacher_velocity_floor"] == 2.5e-4
    resumed = train(resume=tmp_path / "ppo_scaled", steps=64, n_envs=4, eval_freq=10_000, progress_bar=False)
    assert resumed["hyperparameters"]["teacher_velocity_floor"] == 2.5e-4
    sac = train("sac", steps=64, seed=0, out=tmp_path / "sac_bc", n_envs=2, eval_freq=10_000, progress_bar=False,
                warm_start=f"cma:{tmp_path / 'teacher.npz'}")
    assert sac["hyperparameters"]["warm_start_mse"] < 0.02  # SAC's tanh-squashed mean reproduces it too


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_teacher_regulariser_pulls_the_policy_mean_towards_the_teacher(algo):
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.teacher import teacher_regulariser
    from agents.train import make_train_env

    venv = VecNormalize(make_train_env(4, 0, {"k": (0.0, 0.6), "load_ratio": (0.0, 0.3)}))
    venv.reset()
    obs = np.repeat(venv.get_original_obs(), 16, axis=0)
    target = np.array([0.5, -0.5, 1.0, -0.9, 0.2], dtype=np.float32)
    data = {"obs": obs, "targets": np.tile(target, (len(obs), 1))}
    if algo == "ppo":
        model = PPO("MlpPolicy", venv, n_steps=8, batch_size=32, seed=0, device="cpu")
    else:
        model = SAC("MlpPolicy", venv, batch_size=32, seed=0, device="cpu")
    model.set_logger(configure(None, []))

    def error() -> float:
        mean, _ = model.predict(venv.normalize_obs(obs), deterministic=True)
        return float(np.mean((np.clip(mean, -1, 1) - target) ** 2))

    callback = teacher_regulariser(data, steps_per_rollout=300, batch=32)
    callback.init_callback(model)
    before = error()
    callback.on_rollout_end()
    assert error() < 0.5 * before


def test_stall_and_transition_points_lie_at_their_multiples_of_the_trapezoids_critical_load():
    from agents.benchmark import critical_loads_grid
    from agents.teacher import STALL_RANGE, TRANSITION_RANGE, sample_stall_points

    for factors in (STALL_RANGE, TRANSITION_RANGE):
        points = sample_stall_points(3, factor_range=factors, seed=5)
        crit = critical_loads_grid([k for k, _ in points], lambda p: open_loop_velocity(p, trapezoid_action()))
        assert all(factors[0] <= m / crit[k] <= factors[1] for k, m in points)


def test_quick_benchmark_writes_tables_plots_and_a_consistent_summary(tmp_path):
    from agents.benchmark import QUICK_KS, QUICK_MASSES, run

    policy = tmp_path / "ppo"
    train("ppo", steps=64, seed=0, out=policy, n_envs=4, eval_freq=10_000, progress_bar=False)
    res = run([str(policy)], out=tmp_path / "bench", quick=True, cma_budget=24)
    for name in ("velocities.csv", "benchmark.json", "benchmark.md", "velocity_vs_k.png", "velocity_vs_load.png",
                 "critical_load_vs_k.png", "heatmap_learned_minus_trapezoid.png", "learned_waveforms.png"):
        assert (tmp_path / "bench" / name).stat().st_size > 0, name
    points = [(k, m) for k in QUICK_KS for m in QUICK_MASSES]
    assert res["points"] == points
    np.testing.assert_allclose(res["trapezoid"], open_loop_velocity(points, trapezoid_action()), rtol=1e-12)
    assert all(c >= t for c, t in zip(res["cma_es"], res["trapezoid"]))  # CMA-ES never reports worse
    assert np.asarray(res["learned_last_two_actions"][str(policy)]).shape == (len(points), 2, 5)
    crit = res["critical_load_kg"]
    assert set(crit) == {"trapezoid", "cma-es", str(policy)}
    assert all(v >= 0.0 for c in crit.values() for v in c.values())


def _script(name: str):
    import importlib.util

    path = Path(__file__).parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_seed_selection_picks_the_policy_with_the_largest_smallest_critical_load_ratio(tmp_path):
    from agents.benchmark import critical_loads_grid

    select = _script("select_seed")
    policies = []
    for seed in (0, 1):
        out = tmp_path / f"ppo_s{seed}"
        train("ppo", steps=64, seed=seed, out=out, n_envs=4, eval_freq=10_000, progress_bar=False)
        policies.append(str(out))
    ks = (0.0, 0.3)
    trap = critical_loads_grid(ks, lambda pts: open_loop_velocity(pts, trapezoid_action()))
    worst = {p: min(select.critical_load_ratios(Policy(p), ks, trap)) for p in policies}
    report = tmp_path / "selection.md"
    assert select.main([*policies, "--ks", *map(str, ks), "--out", str(report)]) == 0
    text = report.read_text()
    assert f"selected: {max(policies, key=worst.get)}" in text and text.count("(selected)") == 1
    assert f"{min(worst.values()):.2f}" in text and "points below trapezoid" in text


def test_cycle_limit_reports_a_critical_load_and_the_sensitivity_of_every_action_component(tmp_path):
    cycle_limit = _script("cycle_limit")
    assert cycle_limit.main(["--ks", "0.3", "--iterations", "1", "--out", str(tmp_path)]) == 0
    (row,) = json.loads((tmp_path / "cycle_limit.json").read_text())
    ratio = row["cycle_critical_kg"] / row["trapezoid_critical_kg"]
    assert np.isclose(ratio, 1.0) or np.isclose(ratio, 1.4)  # one bisection step in [1.0, 1.8]
    assert np.asarray(row["cycle"]).shape == (2, 5) and np.all(np.abs(row["cycle"]) <= 1.0)
    assert len(row["sensitivity_at_1.25_mm_s"]) == 10 and "clamp z_phase" in row["sensitivity_at_1.25_mm_s"]


def _teacher_stub(ks, ratios, velocities) -> dict:
    obs = np.zeros((len(ks), 14), dtype=np.float32)
    obs[:, 10], obs[:, 11] = ks, ratios
    return {"points": np.c_[ks, ratios], "obs": obs, "velocities": np.asarray(velocities, dtype=float)}


def test_teacher_velocity_interpolates_between_the_teachers_points():
    from agents.reward_scale import TeacherVelocity

    # a negative teacher velocity (the drive goes back) counts as 0
    teacher = TeacherVelocity(_teacher_stub([0.0, 0.0, 0.6], [0.0, 0.2, 0.3], [30e-3, 5e-3, -1e-3]), neighbours=2)
    np.testing.assert_allclose(teacher([0.0, 0.0, 0.6], [0.0, 0.2, 0.3]), [30e-3, 5e-3, 0.0], atol=1e-12)
    between = teacher(0.0, 0.1)[0]
    assert 5e-3 < between < 30e-3


def test_teacher_reward_factor_scales_each_episode_by_its_own_factor():
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.reward_scale import REFERENCE_VELOCITY, TeacherRewardFactor
    from agents.vec_env import BatchedVecEnv

    kw = {"k": (0.0, 0.6), "load_ratio": (0.0, 0.5), "max_periods": 3, "reward_floor": -2.0}
    raw = VecMonitor(BatchedVecEnv(4, seed=3, **kw))
    # the teacher is fast at low loads and stalls at high ones, so the factor depends on the episode
    factor_of = TeacherRewardFactor(_teacher_stub([0.0, 0.6, 0.0, 0.6], [0.0, 0.0, 0.5, 0.5],
                                                  [30e-3, 30e-3, 0.0, 0.0]), floor=1e-3)
    scaled = VecMonitor(BatchedVecEnv(4, seed=3, episode_reward_factor=factor_of, **kw))
    raw.reset()
    factors = [factor_of(scaled.reset())]
    assert np.all((factors[0] >= REFERENCE_VELOCITY / 30e-3) & (factors[0] <= REFERENCE_VELOCITY / 1e-3))
    action = np.tile(trapezoid_action(), (4, 1)).astype(np.float32)
    for t in range(5):  # across the auto-reset after period 3
        r_raw = raw.step(action)[1]
        obs, r, dones, _ = scaled.step(action)
        np.testing.assert_allclose(r, np.maximum(r_raw * factors[-1], -2.0), rtol=1e-6)
        if dones.any():
            assert t == 2
            factors.append(factor_of(obs))
    assert not np.allclose(factors[0], factors[1])  # the new episodes drew new loads


def test_neighbour_exchange_gives_a_point_its_neighbours_better_drive_and_never_a_worse_one():
    from agents.teacher import exchange_with_neighbours, record_rollouts

    points = np.array([[0.2, 0.0], [0.21, 0.0], [0.22, 0.0], [0.6, 0.002]])
    poor = -np.ones(5)  # the shortest x stroke: barely moves
    single = np.array([trapezoid_action(), trapezoid_action(), poor, poor])
    actions = np.repeat(single[:, None], 2, axis=1)
    velocities = open_loop_velocity([tuple(p) for p in points], actions)
    data = record_rollouts({"points": points, "actions": actions, "velocities": velocities}, periods=4)
    new, summary = exchange_with_neighbours(data, neighbours=2)
    assert np.all(new["velocities"] >= velocities)
    assert new["velocities"][2] > velocities[2] and summary["points_improved"] >= 1
    for a in new["actions"]:  # every drive is one the teacher already had
        assert any(np.array_equal(a, b) for b in actions)
    np.testing.assert_allclose(new["velocities"], open_loop_velocity([tuple(p) for p in points], new["actions"]))
    assert new["obs"].shape == data["obs"].shape and np.array_equal(new["points"], points)
    np.testing.assert_array_equal(new["targets"][4:8], new["actions"][:, 1].astype(np.float32))


def _small_teacher():
    from agents.teacher import PUSH_CLAMP, record_rollouts

    points = np.array([[0.1, 0.0], [0.5, 0.006]])
    actions = np.array([np.tile(trapezoid_action(), (2, 1)), PUSH_CLAMP])
    velocities = np.array([12e-3, 0.1e-3])  # m/s; positive: both drives move their point's load
    return record_rollouts({"points": points, "actions": actions, "velocities": velocities}, periods=6)


def test_the_lookup_leaves_out_loaded_teacher_points_whose_drive_does_not_move_their_load():
    from agents.residual import TeacherLookup, moving_teacher

    data = _small_teacher()
    stalled = {**data, "velocities": np.array([12e-3, -0.2e-3])}
    kept = moving_teacher(stalled)
    assert len(kept["points"]) == 1 and kept["obs"].shape == (6, 14)  # one point, its 6 periods
    np.testing.assert_array_equal(kept["obs"], data["obs"][0::2])
    lookup = TeacherLookup.from_teacher(stalled)
    assert len(lookup.xy) == 1 and np.array_equal(lookup.drives[0], data["actions"][0])
    assert moving_teacher(data) is data  # nothing to leave out


def test_the_residual_gate_scales_the_residual_by_the_played_points_velocity(tmp_path):
    from agents.residual import TeacherLookup, TeacherResidual, residual_data
    from agents.vec_env import BatchedVecEnv

    data = _small_teacher()
    with pytest.raises(ValueError, match="gate_velocity"):
        TeacherLookup.from_teacher(data, gate_velocity=0.0)
    lookup = TeacherLookup.from_teacher(data, gate_velocity=1e-3)
    np.testing.assert_allclose(lookup.weight(data["obs"][:2]), [[1.0], [0.1]])  # 12 and 0.1 mm/s
    lookup.save(tmp_path / "lookup.npz")
    loaded = TeacherLookup.load(tmp_path / "lookup.npz")
    np.testing.assert_array_equal(loaded.weight(data["obs"]), lookup.weight(data["obs"]))
    venv = TeacherResidual(BatchedVecEnv(2, seed=0, k=0.5, load_ratio=0.05, max_periods=3), lookup, scale=0.5)
    obs = venv.reset()
    base, weight = obs[:, 14:], lookup.weight(obs[:, :14])
    played = []
    venv.venv.step_async = played.append  # the action the wrapper sends to the env
    venv.step_async(np.ones((2, 5), np.float32))
    np.testing.assert_allclose(played[0], np.clip(base + 0.5 * weight, -1, 1), atol=1e-6)
    res = residual_data(data, lookup, 0.5)  # the teacher's own drives: no residual needed
    np.testing.assert_allclose(res["targets"], 0.0, atol=1e-6)


def test_teacher_lookup_replays_each_teachers_drive_at_its_own_observations(tmp_path):
    from agents.residual import TeacherLookup

    data = _small_teacher()
    lookup = TeacherLookup.from_teacher(data)
    np.testing.assert_allclose(lookup(data["obs"]), data["targets"], atol=1e-6)  # push, clamp, push, ...
    lookup.save(tmp_path / "lookup.npz")
    np.testing.assert_array_equal(TeacherLookup.load(tmp_path / "lookup.npz")(data["obs"]), lookup(data["obs"]))
    np.savez(tmp_path / "teacher.npz", **data)
    from agents.evaluate import load_policy  # how the benchmark and the seed selection load a teacher

    np.testing.assert_array_equal(load_policy(str(tmp_path / "teacher.npz"))(data["obs"]), lookup(data["obs"]))
    assert _script("teacher_lookup").main([str(tmp_path / "teacher.npz"), "--ks", "0.5", "--profile-ks",
                                           "--out", str(tmp_path)]) == 0
    (row,) = json.loads((tmp_path / "teacher_lookup.json").read_text())
    assert row["ratio"]["0.5"] >= 0.0


def test_a_zero_residual_plays_the_teachers_lookup_and_observes_it():
    from agents.residual import TeacherLookup, TeacherResidual
    from agents.vec_env import BatchedVecEnv

    lookup = TeacherLookup.from_teacher(_small_teacher())
    kw = {"k": (0.0, 0.6), "load_ratio": (0.0, 0.3), "max_periods": 3}
    wrapped = TeacherResidual(BatchedVecEnv(4, seed=3, **kw), lookup, scale=0.5)
    plain = BatchedVecEnv(4, seed=3, **kw)
    obs, raw = wrapped.reset(), plain.reset()
    terminal = 0
    assert wrapped.observation_space.shape == (19,) and wrapped.observation_space.contains(obs[0])
    for _ in range(4):  # past the truncation at 3 periods: terminal observations are augmented too
        np.testing.assert_array_equal(obs[:, :14], raw)
        np.testing.assert_array_equal(obs[:, 14:], lookup(raw))
        wrapped.step_async(np.zeros((4, 5), np.float32))
        plain.step_async(lookup(raw))
        (obs, r1, d1, i1), (raw, r2, d2, i2) = wrapped.step_wait(), plain.step_wait()
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        for a, b in zip(i1, i2):
            if "terminal_observation" in b:
                np.testing.assert_array_equal(a["terminal_observation"][:14], b["terminal_observation"])
                assert a["terminal_observation"].shape == (19,)
                terminal += 1
    assert terminal == 4  # every drive was truncated once


def test_residual_policy_trains_resumes_and_evaluates_on_the_lookup(tmp_path):
    data = _small_teacher()
    np.savez(tmp_path / "teacher.npz", **data)
    config = tmp_path / "ppo_residual.yaml"
    config.write_text((Path(__file__).parents[1] / "agents/configs/ppo.yaml").read_text() + "residual_scale: 0.5\n")
    out = tmp_path / "res"
    record = train("ppo", steps=64, seed=0, out=out, n_envs=4, eval_freq=32, config=config, progress_bar=False,
                   warm_start=f"cma:{tmp_path / 'teacher.npz'}")
    assert record["hyperparameters"]["residual_scale"] == 0.5 and (out / "teacher_lookup.npz").exists()
    assert record["hyperparameters"]["warm_start_mse"] < 1e-3  # the residual starts at zero
    resumed = train(resume=out, steps=64, n_envs=4, eval_freq=10_000, progress_bar=False)
    assert resumed["total_timesteps"] > record["total_timesteps"]  # the step counter continues
    policy = Policy(out)
    obs = data["obs"][:2]
    action = policy(obs)
    assert action.shape == (2, 5) and np.all(np.abs(action) <= 1.0)
    assert np.all(np.abs(action - policy.lookup(obs)) <= 0.5 + 1e-6)  # within the residual's reach


def test_refinement_adds_a_teacher_point_where_the_lookup_is_slower_than_the_trapezoid():
    from agents.lookup_refine import failures, refine
    from agents.residual import TeacherLookup
    from agents.teacher import record_rollouts

    poor = np.tile(-np.ones(5), (2, 1))  # the shortest x stroke: slower than the trapezoid everywhere
    points = np.array([[0.3, 0.0], [0.3, 0.01]])
    data = record_rollouts({"points": points, "actions": np.array([poor, poor]),
                            "velocities": np.array([1e-4, 1e-4])}, periods=4)
    probes = [(0.1, 0.0), (0.2, 0.05)]
    bad, v_lookup, v_trap = failures(TeacherLookup.from_teacher(data), probes, [0.0, 0.3])
    assert bad.all() and np.all(v_lookup < v_trap)
    new, summary = refine(data, probe_points=4, rounds=1, max_new=2, workers=1, budget=24, cycle_budget=32,
                          sweeps=1)
    (row,) = summary
    assert row["searched"] >= 2 and row["added"] >= 1 and len(new["points"]) == 2 + row["added"]
    assert new["obs"].shape == (4 * len(new["points"]), 14)  # rollouts recorded again, same layout
    added = slice(2, None)
    np.testing.assert_allclose(new["velocities"][added],
                               open_loop_velocity([tuple(p) for p in new["points"][added]], new["actions"][added]))
    assert np.all(np.abs(new["actions"]) <= 1.0)


def test_sweep_k_sampling_covers_the_range_and_the_chebyshev_draws_crowd_its_ends():
    from agents.lookup_refine import K_RANGE, sweep_ks

    uniform = sweep_ks(np.random.default_rng(3), 4000)
    np.testing.assert_array_equal(uniform, np.random.default_rng(3).uniform(*K_RANGE, 4000))  # earlier teachers
    cheb = sweep_ks(np.random.default_rng(3), 4000, "chebyshev")
    assert np.all((cheb >= K_RANGE[0]) & (cheb <= K_RANGE[1]))
    near_ends = lambda k: np.mean((k < 0.012) | (k > 0.588))  # noqa: E731  within 2 % of the range of an end
    assert near_ends(cheb) > 3 * near_ends(uniform)
    with pytest.raises(ValueError, match="sampling"):
        sweep_ks(np.random.default_rng(0), 3, "sobol")
