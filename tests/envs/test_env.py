"""MDRDrive-v0: the Gymnasium contract, seeding, pickling, subprocesses and physics consistency."""

import multiprocessing as mp
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import mdr_drive_env
from mdr_drive_env.core import DriveParams, DriveSimulator, Waveform
from mdr_drive_env.core import kernel as K
from tests import ROOT

ENV_IDS = mdr_drive_env.ENV_IDS


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_env_checker_passes_without_warnings(env_id):
    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(env_id, max_periods=5)
        check_env(env.unwrapped)
        env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_env_checker_passes_without_warnings(env_id):
    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, max_periods=5), warn=True)


def _rollout(env, seed, n=8):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    for _ in range(n):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        out.append(np.append(obs, [r, info["displacement"]]))
    return out


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_seeded_rollouts_are_identical(env_id):
    kw = dict(k=(0.0, 0.5), cargo_mass=(0.0, 0.3))
    a = _rollout(gym.make(env_id, **kw), seed=7)
    b = _rollout(gym.make(env_id, **kw), seed=7)
    c = _rollout(gym.make(env_id, **kw), seed=8)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[1], c[1])  # another seed, another episode (the sensor env starts at zeros)


def test_pickle_round_trip_continues_identically():
    env = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(3):
        env.step(rng.uniform(-1, 1, 5))
    clone = pickle.loads(pickle.dumps(env))
    actions = rng.uniform(-1, 1, (4, 5))
    for a in actions:
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = clone.step(a)
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


def _spawned_rollout(seed):
    import gymnasium as gym  # no import of mdr_drive_env: the id's module prefix does it

    env = gym.make("mdr_drive_env:MDRDrive-v0", max_periods=3)
    obs, _ = env.reset(seed=seed)
    total = 0.0
    for _ in range(3):
        obs, r, term, trunc, _ = env.step(env.unwrapped.trapezoid_action())
        total += r
    return total, bool(trunc)


def test_make_by_module_prefix_in_a_spawned_subprocess():
    ctx = mp.get_context("spawn")
    with ctx.Pool(1) as pool:
        total, truncated = pool.apply(_spawned_rollout, (0,))
    assert truncated and total == pytest.approx(_spawned_rollout(0)[0], rel=0, abs=0)


def test_async_vector_env_and_sb3_subproc_vec_env():
    vec = gym.make_vec("mdr_drive_env:MDRDrive-v0", num_envs=2, vectorization_mode="async",
                       vector_kwargs={"context": "spawn"}, max_periods=4)
    obs, _ = vec.reset(seed=[1, 2])
    assert obs.shape == (2, 14) and obs.dtype == np.float32
    obs, r, term, trunc, _ = vec.step(np.zeros((2, 5), dtype=np.float32))
    assert np.all(np.isfinite(r))
    vec.close()

    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    sb3 = make_vec_env("mdr_drive_env:MDRDrive-v0", n_envs=2, vec_env_cls=SubprocVecEnv,
                       vec_env_kwargs={"start_method": "spawn"}, env_kwargs={"max_periods": 4})
    sb3.reset()
    _, rewards, _, _ = sb3.step(np.zeros((2, 5), dtype=np.float32))
    assert rewards.shape == (2,) and np.all(np.isfinite(rewards))
    sb3.close()


def test_trapezoid_action_reproduces_the_simulator_bit_for_bit():
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1, max_periods=6)
    env.reset(seed=0)
    a = env.unwrapped.trapezoid_action()
    assert env.action_space.contains(a)
    assert env.unwrapped.action_to_waveform(a) == Waveform.paper()
    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.1), "fast")  # the env's default numerics
    for expected in sim.run(Waveform.paper(), 6):
        _, reward, _, _, info = env.step(a)
        assert info["displacement"] == expected.displacement
        assert info["mean_velocity"] == expected.mean_velocity
        assert reward == expected.displacement / 30e-6


@pytest.mark.parametrize("kwargs", [dict(period=1e-3, x_amplitude_max=20e-6, z_amplitude_max=4e-6),
                                    dict(period=5e-3, x_amplitude_max=50e-6), dict(z_amplitude_max=3e-6)])
def test_the_trapezoid_of_another_drive_is_the_papers_shape_at_its_period_and_full_strokes(kwargs):
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.01, **kwargs).unwrapped
    a = env.trapezoid_action()
    period, x_max, z_max = (kwargs.get(key, default) for key, default in
                            (("period", 2e-3), ("x_amplitude_max", 30e-6), ("z_amplitude_max", 6e-6)))
    w, paper = env.action_to_waveform(a), Waveform.paper(period, x_max, z_max)
    assert env.action_space.contains(a) and (w.x.amplitude, w.z.amplitude) == (x_max, z_max)
    np.testing.assert_allclose([w.x.rise_time, w.x.fall_time, w.z.rise_time, w.z.fall_time, w.z_phase],
                               [paper.x.rise_time, paper.x.fall_time, paper.z.rise_time, paper.z.fall_time, 0.0],
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose([w.x.rise_time / period, w.z.rise_time / period], [0.95, 0.85])
    env.reset(seed=0)
    assert env.step(a)[4]["mean_velocity"] > 0.0


@pytest.mark.parametrize("period", [5e-4, 7e-4])
def test_a_period_under_1_ms_shortens_the_fast_solvers_step_so_its_edges_span_ten_steps(period):
    from mdr_drive_env.core import Numerics

    kw = dict(period=period, x_amplitude_max=10e-6, z_amplitude_max=2e-6, slider_mass=0.03, k=0.3, load_ratio=0.1)
    env = gym.make("MDRDrive-v0", time_quantum=5e-6, **kw).unwrapped
    assert env.numerics.time_step == 2.5e-6  # 5 us / 2: the shortest edge, 5 % of the period, spans >= 10 steps
    assert gym.make("MDRDrive-v0", **kw).unwrapped.numerics.time_step == 2.5e-6  # a 10 us quantum keeps it too
    fast = env.numerics
    fine = Numerics(time_step=fast.time_step / 10, method="nodes", nodes=fast.nodes, node_power=fast.node_power,
                    max_x_step=fast.max_x_step / 10, max_z_step=fast.max_z_step / 10)
    actions = np.vstack([env.trapezoid_action()[None], np.random.default_rng(3).uniform(-1, 1, (4, 5))])
    stroke_speed = 10e-6 / period

    def steady_velocities(numerics):
        e = gym.make("MDRDrive-v0", time_quantum=5e-6, numerics=numerics, **kw).unwrapped
        out = []
        for a in actions:
            e.reset(seed=0)
            out.append(np.mean([e.step(a)[4]["mean_velocity"] for _ in range(10)][-4:]))
        return np.array(out)

    coarse = steady_velocities(fast)
    np.testing.assert_allclose(coarse, steady_velocities(fine), atol=0.005 * stroke_speed)  # 0.5 % of the stroke speed
    assert coarse[0] > 0.0


def test_periods_of_1_ms_and_more_keep_every_presets_step():
    for period in (1e-3, 2e-3, 4e-3):
        for name, step in (("fast", 5e-6), ("default", 1e-6), ("paper", 1e-7)):
            env = gym.make("MDRDrive-v0", period=period, numerics=name).unwrapped
            assert env.numerics.time_step == step


def test_the_papers_waveform_at_its_own_period_and_strokes_is_the_paper_exactly():
    assert Waveform.paper(2e-3, 30e-6, 6e-6) == Waveform.paper() == Waveform()


def test_the_z_phase_origin_moves_the_seam_of_the_phase_not_the_waveforms():
    from mdr_drive_env.gym_envs.spaces import ActionMap, shift_phase_origin

    default, moved = ActionMap(), ActionMap(z_phase_origin=0.5)
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (2000, 5))
    actions[:4, 4] = [1.0, -1.0, 0.0, 0.9]
    shifted = shift_phase_origin(actions, 0.0, 0.5)
    assert np.array_equal(shifted[:, :4], actions[:, :4])
    np.testing.assert_allclose(shifted[:4, 4], [0.0, 0.0, -1.0, -0.1], atol=1e-12)
    phase_gap = np.abs(default.to_params_batch(actions) - moved.to_params_batch(shifted))
    assert phase_gap[:, :4].max() == 0.0 and phase_gap[:, 4].max() <= 1 / default.quanta + 1e-12  # at most a rounding tie
    np.testing.assert_allclose(shift_phase_origin(shifted, 0.5, 0.0)[4:, 4], actions[4:, 4], atol=1e-12)
    # the paper's phase 0 is action 0 with the seam moved; the trapezoid is the same waveform
    env = gym.make("MDRDrive-v0", z_phase_origin=0.5).unwrapped
    a = env.trapezoid_action()
    assert a[4] == 0.0 and env.action_to_waveform(a) == Waveform.paper()
    assert moved.to_waveform(a) == default.to_waveform(gym.make("MDRDrive-v0").unwrapped.trapezoid_action())


@pytest.mark.parametrize("origin", [0.0, 0.5])
def test_quantum_centres_select_the_same_waveform_with_half_a_quantum_of_room(origin):
    from mdr_drive_env.gym_envs.spaces import ActionMap

    amap = ActionMap(z_phase_origin=origin)
    actions = np.random.default_rng(5).uniform(-1.05, 1.05, (5000, 5))
    centres = amap.quantum_centre(actions)
    same = amap.to_params_batch(np.clip(actions, -1.0, 1.0))
    assert np.array_equal(amap.to_params_batch(centres), same)  # the same waveforms, bit for bit
    assert np.array_equal(amap.quantum_centre(centres), centres)
    assert np.array_equal(centres[:, [0, 2]], np.clip(actions[:, [0, 2]], -1.0, 1.0))  # amplitudes only clipped
    rise, phase = 1.0 / (amap.quanta * (amap.max_rise_fraction - amap.min_rise_fraction) / 2), 2.0 / amap.quanta
    for sign in (-1.0, 1.0):  # just under half a quantum either way: still the same waveform
        moved = centres + sign * 0.499 * np.array([0.0, rise, 0.0, rise, phase])
        assert np.array_equal(amap.to_params_batch(np.clip(moved, -1.0, 1.0))[:, :4], same[:, :4])
        np.testing.assert_allclose(amap.to_params_batch(np.clip(moved, -1.0, 1.0))[:, 4], same[:, 4], atol=1e-12)
    # a rise in the box's first quantum is the edge itself: past it the action clips to the same quantum
    first = np.array([[0.5, -1.0 + 0.4 * rise, 0.5, 1.0 - 0.4 * rise, -1.0 + 0.4 * phase]])
    assert np.array_equal(amap.quantum_centre(first)[0, 1:], [-1.0, 0.5, 1.0, -1.0])
    assert amap.quantum_centre(np.array([[0.0, 0.0, 0.0, -1.0 + 0.6 * rise, 0.0]]))[0, 3] == pytest.approx(-1.0 + rise)


def test_truncation_at_max_periods_and_never_terminated():
    env = gym.make("MDRDrive-v0", max_periods=3, cargo_mass=0.5, k=0.5)  # dragged back hard
    env.reset(seed=0)
    flags = [env.step(np.zeros(5))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]


def test_ranges_are_sampled_inside_their_bounds():
    env = gym.make("MDRDrive-v0", k=(0.1, 0.4), cargo_mass=(0.02, 0.3))
    ks, ms = [], []
    for seed in range(40):
        _, info = env.reset(seed=seed)
        ks.append(info["k"])
        ms.append(info["cargo_mass"])
    assert 0.1 <= min(ks) and max(ks) <= 0.4 and np.ptp(ks) > 0.15
    assert 0.02 <= min(ms) and max(ms) <= 0.3 and np.ptp(ms) > 0.1
    _, info = env.reset(seed=0, options={"k": 0.6, "cargo_mass": 0.0})
    assert info["k"] == 0.6 and info["cargo_mass"] == 0.0 and info["load_force"] == 0.0


def test_a_finer_time_quantum_keeps_the_coarse_waveforms_and_adds_those_between():
    coarse = gym.make("MDRDrive-v0").unwrapped.action_map
    fine = gym.make("MDRDrive-v0", time_quantum=5e-6).unwrapped.action_map
    assert (coarse.quanta, fine.quanta) == (200, 400)
    centres = coarse.quantum_centre(np.random.default_rng(0).uniform(-1, 1, (50, 5)))
    np.testing.assert_array_equal(fine.to_params_batch(centres), coarse.to_params_batch(centres))
    between = centres.copy()
    between[:, 1] += 0.4 * 2.0 / (200 * 0.9)  # 0.4 of a coarse rise quantum up: 0.8 of a fine one
    inside = (centres[:, 1] > -0.9) & (centres[:, 1] < 0.9)
    rise = coarse.to_params_batch(centres)[inside, 1]
    np.testing.assert_array_equal(coarse.to_params_batch(between)[inside, 1], rise)  # the same coarse quantum
    np.testing.assert_allclose(fine.to_params_batch(between)[inside, 1] - rise, 5e-6, atol=1e-12)  # the next fine one


@pytest.mark.parametrize("kwargs,name", [
    ({"k": 1.0}, "k"), ({"k": (0.5, 0.1)}, "k"), ({"cargo_mass": -0.1}, "cargo_mass"),
    ({"max_periods": 0}, "max_periods"), ({"x_amplitude_max": 0.0}, "x_amplitude_max"),
    ({"reward_scale": -1.0}, "reward_scale"), ({"actuation_penalty": float("nan")}, "actuation_penalty"),
    ({"numerics": "exact"}, "numerics"), ({"min_rise_fraction": 0.6}, "min_rise_fraction"),
    ({"poisson_ratio": 0.7}, "poisson_ratio"), ({"render_mode": "ascii"}, "render_mode"),
    ({"z_phase_origin": 1.0}, "z_phase_origin"), ({"z_phase_origin": -0.1}, "z_phase_origin"),
    ({"time_quantum": 3e-6}, "time_quantum"), ({"time_quantum": 0.0}, "time_quantum"),
])
@pytest.mark.filterwarnings("ignore:.*render_mode='ascii'.*:UserWarning")  # gym.make's own warning
def test_bad_arguments_raise_naming_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("MDRDrive-v0", **kwargs).reset(seed=0)


def test_non_finite_actions_raise_and_leave_the_state_untouched():
    env = gym.make("MDRDrive-v0")
    env.reset(seed=0)
    env.step(np.zeros(5))
    before = env.unwrapped.sim.state.copy()
    for bad in ([np.nan, 0, 0, 0, 0], [0, 0, np.inf, 0, 0]):
        with pytest.raises(ValueError, match="not finite"):
            env.step(np.array(bad, dtype=np.float32))
    np.testing.assert_array_equal(env.unwrapped.sim.state, before)


def test_actuation_penalty_and_info_units():
    env = gym.make("MDRDrive-v0", actuation_penalty=0.5, k=0.0, cargo_mass=0.0)
    env.reset(seed=0)
    _, r, _, _, info = env.step(env.unwrapped.trapezoid_action())
    assert info["effort"] == 1.0  # full x and z stroke
    assert r == pytest.approx(info["displacement"] / 30e-6 - 0.5)
    w = info["waveform"]
    assert (w["x_amplitude"], w["x_rise_time"], w["z_amplitude"], w["z_rise_time"]) == (30e-6, 1.9e-3, 6e-6, 1.7e-3)
    assert info["load_force"] == 0.0 and info["mean_velocity"] == info["displacement"] / 2e-3


def test_rgb_array_render_shows_a_frame():
    env = gym.make("MDRDrive-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(env.unwrapped.trapezoid_action())
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    assert frame.std() > 10  # not a blank image
    env.close()


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.lists(st.floats(-1, 1), min_size=5, max_size=5), min_size=1, max_size=6),
       st.floats(0.0, 0.95), st.floats(0.0, 0.6))
@example([[0.0, 0.0, -0.99999, 0.0, 0.515625], [0.0] * 5], 0.5, 0.0)  # contact forces near 1e-14 N: round-off 1e-12
@example([[0.0] * 5] * 3 + [[0.0, 0.0, 0.0, -0.90625, -0.8203125]], 0.5, 0.0)  # at 6e-29 N: round-off 1e-6 of it
def test_random_action_sequences_stay_finite_and_obey_coulomb(actions, k, m):
    env = gym.make("MDRDrive-v0", k=k, cargo_mass=m, render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    for a in actions:
        obs, r, _, _, info = env.step(np.array(a, dtype=np.float32))
        assert np.all(np.isfinite(obs)) and np.isfinite(r)
        assert env.observation_space.contains(obs)
        tr = env.unwrapped.last_trace
        # |Fx| <= mu Fz up to the round-off of summing the springs: relative 1e-9, plus 1e-12 of the
        # period's largest normal force for contacts that vanish (at Fz = 6e-29 N the ratio was 1 + 1e-6);
        # a violation of the friction law would be of order 1
        fz = tr[:, K.T_FZ]
        assert np.all(np.abs(tr[:, K.T_FX]) <= 0.3 * fz * (1 + 1e-9) + 1e-12 * max(float(fz.max()), 0.0))
        assert info["peak_tangential_force"] <= 0.3 * info["peak_normal_force"] * (1 + 1e-9)


def test_docs_environment_md_is_the_env_docstring():
    import inspect

    from mdr_drive_env.gym_envs import MDRDriveEnv

    import sys

    doc = inspect.cleandoc(MDRDriveEnv.__doc__)
    text = (ROOT / "docs" / "environment.md").read_text()
    assert doc in text, "docs/environment.md is stale: run python scripts/gen_env_doc.py"
    sys.path.insert(0, str(ROOT / "scripts"))
    from gen_env_doc import render

    assert text == render(), "docs/environment.md is stale: run python scripts/gen_env_doc.py"
    for section in ("Description", "Action Space", "Observation Space", "Rewards", "Starting State",
                    "Episode End", "Arguments", "Version History"):
        assert f"## {section}" in doc


def test_spec_says_the_episode_length():
    assert gym.make("MDRDrive-v0").spec.max_episode_steps == 50
    env = gym.make("MDRDrive-v0", max_periods=7)
    assert env.spec.max_episode_steps == 7
    env.reset(seed=0)
    steps = 0
    while True:
        steps += 1
        *_, terminated, truncated, _ = env.step(env.unwrapped.trapezoid_action())
        if terminated or truncated:
            break
    assert steps == 7 and truncated and not terminated


def test_reset_option_load_ratio_is_the_make_argument():
    made = gym.make("MDRDrive-v0", k=0.3, load_ratio=0.15)
    opt = gym.make("MDRDrive-v0", k=0.3)
    _, i_made = made.reset(seed=4)
    _, i_opt = opt.reset(seed=4, options={"load_ratio": 0.15})
    assert i_made["cargo_mass"] == i_opt["cargo_mass"] > 0
    _, ranged = opt.reset(seed=5, options={"load_ratio": (0.0, 0.2)})
    _, ranged_made = gym.make("MDRDrive-v0", k=0.3, load_ratio=(0.0, 0.2)).reset(seed=5)
    assert ranged["cargo_mass"] == ranged_made["cargo_mass"]
    with pytest.raises(ValueError, match="both set the load"):
        opt.reset(options={"load_ratio": 0.1, "cargo_mass": 0.1})
    with pytest.raises(ValueError, match="load_ratio"):
        opt.reset(options={"load_ratio": -0.1})


def test_reset_options_set_one_episodes_friction_as_the_make_arguments_do():
    opt = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05)
    made = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05, friction_coefficient=0.22, base_friction_coefficient=0.08)
    obs_opt, info_opt = opt.reset(seed=1, options={"friction_coefficient": 0.22, "base_friction_coefficient": 0.08})
    obs_made, _ = made.reset(seed=1)
    assert info_opt["friction_coefficient"] == 0.22 and info_opt["base_friction_coefficient"] == 0.08
    assert np.array_equal(obs_opt, obs_made)
    action = opt.unwrapped.trapezoid_action()
    assert np.array_equal(opt.step(action)[0], made.step(action)[0])
    assert opt.reset(seed=1)[1]["friction_coefficient"] == 0.3  # the option holds for one episode
    # per sub-env in the batched vector env, as each single env would run
    venv = gym.make_vec("MDRDrive-v0", num_envs=2, vectorization_mode="vector_entry_point", k=0.3, cargo_mass=0.05)
    venv.reset(seed=1, options={"friction_coefficient": [0.22, 0.3], "base_friction_coefficient": [0.08, 0.1]})
    stepped = venv.step(np.tile(action, (2, 1)))[0]
    single = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05)
    single.reset(seed=2)
    assert np.array_equal(stepped[1], single.step(action)[0])
    made.reset(seed=1)
    assert np.array_equal(stepped[0], made.step(action)[0])
    with pytest.raises(ValueError, match="friction_coefficient"):
        opt.reset(options={"friction_coefficient": -0.1})


def test_defaults_are_the_documented_ones():
    _, info = gym.make("MDRDrive-v0").reset(seed=0)
    assert info["k"] == 0.2 and info["cargo_mass"] == 0.1
    doc = gym.make("MDRDrive-v0").unwrapped.__doc__
    assert "k = 0.2 and a cargo of m = 0.1 kg" in " ".join(doc.split())


def test_the_documented_trapezoid_rewards():
    """environment.md: 0.78 in the first period, 1.01 per period once settled (k = 0, m = 0.1 kg)."""
    env = gym.make("MDRDrive-v0", k=0.0, cargo_mass=0.1, max_periods=30)
    env.reset(seed=0)
    rewards = [env.step(env.unwrapped.trapezoid_action())[1] for _ in range(30)]
    assert round(rewards[0], 2) == 0.78 and round(rewards[-1], 2) == 1.01


def test_render_frames_say_what_happened(monkeypatch):
    from mdr_drive_env.gym_envs import rendering

    env = gym.make("MDRDrive-v0", render_mode="rgb_array", k=0.2, cargo_mass=0.1)
    env.reset(seed=0)
    texts = []
    real_draw = rendering.Renderer.draw

    def draw(self, e):
        frame = real_draw(self, e)
        texts.append(" ".join(t.get_text() for ax in self.fig.axes for t in ax.texts + [ax.title]
                              + [ax.yaxis.label]))
        return frame

    monkeypatch.setattr(rendering.Renderer, "draw", draw)
    first = env.render()
    assert first.ndim == 3 and "no period simulated yet" in texts[-1] and "F_m 0.981 N" in texts[-1]
    _, reward, *_ , info = env.step(env.unwrapped.trapezoid_action())
    env.render()
    assert f"reward {reward:.3f}" in texts[-1] and f"{info['mean_velocity'] * 1e3:.2f} mm/s" in texts[-1]
    assert "µm" in texts[-1] and " um" not in texts[-1]


def test_quickstart_runs_and_its_returns_are_in_the_documented_range():
    """scripts/quickstart_sb3.py, the SB3 quick start of docs/environment.md, for 1,024 steps."""
    pytest.importorskip("stable_baselines3")
    import sys

    sys.path.insert(0, str(ROOT / "scripts"))
    from quickstart_sb3 import quickstart

    returns = quickstart(steps=1024)
    assert returns["trapezoid"] == pytest.approx(39.5, abs=0.05)  # as documented (deterministic)
    assert returns["random"] == pytest.approx(-189.0, abs=0.05)
    # 50 periods can earn at most about 1.2 each; a barely trained policy is far from that
    assert np.isfinite(returns["PPO"]) and -1000.0 < returns["PPO"] < 60.0


def test_observation_structure_names_the_entries():
    env = gym.make("MDRDrive-v0", k=0.35, cargo_mass=0.05)
    obs, info = env.reset(seed=0)
    s = env.unwrapped.observation_structure
    assert obs[s["k"]][0] == np.float32(0.35)
    assert obs[s["load_over_10N"]][0] == np.float32(info["load_force"] / 10.0)
    covered = sorted(i for sl in s.values() for i in range(*sl.indices(obs.size)))
    assert covered == list(range(obs.size))  # every entry named once


def test_a_codebook_action_plays_its_row_and_the_envs_stay_checker_clean(tmp_path):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    table = np.random.default_rng(4).uniform(-1.0, 1.0, (6, 5))
    np.save(tmp_path / "table.npy", table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("MDRDrive-v0", max_periods=5, action_codebook=table).unwrapped)
        sb3_check_env(gym.make("MDRDrive-v0", max_periods=5, action_codebook=table).unwrapped)
    picks = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05, action_codebook=str(tmp_path / "table.npy"))
    boxes = gym.make("MDRDrive-v0", k=0.3, cargo_mass=0.05)
    assert picks.action_space == gym.spaces.Discrete(6)
    a, b = picks.reset(seed=1)[0], boxes.reset(seed=1)[0]
    for i in (2, 5, 5, 0):
        a, ra, *_ = picks.step(np.int64(i))
        b, rb, *_ = boxes.step(table[i].astype(np.float32))
        assert np.array_equal(a, b) and ra == rb  # a row is played as the float32 action it stands for
    vec = gym.make_vec("MDRDrive-v0", num_envs=2, vectorization_mode="vector_entry_point", k=0.3, cargo_mass=0.05,
                       action_codebook=table)
    vec.reset(seed=1)
    obs, rewards, *_ = vec.step(np.array([2, 5]))
    boxes.reset(seed=1)
    assert rewards[0] == boxes.step(table[2].astype(np.float32))[1]
    assert np.array_equal(obs[1, 5:10], table[5].astype(np.float32))
    picks = pickle.loads(pickle.dumps(picks))
    for bad in (6, -1, 1.5):
        with pytest.raises(ValueError, match="codebook action"):
            picks.step(bad)
    with pytest.raises(ValueError, match="codebook action"):
        vec.step(np.array([0, 6]))
    for bad_table, message in ((np.zeros((3, 4)), "shape"), (np.full((3, 5), 1.5), "range"),
                               (str(tmp_path / "missing.npy"), "missing.npy")):
        with pytest.raises(ValueError, match=f"action_codebook.*{message}"):
            gym.make("MDRDrive-v0", action_codebook=bad_table)


@pytest.mark.parametrize("options, needle", [
    ({"load_step": 5}, "load_step=5 must be (period, cargo mass in kg)"),
    ({"load_step": (2.5, 0.1)}, "load_step period=2.5"),
    ({"k": [0.1, 0.2]}, "reset option k=[0.1, 0.2] must be a number"),
    ({"k": "0.2"}, "reset option k='0.2' must be a number"),
    ({"cargo_mass": 1e308}, "Drive.cargo_mass=1e+308 is outside the allowed range [0, 10000]"),
])
def test_bad_reset_options_are_value_errors_naming_them(options, needle):
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1)
    with pytest.raises(ValueError) as e:
        env.reset(seed=0, options=options)
    assert needle in str(e.value)


@pytest.mark.parametrize("action, needle", [({"x": 1}, "is not an array of real numbers"),
                                            (np.full(5, 0.3 + 0.1j), "is not an array of real numbers"),
                                            ("trapezoid", "is not an array"), (np.zeros(4), "shape (4,)")])
def test_bad_actions_are_value_errors_not_truncated_or_cast(action, needle):
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1)
    env.reset(seed=0)
    with pytest.raises(ValueError) as e:
        env.step(action)
    assert needle in str(e.value)


@pytest.mark.parametrize("kwargs, needle", [
    ({"indenter_radius": 1e-300}, "Contact.indenter_radius=1e-300 is outside the allowed range [1e-07, 10]"),
    ({"indenter_radius": 1e300}, "Contact.indenter_radius=1e+300"),
    ({"cargo_mass": 1e308}, "Drive.cargo_mass=1e+308 is outside the allowed range [0, 10000]"),
    ({"cargo_mass": float("inf")}, "cargo_mass=inf is outside the allowed range"),
    ({"gravity": 1e308}, "Drive.gravity=1e+308"), ({"youngs_modulus": 1e300}, "Material.youngs_modulus=1e+300"),
])
def test_physically_meaningless_values_are_refused_with_their_range_when_the_env_is_made(kwargs, needle):
    with pytest.raises(ValueError) as e:
        gym.make("MDRDrive-v0", **{"k": 0.2, "cargo_mass": 0.1, **kwargs})
    assert needle in str(e.value)


def test_a_finished_episode_is_not_stepped_until_reset():
    env = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1, max_periods=2)
    env.reset(seed=0)
    a = env.unwrapped.trapezoid_action()
    env.step(a)
    assert env.step(a)[3]  # truncated
    with pytest.raises(RuntimeError, match="the episode ended"):
        env.unwrapped.step(a)
    env.reset(seed=0)
    env.step(a)


def test_the_environment_docs_vector_env_lines_run():
    import re

    text = (ROOT / "docs" / "environment.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "BatchedVecEnv" in b)
    scope = {}
    exec(block, scope)
    assert scope["obs"].shape == (64, 14)
