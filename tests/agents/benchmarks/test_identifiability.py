"""What a drive's sensors can tell (mdr_drive_agents.benchmarks.identifiability, mdr-drive identifiability), CI-sized."""

import json

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.benchmarks import identifiability as ident  # noqa: E402
from mdr_drive_agents.policy import load_policy  # noqa: E402
from mdr_drive_env import SENSOR_DEFAULTS  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402
from mdr_drive_env.gym_envs.spaces import SensorLayout  # noqa: E402

TINY = dict(seed=3, episodes=12, test_episodes=6, periods=(2,), steady_end=3, steps=20, estimator_arch=(8,))


def _tier_env(tier: str, history: int):
    kwargs = {} if tier == "encoder" else {"sensor_tier": tier, "trace_samples": 5, "encoder_noise": 0.0,
                                            "force_noise": 0.0}
    return gym.make("MDRDriveSensor-v0", **SENSOR_DEFAULTS, history=history, max_periods=10, **kwargs)


@pytest.mark.parametrize("tier", ["encoder", "trace", "self-sensing"])
@pytest.mark.parametrize("periods", [1, 2])
def test_a_tiers_columns_of_the_self_sensing_observation_are_that_tiers_own_observation(tier, periods):
    """Noise-free, the columns ``tier_columns`` keeps of a deeper self-sensing observation are, value for
    value, the observation an env of that tier and ``history = periods`` gives after the same actions."""
    deep, own = _tier_env("self-sensing", 3), _tier_env(tier, periods)
    cols = ident.tier_columns(deep.unwrapped.sensor.layout, tier, periods)
    measured = ident.tier_columns(deep.unwrapped.sensor.layout, tier, periods, actions=False)
    own_measured = own.unwrapped.sensor.layout.structure["measured"]
    obs_deep, obs_own = deep.reset(seed=11)[0], own.reset(seed=11)[0]
    rng = np.random.default_rng(0)
    for _ in range(4):
        np.testing.assert_array_equal(obs_deep[cols], obs_own)
        np.testing.assert_array_equal(obs_deep[measured], obs_own[own_measured])  # the estimator's: no actions
        action = rng.uniform(-1, 1, 5).astype(np.float32)
        obs_deep, obs_own = deep.step(action)[0], own.step(action)[0]
    np.testing.assert_array_equal(obs_deep[cols], obs_own)
    with pytest.raises(ValueError, match="deeper"):
        ident.tier_columns(SensorLayout(2, forces=True, trace_samples=5), tier, 3)


@pytest.mark.parametrize("field, value, needle", [
    ("drives", ("wander",), "drives="), ("tiers", ("encoder", "encoder"), "tiers="), ("periods", (0,), "periods="),
    ("steady_end", 2, "steady_end="), ("episodes", 1, "episodes="), ("encoder_noise", -1.0, "encoder_noise="),
    ("learning_rate", 0.0, "learning_rate=")])
def test_bad_settings_raise_a_value_error_naming_the_option(field, value, needle):
    with pytest.raises(ValueError, match=needle):
        ident.IdentifiabilityConfig(**{**TINY, field: value})


def test_the_teacher_drives_need_a_full_observation_policy_and_play_the_generalist_too(tmp_path, capsys):
    ident.full_observation_teacher("agents/pretrained/ppo_generalist")  # told k and the load, not friction
    with pytest.raises(ValueError, match="not a full-observation policy"):
        ident.full_observation_teacher("agents/pretrained/ppo_sensor")
    with pytest.raises(ValueError, match="not a sensor policy"):
        ident.sensor_policy_player("agents/pretrained/ppo_generalist", ident.IdentifiabilityConfig(**TINY))
    with pytest.raises(ValueError, match="senses 40 positions"):
        ident.sensor_policy_player("agents/pretrained/ppo_sensor", ident.IdentifiabilityConfig(**{**TINY, "trace_samples": 8}))
    encoder = load_policy("agents/pretrained/ppo_sensor_encoder")  # any trace length: it senses no positions
    assert ident.sensor_policy_player("agents/pretrained/ppo_sensor_encoder", ident.IdentifiabilityConfig(
        **{**TINY, "trace_samples": 8}))[0] == encoder.play_kwargs["history"]
    argv = ["identifiability", "--seed", "3", "--out", str(tmp_path), "--drives", "teacher",
            "--teacher", "agents/pretrained/ppo_sensor"]
    assert main(argv) == 2 and len(capsys.readouterr().err.strip().splitlines()) == 1
    x, y, _ = ident.episodes_of(ident.IdentifiabilityConfig(**{**TINY, "teacher": "agents/pretrained/ppo_generalist"}),
                                "teacher")
    assert np.all(np.isfinite(x)) and len(x) == len(y) == 18


def test_every_drive_plays_the_same_draws_and_the_truth_is_what_the_env_hides():
    config = ident.IdentifiabilityConfig(**TINY)
    x_trap, y_trap, _ = ident.episodes_of(config, "trapezoid")
    x_steady, y_steady, _ = ident.episodes_of(config, "teacher-steady")
    x_sensor, y_sensor, layout = ident.episodes_of(config, "sensor-steady")
    n = config.episodes + config.test_episodes
    assert x_trap.shape == x_steady.shape == (n, SensorLayout(2, forces=True, trace_samples=40).low.size)
    assert layout.history == load_policy(config.sensor_policy).play_kwargs["history"]  # as deep as the policy sees
    assert x_sensor.shape == (n, layout.low.size)
    np.testing.assert_array_equal(y_trap, y_steady)  # paired: the drives differ, the draws do not
    np.testing.assert_array_equal(y_trap, y_sensor)
    k, ratio, mu, mu1 = y_trap[:, 0], y_trap[:, 3], y_trap[:, 4], y_trap[:, 5]
    assert np.all((0 <= k) & (k <= 0.6)) and np.all((0.2 <= mu) & (mu <= 0.4)) and np.all((0.07 <= mu1) & (mu1 <= 0.13))
    np.testing.assert_allclose(ratio, mu1 / mu, rtol=1e-6)
    assert np.all(x_steady[:, -1] == pytest.approx(3 / 4))  # observed after steady_end = 3 of 4 periods
    assert not np.allclose(x_trap[:, :3], x_steady[:, :3])  # the teacher plays another drive


def test_the_cli_writes_the_table_refuses_to_overwrite_and_is_seeded(tmp_path, capsys):
    out = tmp_path / "study"
    argv = ["identifiability", "--seed", "3", "--out", str(out), "--episodes", "12", "--test-episodes", "6",
            "--periods", "1", "2", "--drives", "probe", "teacher", "--steady-end", "3", "--steps", "20",
            "--workers", "1"]
    assert main(argv) == 0
    res = json.loads((out / "identifiability.json").read_text())
    assert list(res["drives"]) == ["probe", "teacher"] and res["targets"] == list(ident.TARGETS)
    for drive in res["drives"].values():
        assert set(drive["errors"]) == {"encoder", "trace", "self-sensing"}
        assert all(len(e) == 6 and np.all(np.isfinite(e)) for by_p in drive["errors"].values() for e in by_p.values())
    table = (out / "identifiability.md").read_text()
    assert table.count("\n| probe |") == 6 and "| mu1 / mu |" in table
    assert (out / "identifiability.png").stat().st_size > 10_000
    assert not (out / ".tasks").exists()
    capsys.readouterr()
    assert main(argv) == 2 and "pass --force" in capsys.readouterr().err
    (out / "identifiability.png").unlink()
    assert main([*argv, "--replot"]) == 0 and (out / "identifiability.png").is_file()  # drawn from the JSON alone
    assert main([*argv[:4], str(tmp_path / "none"), "--replot"]) == 2 and "--replot needs" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0
    again = json.loads((out / "identifiability.json").read_text())["drives"]
    assert {d: r["errors"] for d, r in again.items()} == {d: r["errors"] for d, r in res["drives"].items()}  # seeded
