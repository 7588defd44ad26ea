"""Training a user can rely on: interrupts save a resumable run, runs are not overwritten, --steps is
honoured or its rounding said, bad values are errors, the best model has its own normalisation."""

import json
import os
import signal
import threading

import pytest

pytest.importorskip("stable_baselines3")

import numpy as np  # noqa: E402

from mdr_drive_agents.policy import load_policy  # noqa: E402
from mdr_drive_agents.protocol import open_loop_velocity  # noqa: E402
from mdr_drive_agents.train.sb3 import rounded_steps, train  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

from mdr_drive_env.cli import main  # noqa: E402
from tests import ROOT  # noqa: E402

KW = dict(n_envs=4, eval_freq=64, checkpoint_freq=10_000, progress_bar=False)


def _interrupt_at(step: int, how: str):
    """An SB3 callback that interrupts training once it has run ``step`` steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class Interrupt(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps >= step:
                if how == "sigint":
                    raise KeyboardInterrupt
                os.kill(os.getpid(), signal.SIGTERM)
            return True

    return Interrupt()


@pytest.mark.parametrize("how", ["sigint", "sigterm"])
def test_an_interrupt_saves_a_run_that_resumes_with_the_same_step_counter(how, tmp_path, monkeypatch):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    assert threading.current_thread() is threading.main_thread()  # signal handlers need it
    out = tmp_path / "run"
    learn = PPO.learn

    def learn_with_interrupt(self, *a, callback=None, **kw):
        return learn(self, *a, callback=[*callback, _interrupt_at(192, how)], **kw)

    monkeypatch.setattr(PPO, "learn", learn_with_interrupt)
    record = train("ppo", steps=4096, seed=0, out=out, **KW)
    monkeypatch.setattr(PPO, "learn", learn)
    assert record["interrupted"] and 192 <= record["total_timesteps"] < 4096
    assert json.loads((out / "run.json").read_text())["interrupted"]
    model = PPO.load(out / "model.zip", device="cpu")  # plain SB3 loads what the interrupt saved
    assert model.num_timesteps == record["total_timesteps"]
    assert VecNormalize.load(str(out / "vecnormalize.pkl"), _venv()).obs_rms.count > 0
    resumed = train(resume=out, **KW)  # finishes the run's own total, in whole rollouts from where it stopped
    rollout = resumed["hyperparameters"]["n_steps"] * KW["n_envs"]
    assert not resumed["interrupted"] and resumed["total_timesteps"] == resumed["target_timesteps"]
    assert 4096 <= resumed["total_timesteps"] < 4096 + rollout
    assert resumed["resumes"] == 1


def _venv():
    from mdr_drive_agents.vec_env import BatchedVecEnv

    return BatchedVecEnv(1, seed=0)


def test_an_existing_run_is_not_overwritten_without_force(tmp_path, capsys):
    out = tmp_path / "run"
    train("ppo", steps=64, seed=0, out=out, **KW)
    before = (out / "model.zip").read_bytes()
    with pytest.raises(ValueError, match="already holds a run: continue it with --resume"):
        train("ppo", steps=64, seed=1, out=out, **KW)
    assert (out / "model.zip").read_bytes() == before
    assert main(["train", "--steps", "64", "--n-envs", "4", "--no-progress", "--out", str(out)]) == 2
    assert "already holds a run" in capsys.readouterr().err
    assert train("ppo", steps=64, seed=1, out=out, force=True, **KW)["seed"] == 1
    (out / "run.json").unlink()  # what a kill between the model's save and run.json's leaves
    with pytest.raises(ValueError, match="model.zip without run.json .* again with --force"):
        train("ppo", steps=64, seed=1, out=out, **KW)


def test_steps_rounding_is_said_and_bad_counts_are_errors(tmp_path, capsys):
    assert rounded_steps("ppo", 100, 4, {"n_steps": 16}) == 128 and rounded_steps("ppo", 128, 4, {"n_steps": 16}) == 128
    assert rounded_steps("sac", 100, 4, {}) == 100
    record = train("ppo", steps=100, seed=0, out=tmp_path / "r", **KW)
    err = capsys.readouterr().err
    n_steps = record["hyperparameters"]["n_steps"]
    assert f"--steps runs {rounded_steps('ppo', 100, 4, {'n_steps': n_steps})} steps, not 100" in err
    assert record["total_timesteps"] == rounded_steps("ppo", 100, 4, {"n_steps": n_steps})
    for argv in (["--steps", "0"], ["--n-envs", "-2"], ["--steps", "ten"], ["--torch-threads", "0"]):
        with pytest.raises(SystemExit) as e:
            main(["train", *argv])
        assert e.value.code == 2
    with pytest.raises(ValueError, match="steps=0"):
        train("ppo", steps=0, out=tmp_path / "x", **KW)


def test_the_best_model_has_its_own_normalisation_and_one_torch_thread(tmp_path):
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    out = tmp_path / "run"
    record = train("ppo", steps=256, seed=0, out=out, **KW)
    assert record["torch_threads"] == 1 and torch.get_num_threads() == 1
    assert (out / "best" / "best_model.zip").exists() and (out / "best" / "vecnormalize.pkl").exists()
    PPO.load(out / "best" / "best_model.zip", device="cpu")
    assert VecNormalize.load(str(out / "best" / "vecnormalize.pkl"), _venv()).obs_rms.mean.shape == (14,)


def test_several_seeds_train_as_one_sweep_and_a_rerun_keeps_them(tmp_path, capsys):
    from mdr_drive_env.cli import main

    args = ["train", "--seeds", "0", "1", "--steps", "256", "--n-envs", "4", "--eval-freq", "100000",
            "--no-progress", "--workers", "2", "--out", str(tmp_path)]
    assert main(args) == 0
    for s in (0, 1):
        run = json.loads((tmp_path / f"s{s}" / "run.json").read_text())
        assert run["seed"] == s and (tmp_path / f"s{s}" / "vecnormalize.pkl").exists()
    first = (tmp_path / "s0" / "model.zip").read_bytes()
    capsys.readouterr()
    assert main(args) == 0
    assert "seed 0 is already trained" in capsys.readouterr().out
    assert (tmp_path / "s0" / "model.zip").read_bytes() == first


def test_a_critic_warmup_trains_the_value_function_and_leaves_the_actions_alone(tmp_path):
    import torch
    from stable_baselines3 import PPO

    from mdr_drive_agents.train.sb3 import actor_parameters, frozen_actor

    out = tmp_path / "run"
    train("ppo", steps=64, seed=0, out=out, **KW)
    model = PPO.load(out / "model.zip", env=_venv(), device="cpu", n_steps=32, batch_size=32)
    actor = [p.detach().clone() for p in actor_parameters(model)]
    critic = [p.detach().clone() for p in model.policy.mlp_extractor.value_net.parameters()]
    with frozen_actor(model):
        model.learn(64)
    assert all(torch.equal(a, p) for a, p in zip(actor, actor_parameters(model)))
    assert not all(torch.equal(c, p) for c, p in zip(critic, model.policy.mlp_extractor.value_net.parameters()))
    assert all(p.requires_grad for p in actor_parameters(model))  # the context gives them back
    model.learn(64)
    assert not all(torch.equal(a, p) for a, p in zip(actor, actor_parameters(model)))

    from stable_baselines3 import SAC

    sac = SAC("MlpPolicy", _venv(), learning_starts=0, batch_size=16, device="cpu", seed=0)
    actor = [p.detach().clone() for p in actor_parameters(sac)]
    critic = [p.detach().clone() for p in sac.critic.parameters()]
    with frozen_actor(sac):
        sac.learn(16)
    assert all(torch.equal(a, p) for a, p in zip(actor, actor_parameters(sac)))
    assert not all(torch.equal(c, p) for c, p in zip(critic, sac.critic.parameters()))

    before = json.loads((out / "run.json").read_text())["total_timesteps"]
    warmup = rounded_steps("ppo", 100, 4, json.loads((out / "run.json").read_text())["hyperparameters"])
    # --steps is the run's total: the warmup's steps count towards it, the actor learns the rest
    resumed = train(resume=out, steps=before + warmup + 64, critic_warmup=100, **KW)
    assert resumed["critic_warmup_steps_this_run"] == warmup
    assert resumed["steps_this_run"] == warmup + rounded_steps("ppo", 64, 4, resumed["hyperparameters"])
    with pytest.raises(ValueError, match="critic_warmup=-1"):
        train(resume=out, steps=64, critic_warmup=-1, **KW)
    with pytest.raises(SystemExit) as e:
        main(["train", "--critic-warmup", "-5"])
    assert e.value.code == 2


def test_hyperparams_replace_the_runs_own_when_resuming(tmp_path, capsys):
    from stable_baselines3 import PPO

    from mdr_drive_agents.train.sb3 import key_value

    assert key_value("learning_rate:1e-5") == ("learning_rate", 1e-5) and key_value("n_steps:64") == ("n_steps", 64)
    assert key_value("net_arch:[64, 64]") == ("net_arch", [64, 64])
    out = tmp_path / "run"
    train("ppo", steps=64, seed=0, out=out, **KW)
    record = train(resume=out, steps=1024, hyperparams={"learning_rate": 1e-5, "n_steps": 32}, **KW)
    assert record["hyperparameters"]["learning_rate"] == 1e-5 and record["hyperparameters"]["n_steps"] == 32
    model = PPO.load(out / "model.zip", device="cpu")
    assert model.learning_rate == 1e-5 and model.n_steps == 32
    assert any((out / "tb").iterdir())  # a resumed run logs to TensorBoard too
    with pytest.raises(ValueError, match="policy_kwargs cannot change"):
        train(resume=out, steps=64, hyperparams={"policy_kwargs": {}}, **KW)
    with pytest.raises(ValueError, match="'learning_rat' is not a PPO hyperparameter this command sets"):
        train(resume=out, steps=64, hyperparams={"learning_rat": 1e-5}, **KW)
    for bad in ("learning_rate", "1x:2"):
        with pytest.raises(SystemExit) as e:
            main(["train", "--hyperparams", bad])
        assert e.value.code == 2
    assert "is not KEY:VALUE" in capsys.readouterr().err


def test_plain_ppo_over_a_codebook_trains_from_a_config_and_refuses_the_box_warm_start(tmp_path):
    import numpy as np
    import yaml

    from mdr_drive_agents.train.sb3 import load_config

    hyper, env_kwargs = load_config("ppo")
    np.save(tmp_path / "table.npy", np.random.default_rng(0).uniform(-1.0, 1.0, (4, 5)))
    block = {key: v for key, v in hyper.items() if key != "warm_start"}
    block["env_kwargs"] = {**env_kwargs, "action_codebook": str(tmp_path / "table.npy")}
    block["policy_kwargs"] = {"net_arch": [8]}
    (tmp_path / "codebook.yaml").write_text(yaml.safe_dump({"MDRDrive-v0": block, "warm_start": "trapezoid"}))
    (tmp_path / "old.yaml").write_text(yaml.safe_dump({"MDRDrive-v0": hyper, "env_kwargs": env_kwargs}))
    with pytest.raises(ValueError, match=r"unknown top-level key\(s\) \['env_kwargs'\]"):
        load_config("ppo", tmp_path / "old.yaml")  # env_kwargs beside the block would be ignored: refused
    with pytest.raises(ValueError, match="warm_start='trapezoid'.*action_codebook"):
        train("ppo", steps=64, out=tmp_path / "box", config=tmp_path / "codebook.yaml", **KW)
    assert not (tmp_path / "box").exists()  # refused before any folder is made
    record = train("ppo", steps=64, out=tmp_path / "picks", config=tmp_path / "codebook.yaml", warm_start="none", **KW)
    assert record["total_timesteps"] >= 64 and record["env_kwargs"]["action_codebook"] == str(tmp_path / "table.npy")


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
    assert record["seed"] == 0 and record["versions"]["torch"].startswith("2.13")
    # a 256-step run can take well under 0.1 s on a fast machine: the record keeps milliseconds
    assert isinstance(record["wall_time_s"], float) and record["wall_time_s"] >= 0
    assert np.isfinite(record["steps_per_s_this_run"])
    resumed = train(resume=out, steps=first["total_timesteps"] + 128, **kw)  # --steps: the run's new total
    assert resumed["total_timesteps"] >= first["total_timesteps"] + 128
    assert resumed["resumes"] == 1
    policy = load_policy(out)
    v = open_loop_velocity([(0.2, 0.1)], policy.act(np.zeros((1, 14), dtype=np.float32)))
    assert np.isfinite(v).all()


def test_rl_zoo_trains_with_the_shipped_config(tmp_path):
    pytest.importorskip("rl_zoo3")

    conf = ROOT / "agents" / "configs" / "ppo.yaml"
    res = subprocess.run([sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "MDRDrive-v0",
                          "--gym-packages", "mdr_drive_env", "-n", "300", "-conf", str(conf), "--log-folder",
                          str(tmp_path), "--eval-freq", "-1"], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert list(tmp_path.rglob("MDRDrive-v0.zip")) and list(tmp_path.rglob("vecnormalize.pkl"))
    # the Zoo trained on the config's domain (its env_kwargs), not the env's default single point
    assert "env_kwargs={'k': [0.0, 0.6], 'load_ratio': [0.0, 0.6], 'max_periods': 50, 'reward_floor': -2.0}" in res.stdout


def test_resume_finishes_the_runs_total_and_steps_on_resume_sets_a_new_one(tmp_path, capsys, monkeypatch):
    from stable_baselines3 import PPO

    out = tmp_path / "run"
    learn = PPO.learn
    monkeypatch.setattr(PPO, "learn", lambda self, *a, callback=None, **kw: learn(
        self, *a, callback=[*callback, _interrupt_at(64, "sigint")], **kw))
    first = train("ppo", steps=512, seed=0, out=out, **KW)
    monkeypatch.setattr(PPO, "learn", learn)
    assert first["interrupted"] and first["total_timesteps"] < 512 and first["target_timesteps"] == 512
    rollout = first["hyperparameters"]["n_steps"] * KW["n_envs"]
    finished = train(resume=out, **KW)  # a bare --resume finishes the run's 512, in whole rollouts
    assert finished["total_timesteps"] == finished["target_timesteps"] and 512 <= finished["total_timesteps"] < 512 + rollout
    with pytest.raises(ValueError, match="give --steps with a larger total"):
        train(resume=out, **KW)  # nothing left: said, not a silent re-save
    capsys.readouterr()
    have = finished["total_timesteps"]
    again = train(resume=out, steps=have + rollout, **KW)  # a new total, said in one line
    assert again["total_timesteps"] == again["target_timesteps"] == have + rollout
    assert f"--steps {have + rollout} sets the run's total (it has {have} steps): {rollout} more" in capsys.readouterr().err
    assert again["continued_from"][-1]["total_timesteps"] == have


def test_a_resumed_run_keeps_its_algorithm(tmp_path, capsys):
    out = tmp_path / "run"
    train("ppo", steps=64, seed=0, out=out, **KW)
    capsys.readouterr()
    assert main(["train", "--resume", str(out), "--algo", "sac", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "trained with 'ppo'" in err and len(err.strip().splitlines()) == 1


def test_one_command_at_a_time_writes_a_run_folder(tmp_path, capsys):
    from mdr_drive_agents.run_record import RunLock

    out = tmp_path / "run"
    with RunLock(out):  # another train (or recipe) is writing here
        assert main(["train", "--steps", "64", "--n-envs", "4", "--no-progress", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "is being written by process" in err and len(err.strip().splitlines()) == 1
    assert not (out / "model.zip").exists()


def test_the_last_good_model_survives_a_save_that_dies(tmp_path, monkeypatch):
    from stable_baselines3 import PPO

    out = tmp_path / "run"
    train("ppo", steps=64, seed=0, out=out, **KW)
    good = {name: (out / name).read_bytes() for name in ("model.zip", "run.json", "vecnormalize.npz")}

    def dying_save(self, path, *a, **kw):
        with open(path, "wb") as f:
            f.write(b"half a zip")
        raise KeyboardInterrupt  # killed mid-write

    monkeypatch.setattr(PPO, "save", dying_save)
    with pytest.raises(KeyboardInterrupt):
        train(resume=out, steps=1024, **KW)
    assert {name: (out / name).read_bytes() for name in good} == good  # the last good set, whole
    monkeypatch.undo()
    (out / ".model.zip.k3j4h5g6.zip").write_bytes(b"what SIGKILL leaves of a save")
    assert train(resume=out, steps=1024, **KW)["total_timesteps"] == 1024  # it resumes from the good set
    assert not (out / ".model.zip.k3j4h5g6.zip").exists()  # and the dead save's file is gone


@pytest.mark.parametrize("value, needle", [("learning_rate:abc", "learning_rate='abc' must be a number"),
                                           ("n_steps:-1", "n_steps=-1 must be an integer"),
                                           ("gamma:1.5", "gamma=1.5"), ("batch_size:0.5", "batch_size=0.5")])
def test_bad_hyperparameters_are_one_line_errors_naming_them(value, needle, tmp_path, capsys):
    assert main(["train", "--steps", "64", "--n-envs", "4", "--no-progress", "--out", str(tmp_path / "r"),
                 "--hyperparams", value]) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "r").exists()


def test_weights_that_are_not_the_runs_algorithm_are_one_line(tmp_path, capsys):
    ppo, sac = tmp_path / "ppo", tmp_path / "sac"
    train("ppo", steps=64, seed=0, out=ppo, **KW)
    train("sac", steps=64, seed=0, out=sac, **{**KW, "n_envs": 2})
    capsys.readouterr()
    (ppo / "model.zip").write_bytes((sac / "model.zip").read_bytes())  # SAC weights, a PPO run.json
    for argv in (["train", "--resume", str(ppo), "--steps", "1024", "--no-progress"],
                 ["evaluate", "--policy", str(ppo), "--k", "0.2", "--cargo-mass", "0.1"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "model" in err and len(err.strip().splitlines()) == 1


def test_a_distilled_picking_policy_fine_tunes_after_a_critic_warmup_and_keeps_its_provenance(tmp_path):
    import shutil

    from mdr_drive_agents.policy import PRETRAINED, load_policy

    copy = tmp_path / "ft"
    shutil.copytree(PRETRAINED, copy)
    record = train(resume=copy, critic_warmup=128, steps=256, progress_bar=False, eval_freq=10_000,
                   hyperparams={"n_steps": 8, "batch_size": 64})
    assert record["critic_warmup_steps_this_run"] == 128 and record["total_timesteps"] == 256
    assert record["distilled_from"] == json.loads((PRETRAINED / "run.json").read_text())["distilled_from"]
    assert load_policy(copy).model.action_space.n == 657
