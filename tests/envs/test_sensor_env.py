"""MDRDriveSensor-v0 and observation="sensor": the encoder's view, hidden parameters, load steps."""

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mdr_drive_env  # noqa: F401


def test_gymnasium_and_sb3_checkers_pass():
    check_env(gym.make("MDRDriveSensor-v0").unwrapped, skip_render_check=True)
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env as sb3_check

    sb3_check(gym.make("MDRDriveSensor-v0", load_step_period=(3, 6)), warn=True)


def test_the_sensor_observation_holds_what_an_encoder_measures_and_nothing_hidden():
    env = gym.make("MDRDriveSensor-v0", history=3)
    obs, info = env.reset(seed=2)
    s = env.unwrapped.observation_structure
    assert obs.shape == (8 * 3 + 1,) and env.observation_space.contains(obs)
    assert not np.any(obs[s["measured"]]) and not np.any(obs[s["actions"]])  # nothing measured yet
    actions = [np.array([0.5, 0.2, 1.0, -0.3, 0.1], dtype=np.float32), env.unwrapped.trapezoid_action()]
    infos = []
    for a in actions:
        obs, _, _, _, info = env.step(a)
        infos.append(info)
    measured = obs[s["measured"]].reshape(3, 3)  # newest first: displacement, mean velocity, end velocity
    scale = env.unwrapped.reward_scale
    for lag, i in enumerate(reversed(infos)):
        assert measured[lag, 0] == np.float32(i["displacement"] / scale)
        assert measured[lag, 1] == np.float32(i["mean_velocity"] / (scale / 2e-3))
    assert not np.any(measured[2])
    np.testing.assert_array_equal(obs[s["actions"]].reshape(3, 5)[:2], np.array(actions[::-1]))
    assert obs[s["episode_fraction"]][0] == np.float32(2 / 50)
    # the hidden values are in info, never in the observation: two episodes that differ only in
    # them look the same until a period has been measured
    a, _ = gym.make("MDRDriveSensor-v0").reset(seed=5)
    b, info_b = gym.make("MDRDriveSensor-v0").reset(seed=6)
    np.testing.assert_array_equal(a, b)
    assert {"k", "cargo_mass", "friction_coefficient", "base_friction_coefficient"} <= set(info_b)


def test_hidden_parameters_are_drawn_in_their_ranges_and_fixed_values_draw_nothing():
    env = gym.make("MDRDriveSensor-v0")
    seen = [env.reset(seed=s)[1] for s in range(40)]
    for key, (lo, hi) in (("k", (0.0, 0.6)), ("friction_coefficient", (0.2, 0.4)),
                          ("base_friction_coefficient", (0.07, 0.13))):
        values = [i[key] for i in seen]
        assert lo <= min(values) and max(values) <= hi and np.std(values) > 0.1 * (hi - lo) / 4
    # a fixed friction consumes no draw: the full env's seeded episodes are what they were
    plain = gym.make("MDRDrive-v0", k=(0.0, 0.5), cargo_mass=(0.0, 0.3))
    fixed = gym.make("MDRDrive-v0", k=(0.0, 0.5), cargo_mass=(0.0, 0.3), friction_coefficient=0.3)
    assert plain.reset(seed=9)[1]["cargo_mass"] == fixed.reset(seed=9)[1]["cargo_mass"]


def test_the_load_steps_once_at_its_period():
    env = gym.make("MDRDriveSensor-v0", k=0.1, load_ratio=(0.0, 0.3), load_step_period=(4, 8))
    _, info = env.reset(seed=3)
    step_at, before = info["load_step_period"], info["cargo_mass"]
    assert 4 <= step_at <= 8
    masses = []
    for _ in range(12):
        *_, info = env.step(env.unwrapped.trapezoid_action())
        masses.append(info["cargo_mass"])
    assert masses[:step_at] == [before] * step_at  # periods 1 .. step_at ran with the first load
    assert len(set(masses[step_at:])) == 1 and masses[step_at] != before
    assert env.unwrapped.sim.params.drive.cargo_mass == masses[-1]  # the simulator has the new load


def test_seeded_pickled_and_vectorised_like_the_full_env():
    kw = dict(load_step_period=(2, 4), max_periods=6)
    env = gym.make("MDRDriveSensor-v0", **kw)
    env.reset(seed=11)
    rng = np.random.default_rng(0)
    for _ in range(2):
        env.step(rng.uniform(-1, 1, 5))
    clone = pickle.loads(pickle.dumps(env))
    for a in rng.uniform(-1, 1, (3, 5)):
        np.testing.assert_array_equal(env.step(a)[0], clone.step(a)[0])
    again = gym.make("MDRDriveSensor-v0", **kw)
    first = gym.make("MDRDriveSensor-v0", **kw)
    np.testing.assert_array_equal(again.reset(seed=4)[0], first.reset(seed=4)[0])
    vec = gym.make_vec("MDRDriveSensor-v0", num_envs=2, vectorization_mode="sync", **kw)
    obs, _ = vec.reset(seed=[1, 2])
    assert obs.shape == (2, 33)
    with pytest.raises(ValueError, match="vectorization_mode"):
        gym.make_vec("MDRDriveSensor-v0", num_envs=2, vectorization_mode="vector_entry_point")


@pytest.mark.parametrize("kwargs,name", [({"observation": "camera"}, "observation"), ({"history": 0}, "history"),
                                         ({"friction_coefficient": (0.4, 0.2)}, "friction_coefficient"),
                                         ({"load_step_period": (0, 10)}, "load_step_period"),
                                         ({"load_step_period": 50}, "load_step_period")])
def test_bad_sensor_arguments_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("MDRDriveSensor-v0", **kwargs)


def test_sensor_forces_add_two_entries_a_period():
    env = gym.make("MDRDriveSensor-v0", sensor_forces=True, history=2)
    env.reset(seed=0)
    obs, *_, info = env.step(env.unwrapped.trapezoid_action())
    measured = obs[env.unwrapped.observation_structure["measured"]].reshape(2, 5)
    assert obs.shape == (2 * 5 + 2 * 5 + 1,)
    assert measured[0, 3] == np.float32(info["peak_tangential_force"] / 10.0)
    assert measured[0, 4] == np.float32(info["peak_normal_force"] / 100.0)


def test_a_cargo_mass_given_to_the_sensor_id_replaces_its_load_range():
    env = gym.make("MDRDriveSensor-v0", k=0.2, cargo_mass=0.1)
    for seed in range(3):
        assert env.reset(seed=seed)[1]["cargo_mass"] == 0.1  # not drawn from the default load_ratio range
    drawn = {gym.make("MDRDriveSensor-v0").reset(seed=seed)[1]["cargo_mass"] for seed in range(3)}
    assert len(drawn) == 3


def test_the_privileged_observation_is_the_full_observation_with_the_coming_load():
    full = gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.05)
    obs, _ = full.reset(seed=1)
    assert np.array_equal(full.unwrapped.privileged_observation(), obs)
    for _ in range(2):
        obs, *_ = full.step(full.action_space.sample())
        assert np.array_equal(full.unwrapped.privileged_observation(), obs)

    env = gym.make("MDRDriveSensor-v0", max_periods=10)
    _, info = env.reset(seed=3, options={"load_step": (2, 0.2)})
    priv = env.unwrapped.privileged_observation()
    assert priv.shape == (14,) and priv[10] == np.float32(info["k"])
    load_entry = priv[12]  # load / 10 N
    assert load_entry == pytest.approx(info["load_force"] / 10.0, rel=1e-6)
    env.step(env.action_space.sample())
    env.step(env.action_space.sample())  # the next period is the step's: the teacher is told the new load
    assert env.unwrapped.privileged_observation()[12] == pytest.approx(0.2 * 9.81 / 10.0, rel=1e-6)


def _tier_env(tier, **kw):
    return gym.make("MDRDriveSensor-v0", sensor_tier=tier, history=2, k=0.2, cargo_mass=0.05,
                    friction_coefficient=0.3, base_friction_coefficient=0.1, **kw)


@pytest.mark.parametrize("tier, extra", [("encoder", 0), ("trace", 40), ("self-sensing", 42)])
def test_each_sensor_tier_passes_both_checkers_and_adds_its_entries(tier, extra):
    env = _tier_env(tier)
    check_env(env.unwrapped, skip_render_check=True)
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env as sb3_check

    sb3_check(_tier_env(tier), warn=True)
    layout = env.unwrapped.sensor.layout
    assert len(layout.per_period) == 3 + extra and env.observation_space.shape == ((3 + extra + 5) * 2 + 1,)
    assert env.observation_space.dtype == np.float32


def test_the_trace_samples_the_position_through_the_period_and_ends_at_its_displacement():
    env = _tier_env("trace", trace_samples=8, encoder_noise=0.0)
    env.reset(seed=0)
    obs, _, _, _, info = env.step(env.unwrapped.trapezoid_action())
    layout, s = env.unwrapped.sensor.layout, env.unwrapped.observation_structure
    newest = obs[s["measured"]].reshape(2, -1)[0]
    positions = newest[[layout.per_period.index(f"position_{i}/8") for i in range(1, 9)]] * env.unwrapped.reward_scale
    assert positions[-1] == pytest.approx(info["displacement"], rel=1e-6)  # the last sample is the period's end
    # the samples are the simulator's trace at T/8, 2T/8, ...: replayed with a trace
    from mdr_drive_env.core import DriveParams, DriveSimulator
    from mdr_drive_env.gym_envs.sensor import sample_positions

    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.05), "fast", max_depth=6e-6)
    wp = env.unwrapped.action_map.to_params(env.unwrapped.trapezoid_action())
    r = sim.step_params(wp.x_amplitude, wp.x_rise_time, wp.z_amplitude, wp.z_rise_time, wp.z_phase, wp.period, 1)
    np.testing.assert_allclose(positions, sample_positions(r.trace, r.displacement, 2e-3, 8), rtol=1e-6, atol=1e-12)
    t = r.trace[:, 0] - r.trace[0, 0] + (r.trace[1, 0] - r.trace[0, 0])
    at = np.searchsorted(t, 2e-3 / 8 * 4 - 1e-12)
    assert positions[3] == pytest.approx(r.trace[at, 3] - r.trace[-1, 3] + r.displacement, abs=1e-10)


def test_tier_noise_is_seeded_with_the_env_and_leaves_the_episode_draws_alone():
    def run(seed, **kw):
        env = gym.make("MDRDriveSensor-v0", sensor_tier="self-sensing", history=1, **kw)
        obs, info = env.reset(seed=seed)
        for _ in range(3):
            obs, *_, info = env.step(env.unwrapped.trapezoid_action())
        return obs, info

    a, info_a = run(3)
    b, _ = run(3)
    c, _ = run(4)
    np.testing.assert_array_equal(a, b)  # reset(seed=...) reproduces the noise
    assert not np.array_equal(a, c)
    quiet, info_q = run(3, encoder_noise=0.0, force_noise=0.0)
    assert info_q["k"] == info_a["k"] and info_q["cargo_mass"] == info_a["cargo_mass"]  # the same drive drawn
    diff = np.abs(a - quiet)
    assert np.all(diff[:3] == 0)  # the encoder's summaries carry no noise
    assert 0 < np.max(diff[3:5] / quiet[3:5]) < 0.1  # the forces: 2 % of each force
    assert 0 < diff[5:45].max() < 1e-3  # the positions: 2 nm of a 30 um reward scale
    plain, info_p = gym.make("MDRDriveSensor-v0", history=1).reset(seed=3)
    assert info_p["k"] == info_a["k"]  # the encoder tier draws the same episode
    assert pickle.loads(pickle.dumps(_tier_env("trace"))).unwrapped.sensor.tier.name == "trace"


@pytest.mark.parametrize("kwargs, needle", [
    ({"sensor_tier": "camera"}, "sensor_tier='camera' is not one of"),
    ({"sensor_tier": "trace", "trace_samples": 0}, "trace_samples=0 is outside the allowed range [1, 1000]"),
    ({"sensor_tier": "trace", "trace_samples": 401}, "trace_samples=401 is outside the allowed range [1, 400]"),
    ({"sensor_tier": "trace", "encoder_noise": -1e-9}, "encoder_noise=-1e-09 is outside the allowed range"),
    ({"sensor_tier": "self-sensing", "force_noise": 2.0}, "force_noise=2.0 is outside the allowed range"),
])
def test_bad_tier_values_are_one_line_errors(kwargs, needle):
    with pytest.raises(ValueError) as e:
        gym.make("MDRDriveSensor-v0", **kwargs)
    assert needle in str(e.value)
    with pytest.raises(ValueError, match="needs observation='sensor'"):
        gym.make("MDRDrive-v0", sensor_tier="trace")
