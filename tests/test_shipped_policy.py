"""The shipped policy is a plain SB3 model: its model card's loading snippet runs as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest


ROOT = Path(__file__).parents[1]
SHIPPED = ROOT / "agents" / "pretrained" / "ppo_generalist"
SENSOR = ROOT / "agents" / "pretrained" / "ppo_sensor"


@pytest.mark.parametrize("folder", [SHIPPED, SENSOR], ids=["full", "sensor"])
def test_model_card_snippet_loads_with_plain_sb3_and_drives(folder):
    card = (folder / "MODEL_CARD.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", card, flags=re.S)
    assert blocks, "the model card has no python snippet"
    r = subprocess.run([sys.executable, "-c", blocks[0]], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    velocity = float(re.search(r"steady velocity (-?[\d.]+) mm/s", r.stdout).group(1))
    assert velocity > 0.0


@pytest.mark.parametrize("folder", [SHIPPED, SENSOR], ids=["full", "sensor"])
def test_shipped_folder_holds_only_the_plain_model_files(folder):
    from mdr_drive_agents.model_card import policy_files

    files = sorted(p.name for p in folder.iterdir() if p.name != "teacher")
    assert files == sorted(["MODEL_CARD.md", *policy_files(folder)])  # an action table only if run.json names it
    assert {"model.zip", "run.json", "vecnormalize.pkl"} <= set(files)
    if (folder / "teacher").exists():  # a policy's pinned teacher, which its training config reads
        assert sorted(p.name for p in (folder / "teacher").iterdir()) == ["model.zip", "run.json", "vecnormalize.pkl"]


def test_the_sensor_policy_is_rebuilt_from_its_pinned_teacher():
    import yaml

    config = yaml.safe_load((ROOT / "agents" / "configs" / "sensor.yaml").read_text())
    assert (ROOT / config["adapt"]["teacher"]).resolve() == (SENSOR / "teacher").resolve()


def test_the_sensor_policy_sees_only_the_sensor_observation():
    import json
    import pickle

    import gymnasium as gym

    import mdr_drive_env  # noqa: F401

    run = json.loads((SENSOR / "run.json").read_text())
    assert run["env_id"] == "MDRDriveSensor-v0" and "sensor" in SENSOR.name
    env = gym.make("MDRDriveSensor-v0", history=run["env_kwargs"]["history"])
    with open(SENSOR / "vecnormalize.pkl", "rb") as f:
        vn = pickle.load(f)
    assert vn.obs_rms.mean.shape == env.observation_space.shape


def test_vecnormalize_matches_the_envs_observation():
    import pickle

    with open(SHIPPED / "vecnormalize.pkl", "rb") as f:
        vn = pickle.load(f)
    assert vn.obs_rms.mean.shape == (14,)
