"""The shipped policies: plain SB3 models that load from any folder, whose model-card snippets run as
written, and whose one-call loading (``load_policy``) plays exactly what ``mdr-drive evaluate`` reports."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from mdr_drive_agents.policy import PRETRAINED, SENSOR_PRETRAINED, load_policy, policy_files
from tests import ROOT

pytest.importorskip("stable_baselines3")

#: The shipped policies: the generalist, the sensor policy and the best plain-RL run (make rl-baselines).
PLAIN = sorted(PRETRAINED.parent.glob("*_plain"))
SELF_SENSING = SENSOR_PRETRAINED.parent / "ppo_sensor_self_sensing"
ENCODER = SENSOR_PRETRAINED.parent / "ppo_sensor_encoder"
#: The sensor policies by the tier each was built in from agents/configs/sensor.yaml (make train-sensor).
SENSOR_TIERS = {SENSOR_PRETRAINED: "trace", ENCODER: "encoder", SELF_SENSING: "self-sensing"}
SHIPPED = [PRETRAINED, SENSOR_PRETRAINED, ENCODER, SELF_SENSING, *PLAIN]
IDS = ["full", "sensor", "encoder", "self-sensing", *[p.name for p in PLAIN]]


def snippets(folder) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (folder / "MODEL_CARD.md").read_text(), flags=re.S)


@pytest.mark.parametrize("folder", SHIPPED, ids=IDS)
def test_both_model_card_snippets_load_and_drive_the_same(folder, tmp_path):
    """Both snippets, each from an unrelated folder and from the checkout's root: the same steady
    velocity (forward, but for the plain-RL policy, which may not move there)."""
    found = []
    for code, cwd in [(code, cwd) for code in snippets(folder) for cwd in (tmp_path, ROOT)]:
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=cwd)
        assert r.returncode == 0, r.stderr
        found.append(float(re.search(r"steady velocity (-?[\d.]+) mm/s", r.stdout).group(1)))
    assert len(found) == 4 and len(set(found)) == 1 and (found[0] > 0.0 or folder in PLAIN)


@pytest.mark.parametrize("folder", SHIPPED, ids=IDS)
def test_shipped_folder_holds_only_the_policy_its_card_and_its_teacher(folder):
    files = sorted(p.name for p in folder.iterdir() if p.name != "teacher")
    extra = ["recipe.json", "teacher_field.npz"] if folder == PRETRAINED else []
    assert files == sorted(["MODEL_CARD.md", *policy_files(folder), *extra])
    assert {"model.zip", "run.json", "vecnormalize.pkl"} <= set(files)
    if (folder / "teacher").exists():  # a policy's pinned teacher, which its training config reads
        assert sorted(p.name for p in (folder / "teacher").iterdir()) == ["model.zip", "run.json", "vecnormalize.npz",
                                                                          "vecnormalize.pkl"]


def test_load_policy_plays_exactly_what_evaluate_reports(capsys):
    from mdr_drive_env.cli import main

    points = [(0.2, 0.1), (0.05, 0.25), (0.45, 0.01)]
    assert main(["evaluate", "--policy", str(PRETRAINED), "--k", *[str(k) for k, _ in points], "--cargo-mass",
                 *[str(m) for _, m in points], "--json"]) == 0
    reported = json.loads(capsys.readouterr().out)
    policy = load_policy(PRETRAINED)
    for (k, m), record in zip(points, reported):
        played = policy.play(k=k, cargo_mass=m, periods=30)
        assert played.tolist() == record["learned_period_velocity"]


def test_a_policy_loads_from_any_working_directory_by_its_package_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    policy = load_policy("agents/pretrained/ppo_generalist")
    env = policy.make_env(k=0.2, cargo_mass=0.1)
    assert env.action_space == policy.model.action_space and env.unwrapped.action_map.time_quantum == 5e-6
    obs, _ = env.reset(seed=0)
    assert policy.model.action_space.contains(policy.predict(obs))


def test_an_env_without_the_policys_action_table_is_refused_naming_the_fix():
    import gymnasium as gym

    policy = load_policy(PRETRAINED)
    with pytest.raises(ValueError, match="action_codebook="):
        policy.play(gym.make("MDRDrive-v0", k=0.2, cargo_mass=0.1))


def test_the_sensor_policies_pick_from_one_table_built_as_the_config_says():
    """Each tier: the config's settings in its own tier (--sensor-tier), rows from the same table, which
    polished the shipped full-observation teacher's drives (``polish_from``)."""
    import numpy as np
    import yaml

    from mdr_drive_agents.student.estimator import teacher_layout
    from mdr_drive_env.gym_envs.spaces import PrivilegedLayout

    config = yaml.safe_load((ROOT / "agents" / "configs" / "sensor.yaml").read_text())
    assert (ROOT / config["table"]["polish_from"]).resolve() == (SENSOR_PRETRAINED / "teacher").resolve()
    assert teacher_layout(load_policy(SENSOR_PRETRAINED / "teacher")) is PrivilegedLayout
    rows = np.load(SENSOR_PRETRAINED / "action_codebook.npy")
    for folder, tier in SENSOR_TIERS.items():
        run = json.loads((folder / "run.json").read_text())
        picks = run["picks_from"]
        assert {**picks["sensor"], **config["sensor"], "sensor_tier": tier} == picks["sensor"]
        assert {**picks["drive_table"]["config"], **config["table"]} == picks["drive_table"]["config"]
        assert run["env_kwargs"].get("sensor_tier", "encoder") == tier
        assert np.array_equal(np.load(folder / "action_codebook.npy"), rows)
        assert picks["rows"] == len(rows) == 2 * picks["drives"] and picks["merged"]["merge_rows_differ"] == 0


def test_each_policy_sees_the_observation_it_was_trained_on():
    for folder in SHIPPED:
        policy = load_policy(folder)
        env = policy.make_env()
        assert policy.normalize.mean.shape == env.observation_space.shape == policy.model.observation_space.shape
    assert load_policy(SENSOR_PRETRAINED).env_id == "MDRDriveSensor-v0"
