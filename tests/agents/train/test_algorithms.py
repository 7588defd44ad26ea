"""TD3 and RecurrentPPO train, resume and load like PPO and SAC: safely (nothing unpickled), and a
recurrent policy's memory starts afresh with every episode."""

import json

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from mdr_drive_agents.policy import ALGORITHMS, load_policy, policy_name, sb3_class  # noqa: E402
from mdr_drive_agents.protocol import policy_velocity  # noqa: E402
from mdr_drive_agents.train.hyperparameters import check_hyperparameters, known_keys  # noqa: E402
from mdr_drive_agents.train.sb3 import train  # noqa: E402

KW = dict(n_envs=4, eval_freq=10_000, checkpoint_freq=10_000, progress_bar=False)


def test_every_algorithm_has_a_class_and_a_policy_and_others_are_refused():
    for algo in ALGORITHMS:
        assert policy_name(algo) in sb3_class(algo).policy_aliases
    with pytest.raises(ValueError, match="algo='a2c' is not one of"):
        sb3_class("a2c")


def test_action_noise_is_an_off_policy_hyperparameter_with_a_range():
    assert "action_noise_std" in known_keys("td3") and "action_noise_std" not in known_keys("ppo")
    with pytest.raises(ValueError, match=r"action_noise_std=3.0 must be a number in the allowed range \[0.0, 2.0\]"):
        check_hyperparameters("td3", {"action_noise_std": 3.0}, "--hyperparams")
    with pytest.raises(ValueError, match="'action_noise_std' is not a PPO hyperparameter"):
        check_hyperparameters("ppo", {"action_noise_std": 0.1}, "--hyperparams")


@pytest.mark.parametrize("algo", ["td3", "recurrent_ppo"])
def test_a_run_trains_resumes_and_loads_without_unpickling(algo, tmp_path, monkeypatch):
    out = tmp_path / algo
    first = train(algo, steps=128, seed=0, out=out, warm_start="none", **KW)
    resumed = train(resume=out, steps=first["total_timesteps"] + 64, **KW)
    assert resumed["total_timesteps"] >= first["total_timesteps"] + 64 and resumed["algo"] == algo
    if algo == "td3":
        assert json.loads((out / "run.json").read_text())["hyperparameters"]["action_noise_std"] == 0.1

    import pickle

    load_policy(out)  # the simulator's compiled kernels load first (numba's cache index is a pickle)

    def refuse(*a, **k):
        raise AssertionError("unpickled")

    with monkeypatch.context() as m:
        m.setattr(pickle, "loads", refuse)
        m.setattr(pickle, "load", refuse)
        policy = load_policy(out)
    points = [(0.2, 0.05), (0.4, 0.0)]
    first_play, again = policy_velocity(policy, points), policy_velocity(policy, points)
    np.testing.assert_array_equal(first_play, again)  # a new episode forgets the last one
    np.testing.assert_array_equal(policy.play(k=0.2, cargo_mass=0.05, periods=4),
                                  policy.play(k=0.2, cargo_mass=0.05, periods=4))


def test_a_recurrent_policy_remembers_within_an_episode_and_forgets_on_reset(tmp_path):
    train("recurrent_ppo", steps=64, seed=0, out=tmp_path / "r", warm_start="none", **KW)
    policy = load_policy(tmp_path / "r")
    obs = np.zeros((1, 14), dtype=np.float32)
    policy.reset()
    a0 = policy.act(obs)
    assert policy._memory is not None
    policy.reset()
    np.testing.assert_array_equal(policy.act(obs), a0)  # the same first step after reset


def test_a_reward_relative_to_the_trapezoid_is_zero_when_the_trapezoid_plays_settled():
    from mdr_drive_agents.vec_env import BatchedVecEnv

    kw = dict(k=(0.0, 0.6), load_ratio=(0.0, 0.3), max_periods=40, friction_coefficient=(0.2, 0.4))
    plain, relative = BatchedVecEnv(6, seed=3, **kw), BatchedVecEnv(6, seed=3, reward_baseline="trapezoid", **kw)
    plain.reset(), relative.reset()
    action = np.repeat(plain.venv.unwrapped.template.trapezoid_action()[None], 6, axis=0)
    settled = []
    for period in range(40):
        plain.step_async(action)
        relative.step_async(action)
        (_, r_plain, done, _), (_, r_rel, _, infos) = plain.step_wait(), relative.step_wait()
        np.testing.assert_allclose(r_plain - r_rel, [i["reward_baseline"] for i in infos], rtol=1e-6, atol=1e-6)
        if 20 <= period < 30:  # settled: the trapezoid earns its own baseline (the mean of periods 21-30)
            settled.append(r_rel)
    np.testing.assert_allclose(np.mean(settled, axis=0), 0.0, atol=1e-6)
    assert done.all() and np.abs(relative.baseline).max() > 0.1  # new episodes, new baselines
    with pytest.raises(ValueError, match="reward_baseline='zero' is not one of"):
        BatchedVecEnv(2, reward_baseline="zero")
    with pytest.raises(ValueError, match="reward_baseline='zero' is not one of"):
        check_hyperparameters("ppo", {"reward_baseline": "zero"}, "--hyperparams")


def test_a_two_period_cycle_action_plays_its_halves_in_turn(tmp_path):
    from mdr_drive_agents.vec_env import BatchedVecEnv, CycleActions

    kw = dict(k=(0.0, 0.6), load_ratio=(0.0, 0.3), max_periods=6)
    plain, cycled = BatchedVecEnv(3, seed=1, **kw), CycleActions(BatchedVecEnv(3, seed=1, **kw))
    assert cycled.action_space.shape == (10,)
    plain.reset(), cycled.reset()
    rng = np.random.default_rng(0)
    for _ in range(3):
        pair = rng.uniform(-1, 1, (3, 10)).astype(np.float32)
        total = 0.0
        for half in (pair[:, :5], pair[:, 5:]):
            plain.step_async(half)
            obs, r, done, _ = plain.step_wait()
            total = total + r
        cycled.step_async(pair)
        obs_c, r_c, done_c, _ = cycled.step_wait()
        np.testing.assert_allclose(r_c, total, rtol=1e-6)
        np.testing.assert_array_equal(obs_c, obs)
    assert done_c.all()
    with pytest.raises(ValueError, match="even number of periods, not max_periods=5"):
        CycleActions(BatchedVecEnv(2, max_periods=5))

    train("ppo", steps=64, seed=0, out=tmp_path / "c", warm_start="trapezoid",
          hyperparams={"action_cycle": 2}, **KW)
    policy = load_policy(tmp_path / "c")
    assert policy.cycle == 2 and policy.model.action_space.shape == (10,)
    obs = np.zeros((2, 14), dtype=np.float32)
    policy.reset()
    first, second, third = policy.act(obs), policy.act(obs), policy.act(obs)
    pair = policy.model.predict(policy.normalized(obs), deterministic=True)[0]
    np.testing.assert_array_equal(first, pair[:, :5])
    np.testing.assert_array_equal(second, pair[:, 5:])
    np.testing.assert_array_equal(third, first)  # a new cycle
    assert np.isfinite(policy.play(k=0.2, cargo_mass=0.05, periods=4)).all()


def test_a_load_curriculum_widens_the_load_range_over_its_fraction_of_the_run(tmp_path, monkeypatch):
    from mdr_drive_agents.train.curriculum import load_range_at
    from mdr_drive_agents.vec_env import BatchedVecEnv

    assert load_range_at(0.0, (0.0, 0.6), 0.5) == (0.0, 0.15)
    assert load_range_at(0.25, (0.0, 0.6), 0.5) == pytest.approx((0.0, 0.375))
    assert load_range_at(0.5, (0.0, 0.6), 0.5) == load_range_at(0.9, (0.0, 0.6), 0.5) == (0.0, 0.6)
    env = BatchedVecEnv(2, k=0.2, load_ratio=(0.0, 0.6))
    env.set_load_ratio_range(0.0, 0.1)
    env.reset()
    assert env.venv.unwrapped.load.max() <= 0.1 * env.venv.unwrapped.friction_ref.max() + 1e-9
    with pytest.raises(ValueError, match="needs a load_ratio range"):
        BatchedVecEnv(2, cargo_mass=(0.0, 0.1)).set_load_ratio_range(0.0, 0.1)

    seen = []
    from mdr_drive_agents.train import curriculum

    callback = curriculum.load_curriculum_callback

    def spy(fraction, total):
        cb = callback(fraction, total)
        original = cb._on_rollout_start

        def record():
            original()
            seen.append(cb.env.load_ratio_range)
        cb._on_rollout_start = record
        return cb

    monkeypatch.setattr(curriculum, "load_curriculum_callback", spy)
    train("ppo", steps=2048, seed=0, out=tmp_path / "cur", warm_start="none",
          hyperparams={"load_curriculum": 0.5, "n_steps": 64, "batch_size": 128}, **KW)
    highs = [high for _, high in seen]
    assert highs[0] == pytest.approx(0.15) and highs[-1] == pytest.approx(0.6) and highs == sorted(highs)
