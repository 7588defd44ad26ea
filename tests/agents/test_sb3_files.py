"""Loading a file runs no code: a policy folder's SB3 zip and normalisation, a sweep's task store and
the student's checkpoint are read as data. Each case plants a harmless payload that would write a
marker file if it ran."""

from __future__ import annotations

import base64
import json
import os
import pickle
import shutil
import zipfile

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from mdr_drive_agents.policy import PRETRAINED, load_policy  # noqa: E402
from mdr_drive_env.cli import main  # noqa: E402


class Payload:
    """Unpickling this runs ``open(marker, "w")``: the marker's existence says the file's code ran."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def planted_policy(tmp_path):
    """A copy of the shipped policy whose vecnormalize.pkl and model.zip's lr_schedule and clip_range
    are payloads; returns (folder, marker)."""
    folder, marker = tmp_path / "planted", tmp_path / "ran"
    shutil.copytree(PRETRAINED, folder)
    (folder / "vecnormalize.pkl").write_bytes(pickle.dumps(Payload(marker)))
    with zipfile.ZipFile(PRETRAINED / "model.zip") as src, zipfile.ZipFile(folder / "model.zip", "w") as dst:
        for item in src.infolist():
            content = src.read(item.filename)
            if item.filename == "data":
                data = json.loads(content)
                for key in ("lr_schedule", "clip_range", "observation_space"):
                    data[key][":serialized:"] = base64.b64encode(pickle.dumps(Payload(marker))).decode()
                content = json.dumps(data).encode()
            dst.writestr(item, content)
    return folder, marker


def test_a_planted_policy_folder_loads_and_evaluates_without_running_its_payloads(tmp_path, capsys):
    folder, marker = planted_policy(tmp_path)
    policy = load_policy(folder)
    assert policy.play(k=0.2, cargo_mass=0.1, periods=3).shape == (3,)
    assert main(["evaluate", "--policy", str(folder), "--k", "0.2", "--cargo-mass", "0.1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["learned_mean_velocity"] > 0
    assert not marker.exists()
    # fine-tuning a planted copy reads the same files as data: one PPO rollout, and no payload ran
    (tmp_path / "tune").mkdir()
    tune, tune_marker = planted_policy(tmp_path / "tune")
    assert main(["train", "--resume", str(tune), "--steps", "64", "--eval-freq", "100000", "--no-progress"]) == 0
    assert not tune_marker.exists() and json.loads((tune / "run.json").read_text())["total_timesteps"] >= 64
    # SB3's own loader would have run them: the payloads are real
    from stable_baselines3 import PPO

    with pytest.raises(ValueError):  # it unpickles the observation space, runs the payload, then fails
        PPO.load(folder / "model.zip", device="cpu")
    assert marker.exists()


def test_a_folder_with_only_the_pickled_statistics_is_refused_naming_why_unless_trusted(tmp_path):
    folder = tmp_path / "old"
    shutil.copytree(PRETRAINED, folder)
    (folder / "vecnormalize.npz").unlink()
    with pytest.raises(ValueError, match="a pickle runs code"):
        load_policy(folder)
    assert load_policy(folder, trust_pickle=True).normalize.mean.shape == (14,)


def test_a_planted_model_refuses_an_entry_it_cannot_rebuild(tmp_path):
    folder, marker = tmp_path / "odd", tmp_path / "ran"
    shutil.copytree(PRETRAINED, folder)
    with zipfile.ZipFile(PRETRAINED / "model.zip") as src, zipfile.ZipFile(folder / "model.zip", "w") as dst:
        for item in src.infolist():
            content = src.read(item.filename)
            if item.filename == "data":
                data = json.loads(content)
                data["something_new"] = {":type:": "<class 'x'>",
                                         ":serialized:": base64.b64encode(pickle.dumps(Payload(marker))).decode()}
                content = json.dumps(data).encode()
            dst.writestr(item, content)
    with pytest.raises(ValueError, match="something_new"):
        load_policy(folder)
    assert not marker.exists()


def test_a_planted_task_store_is_recomputed_not_run(tmp_path, capsys):
    from mdr_drive_env.sweep import Executor, TaskStore, task_key

    store = TaskStore(tmp_path / "tasks")
    tasks = [1.0, 2.0, 3.0]
    marker = tmp_path / "ran"
    store.folder.mkdir(parents=True)
    (store.folder / "000000.pkl").write_bytes(pickle.dumps((task_key(1.0), Payload(marker))))  # an old-style file
    store.save(1, task_key(2.0), 99.0)
    damaged = json.loads(store.path(1).read_text())
    damaged["result"] = damaged["result"].replace("99", "98")  # a flipped digit
    store.path(1).write_text(json.dumps(damaged))
    store.path(2).write_text("not json")
    found = Executor(workers=1, progress=False).map(np.sqrt, tasks, "t", store=store)
    assert found == [1.0, np.sqrt(2.0), np.sqrt(3.0)] and not marker.exists()
    err = capsys.readouterr().err
    assert "checksum does not hold" in err and "not readable as JSON" in err and len(err.strip().splitlines()) == 2
    assert store.load(1, task_key(2.0)) == (True, np.sqrt(2.0))  # rewritten


def test_a_planted_student_checkpoint_is_not_read(tmp_path):
    from mdr_drive_agents.student import checkpoint

    path, marker = tmp_path / "student_round0.npz", tmp_path / "ran"
    with open(path, "wb") as f:
        np.save(f, np.array([Payload(marker)], dtype=object), allow_pickle=True)
    state, why = checkpoint.load(path, {"teacher": "x"})
    assert state is None and "not a round-0 checkpoint" in why and not marker.exists()
    os.remove(path)
