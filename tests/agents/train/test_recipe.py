"""The recipe (mdr_drive_agents.train.recipe, mdr-drive recipe) end to end at CI size: the policy it
writes is a plain SB3 model."""

from __future__ import annotations

import json
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents.train import recipe
from mdr_drive_agents.student.distill import DistillConfig
from mdr_drive_agents.policy import PRETRAINED
from mdr_drive_agents.teacher import FieldConfig
from mdr_drive_agents.teacher.config import PolishPass
from mdr_drive_env.cli import main
from tests import DATA
from tests.agents.train.student_stage import ctrl_c, interrupt_in_the_hole_round, record_fits

TINY = DATA / "recipe_tiny.yaml"


@pytest.fixture(scope="module")
def recipe_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("recipe")
    summary = recipe.run(TINY, out, progress=False, force=True)
    return out, summary


def test_recipe_writes_a_plain_sb3_policy_that_loads_and_acts(recipe_run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, summary = recipe_run
    assert set(summary["stage_wall_time_s"]) == {"teacher_s", "student_s", "total_s"}
    teacher_stages = summary["teacher_stage_wall_time_s"]  # each of the teacher's stages, in the order they ran
    assert list(teacher_stages) == ["grid", "polish_1", "refine_k", "polish_stall", "audit", "exchange_all",
                                    "env_replay"]  # the paper drive's 2 ms: searched at T/200, replayed on the env's solver
    assert all(s >= 0.0 for s in teacher_stages.values())
    assert sum(teacher_stages.values()) <= summary["stage_wall_time_s"]["teacher_s"] + 1.0
    assert "blas_core" in summary  # the BLAS kernels the teacher was searched with (mdr_drive_env.blas)
    venv = VecNormalize.load(str(out / "policy" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: gym.make("MDRDrive-v0", k=0.1, cargo_mass=0.05)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(out / "policy" / "model.zip", device="cpu")
    obs = venv.reset()
    for _ in range(3):
        action, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(action)
    assert action.shape == (1, 5) and np.all(np.abs(action) <= 1.0)
    run = json.loads((out / "policy" / "run.json").read_text())
    assert run["algo"] == "ppo" and "residual_scale" not in run["hyperparameters"]
    history = run["distilled_from"]["history"]
    assert len(history) == 3  # the teacher's round, one DAgger round, one hole round
    assert history[0]["samples"] == (16 + history[0]["jump_points"]) * 4  # round 0: random points and bisection
    assert history[2]["hole_round"] == 1 and history[2]["probes"] == 16 + 4 and 0 <= history[2]["holes"] <= 20
    assert 0 <= history[2]["stall_holes"] <= min(4, history[2]["holes"])  # the stall probes ran (the shipped recipe's)
    assert not (out / ".tasks").exists()
    from mdr_drive_agents.teacher import DriveField

    field = DriveField.load(out / "teacher_field.npz")
    assert [p["budget"] for p in field.meta["polished"]] == [8]  # the polish ran
    assert np.allclose(field.ks, [0.0, 0.15, 0.3]) and field.meta["refined_k"]["new_nodes"] == 2  # and the refinement
    assert field.meta["polished_stall"]["k_max"] is None and field.meta["polished_stall"]["nodes"] == 6  # every k line
    audited = field.meta["audited"]  # and the audit against a stronger search
    assert audited["points"] == 2 and 0 <= audited["short"] <= 2 and audited["nodes"] <= 4 * audited["short"]
    exchanged = field.meta["exchanged_all"]  # and every node offered every drive of the field, last
    assert exchanged["nodes"] == field.velocities.size and 0 <= exchanged["changed"] <= exchanged["nodes"]
    assert exchanged["drives"] >= 2


def test_the_distilled_policy_fine_tunes_with_train_resume(recipe_run):
    import pickle

    from mdr_drive_agents.train.sb3 import train

    out, _ = recipe_run
    before = pickle.loads((out / "policy" / "vecnormalize.pkl").read_bytes()).obs_rms
    record = train(resume=out / "policy", steps=64, progress_bar=False, eval_freq=10_000)
    assert record["resumes"] == 1 and record["total_timesteps"] >= 64
    after = pickle.loads((out / "policy" / "vecnormalize.pkl").read_bytes()).obs_rms
    # the observation statistics the network was distilled on are not moved by PPO's rollouts
    np.testing.assert_array_equal(after.mean, before.mean)
    np.testing.assert_array_equal(after.var, before.var)


def test_an_existing_output_is_refused_without_resume_or_force(recipe_run, capsys):
    out, _ = recipe_run
    assert main(["recipe", str(TINY), "--out", str(out), "--no-progress", "--workers", "1"]) == 2
    assert "--resume" in capsys.readouterr().err


def test_a_saved_teacher_is_distilled_without_searching_again(recipe_run, tmp_path, capsys):
    from mdr_drive_agents.teacher import DriveField

    out, _ = recipe_run
    assert main(["recipe", str(TINY), "--out", str(tmp_path / "again"), "--no-progress", "--workers", "1",
                        "--teacher", str(out / "teacher_field.npz"), "--snapshots"]) == 0
    assert "(loaded)" in capsys.readouterr().out
    again, first = DriveField.load(tmp_path / "again" / "teacher_field.npz"), DriveField.load(out / "teacher_field.npz")
    assert np.array_equal(again.drives, first.drives)
    summary = json.loads((tmp_path / "again" / "recipe.json").read_text())
    assert summary["teacher_loaded_from"] == str(out / "teacher_field.npz")
    assert (tmp_path / "again" / "policy" / "model.zip").exists()
    # --snapshots: the student after its one hole round, which is the final student
    from stable_baselines3 import PPO

    snapshot = tmp_path / "again" / "snapshots" / "hole_round1"
    assert sorted(p.name for p in snapshot.iterdir()) == ["model.zip", "run.json", "vecnormalize.npz", "vecnormalize.pkl"]
    final, saved = PPO.load(tmp_path / "again" / "policy" / "model.zip"), PPO.load(snapshot / "model.zip")
    for a, b in zip(final.policy.parameters(), saved.policy.parameters()):
        assert np.array_equal(a.detach().numpy(), b.detach().numpy())
    assert json.loads((snapshot / "run.json").read_text())["distilled_from"]["history"][-1]["hole_round"] == 1
    with pytest.raises(SystemExit) as exit_:
        main(["recipe", str(TINY), "--out", str(tmp_path / "x"), "--teacher", str(tmp_path / "missing.npz")])
    assert exit_.value.code == 2 and "missing.npz" in capsys.readouterr().err
    (tmp_path / "bad.npz").write_text("not a field")
    assert main(["recipe", str(TINY), "--out", str(tmp_path / "y"), "--teacher", str(tmp_path / "bad.npz")]) == 2
    err = capsys.readouterr().err
    assert "--teacher" in err and "bad.npz" in err and len(err.strip().splitlines()) == 1


def test_a_student_taught_with_the_phase_seam_moved_acts_in_that_env_and_reports_default_actions(recipe_run, tmp_path):
    import yaml

    from mdr_drive_agents.student.data import labelled_episodes, rollout
    from mdr_drive_agents.teacher import DriveField
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.protocol import policy_rollout, steady_velocity_of
    from mdr_drive_env.gym_envs.spaces import shift_phase_origin

    out, _ = recipe_run
    field = DriveField.load(out / "teacher_field.npz")
    config = yaml.safe_load(TINY.read_text())
    # the teacher's episodes, translated: the same observations bar the phase entry, the same motion
    points = [(0.05, 0.01), (0.2, 0.03), (0.25, 0.0)]
    cfg = recipe.load_recipe(TINY).distill
    obs0, drives0 = labelled_episodes(field, points, None, cfg, 0)
    obs5, drives5 = labelled_episodes(field, points, None, cfg, 0, z_phase_origin=0.5)
    np.testing.assert_allclose(drives5, shift_phase_origin(drives0, 0.0, 0.5))
    phase = 9  # prev_z_phase, the only entry that differs
    assert np.array_equal(np.delete(obs0, phase, axis=1), np.delete(obs5, phase, axis=1))
    _, _, d0 = rollout(points, drives0[:3], None, 6)
    _, _, d5 = rollout(points, drives5[:3], None, 6, z_phase_origin=0.5)
    assert np.array_equal(steady_velocity_of(d0, 3), steady_velocity_of(d5, 3))

    config["env_kwargs"]["z_phase_origin"] = 0.5
    (tmp_path / "moved.yaml").write_text(yaml.safe_dump(config))
    recipe.run(tmp_path / "moved.yaml", tmp_path / "moved", progress=False, teacher=out / "teacher_field.npz")
    policy = load_policy(tmp_path / "moved" / "policy")
    assert policy.play_kwargs == {"z_phase_origin": 0.5}
    disp, acts, _ = policy_rollout(policy, points, periods=3)
    env = gym.make("MDRDrive-v0", k=points[1][0], cargo_mass=points[1][1], max_periods=3, z_phase_origin=0.5)
    obs, _ = env.reset(seed=0)
    raw = []
    for _ in range(3):
        raw.append(policy.act(obs[None])[0])
        obs, _, _, _, info = env.step(raw[-1])
    assert info["displacement"] == pytest.approx(disp[-1, 1], rel=1e-5)  # played in the env it was taught in (the batched solver rounds otherwise)
    np.testing.assert_allclose(acts[:, 1], shift_phase_origin(np.array(raw), 0.5, 0.0), atol=1e-6)  # reported in default units


def test_a_teacher_field_counts_as_searched_with_the_config_it_records_and_no_other():
    import dataclasses

    from mdr_drive_agents.teacher import DriveField

    config = recipe.load_recipe(recipe.DEFAULT_CONFIG).teacher
    shipped = DriveField.load(PRETRAINED / "teacher_field.npz")  # searched before the audit replaced polish_band
    assert "polished_band" in shipped.meta and "audited" not in shipped.meta
    assert recipe.searched_with_another_config(shipped, config)
    saved = json.loads(json.dumps(dataclasses.asdict(config)))
    field = DriveField(shipped.ks, shipped.fractions, shipped.trapezoid_critical, shipped.drives, shipped.velocities,
                       {"config": saved})
    assert not recipe.searched_with_another_config(field, config)
    assert recipe.searched_with_another_config(field, dataclasses.replace(config, cycle_budget=701))
    assert recipe.searched_with_another_config(field, dataclasses.replace(config, friction=(0.3, 0.13)))
    older = DriveField(field.ks, field.fractions, field.trapezoid_critical, field.drives, field.velocities,
                       {"config": {key: value for key, value in saved.items()
                                   if key not in ("friction", "refine_k")}})  # saved before those keys existed
    assert not recipe.searched_with_another_config(older, dataclasses.replace(config, refine_k=None))  # defaults count
    assert recipe.searched_with_another_config(older, config)
    audit = {key: value for key, value in saved["audit"].items() if key != "keep_found"}  # saved before it existed
    no_keep = DriveField(field.ks, field.fractions, field.trapezoid_critical, field.drives, field.velocities,
                         {"config": {**saved, "audit": audit}})
    assert not recipe.searched_with_another_config(no_keep, dataclasses.replace(
        config, audit=dataclasses.replace(config.audit, keep_found=False)))  # a stage's defaults count too
    assert recipe.searched_with_another_config(no_keep, config)
    gone = DriveField(field.ks, field.fractions, field.trapezoid_critical, field.drives, field.velocities,
                      {"config": {**saved, "retired_option": 1}})
    assert recipe.searched_with_another_config(gone, config)


def test_the_student_seed_reaches_the_student_alone(recipe_run, tmp_path):
    import yaml
    from stable_baselines3 import PPO

    out, first = recipe_run
    config = yaml.safe_load(TINY.read_text())
    assert "student_seed" not in config and recipe.load_recipe(TINY).seeds[1] == config["seed"]
    (tmp_path / "other_student.yaml").write_text(yaml.safe_dump({**config, "student_seed": config["seed"] + 1}))
    summary = recipe.run(tmp_path / "other_student.yaml", tmp_path / "other", progress=False,
                         teacher=out / "teacher_field.npz")
    assert (summary["seed"], summary["student_seed"], first["student_seed"]) == (config["seed"], config["seed"] + 1,
                                                                       config["seed"])
    assert json.loads((tmp_path / "other" / "policy" / "run.json").read_text())["seed"] == config["seed"] + 1
    a, b = PPO.load(out / "policy" / "model.zip"), PPO.load(tmp_path / "other" / "policy" / "model.zip")
    assert not all(np.array_equal(x.detach().numpy(), y.detach().numpy())
                   for x, y in zip(a.policy.parameters(), b.policy.parameters()))
    (tmp_path / "typo.yaml").write_text(yaml.safe_dump({**config, "student_sed": 3}))
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['student_sed'\]"):
        recipe.load_recipe(tmp_path / "typo.yaml")


def _weights(policy_dir: Path) -> list[np.ndarray]:
    from stable_baselines3 import PPO

    return [x.detach().numpy() for x in PPO.load(policy_dir / "model.zip").policy.parameters()]


def _checkpoint_meta(path: Path) -> dict:
    with np.load(path, allow_pickle=False) as f:  # the checkpoint is data: nothing in it is run
        return json.loads(str(f["meta"]))


def test_an_interrupted_student_stage_resumes_after_its_first_fit_with_the_same_weights(recipe_run, tmp_path,
                                                                                        monkeypatch, capsys):

    import yaml

    from mdr_drive_agents.student import distill

    out, _ = recipe_run
    teacher = out / "teacher_field.npz"
    run = tmp_path / "run"

    # Ctrl-C in the hole round, after the first fit and the DAgger round
    saved = interrupt_in_the_hole_round(["recipe", str(TINY), "--out", str(run), "--no-progress", "--teacher",
                                         str(teacher)], run, monkeypatch, capsys)
    fits = record_fits(monkeypatch)
    recipe.run(TINY, run, progress=False, resume=True, teacher=teacher)
    assert f"round 0 read from {saved}" in capsys.readouterr().out
    # the DAgger round and the hole round were fitted, round 0 was not
    tiny = recipe.load_recipe(TINY).distill
    assert fits == [tiny.round_steps, tiny.hole_steps]
    assert not (run / ".tasks").exists()
    fits.clear()
    recipe.run(TINY, tmp_path / "whole", progress=False, teacher=teacher)  # (the fixture's policy is fine-tuned by
    assert fits == [tiny.steps, tiny.round_steps, tiny.hole_steps]      # another test: not the reference)
    for a, b in zip(_weights(run / "policy"), _weights(tmp_path / "whole" / "policy"), strict=True):
        np.testing.assert_array_equal(a, b)  # the resumed run's weights are the uninterrupted run's
    history = json.loads((run / "policy" / "run.json").read_text())["distilled_from"]["history"]
    assert [h.get("round", h.get("hole_round")) for h in history] == [0, 1, 1]

    # Ctrl-C in round 0's fit: its labelled episodes are kept, and the resumed run fits them to the same weights
    during = tmp_path / "during_fit"
    with monkeypatch.context() as m:
        m.setattr(distill, "fit", ctrl_c)
        assert main(["recipe", str(TINY), "--out", str(during), "--no-progress", "--teacher", str(teacher)]) == 130
    capsys.readouterr()
    assert _checkpoint_meta(during / ".tasks" / "student_round0.npz")["fitted"] is False
    fits.clear()
    recipe.run(TINY, during, progress=False, resume=True, teacher=teacher)
    assert f"round 0's episodes read from {during / '.tasks' / 'student_round0.npz'}" in capsys.readouterr().out
    assert fits == [tiny.steps, tiny.round_steps, tiny.hole_steps]
    for a, b in zip(_weights(during / "policy"), _weights(tmp_path / "whole" / "policy"), strict=True):
        np.testing.assert_array_equal(a, b)

    # a checkpoint is used only for the round-0 settings and teacher it was fitted with
    config = yaml.safe_load(TINY.read_text())
    monkeypatch.setattr(distill, "hole_round", ctrl_c)
    assert main(["recipe", str(TINY), "--out", str(run), "--no-progress", "--force", "--teacher", str(teacher)]) == 130
    capsys.readouterr()
    state = _checkpoint_meta(saved)
    (tmp_path / "later.yaml").write_text(yaml.safe_dump({**config, "distill": {**config["distill"], "hole_steps": 12}}))
    (tmp_path / "round0.yaml").write_text(yaml.safe_dump({**config, "distill": {**config["distill"], "steps": 41}}))
    fits.clear()
    with pytest.raises(KeyboardInterrupt):  # a later round's setting: round 0 is read
        recipe.run(tmp_path / "later.yaml", run, progress=False, resume=True, teacher=teacher)
    assert "round 0 read from" in capsys.readouterr().out and fits == [tiny.round_steps]
    fits.clear()
    with pytest.raises(KeyboardInterrupt):  # a round-0 setting: fitted again, and said why
        recipe.run(tmp_path / "round0.yaml", run, progress=False, resume=True, teacher=teacher)
    err = capsys.readouterr().err
    assert "another distill: steps: round 0 is fitted again" in err and fits == [41, tiny.round_steps]
    assert _checkpoint_meta(saved)["fingerprint"]["distill"]["steps"] == 41 != state["fingerprint"]["distill"]["steps"]
    saved.write_bytes(b"truncated")
    fits.clear()
    with pytest.raises(KeyboardInterrupt):
        recipe.run(TINY, run, progress=False, resume=True, teacher=teacher)
    assert "is not a round-0 checkpoint" in capsys.readouterr().err and fits == [tiny.steps, tiny.round_steps]


def test_configs_reject_bad_values_naming_them():
    with pytest.raises(ValueError, match="k_values"):
        FieldConfig(k_values=1)
    with pytest.raises(ValueError, match="learning_rate"):
        DistillConfig(learning_rate=0.0)
    with pytest.raises(ValueError, match="activation"):
        DistillConfig(activation="gelu")
    with pytest.raises(ValueError, match="huber_delta"):
        DistillConfig(huber_delta=-1.0)
    with pytest.raises(ValueError, match="jump_levels"):
        DistillConfig(jump_levels=-1)
    with pytest.raises(ValueError, match=r"bf16_share=1\.5 is outside the allowed range \[0, 1\]"):
        DistillConfig(bf16_share=1.5)
    with pytest.raises(ValueError, match="fused_adam='yes' must be true or false"):
        DistillConfig(fused_adam="yes")
    with pytest.raises(ValueError, match="flush_denormal='yes' must be true or false"):
        DistillConfig(flush_denormal="yes")
    with pytest.raises(ValueError, match="jump_threshold"):
        DistillConfig(jump_threshold=0.0)
    with pytest.raises(ValueError, match="polish budget"):
        FieldConfig(polish=(PolishPass(0, 0.1),))
    with pytest.raises(ValueError, match="polish"):
        FieldConfig(polish=((10, 0.1, 3),))


def test_a_codebook_student_picks_the_teachers_grid_actions_and_loads_as_plain_sb3(recipe_run, tmp_path):
    import yaml
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from mdr_drive_agents.teacher import DriveField
    from mdr_drive_agents.policy import load_policy, run_env_kwargs
    from mdr_drive_agents.protocol import policy_rollout
    from mdr_drive_agents.student.data import grid_actions
    from mdr_drive_agents.train.sb3 import train

    out, _ = recipe_run
    config = yaml.safe_load(TINY.read_text())
    config["distill"].update(action_codebook=True, quantum_centres=True)
    (tmp_path / "codebook.yaml").write_text(yaml.safe_dump(config))
    run = tmp_path / "run"
    recipe.run(tmp_path / "codebook.yaml", run, progress=False, teacher=out / "teacher_field.npz")
    folder = run / "policy"
    table = np.load(folder / "action_codebook.npy")
    np.testing.assert_array_equal(table, grid_actions(DriveField.load(out / "teacher_field.npz")))
    saved = json.loads((folder / "run.json").read_text())
    assert saved["env_kwargs"]["action_codebook"] == "action_codebook.npy"  # beside model.zip, found from there

    # plain SB3: the env with the shipped table, PPO.load, VecNormalize.load, predict gives indices
    env_kwargs = {**run_env_kwargs(folder, saved), "k": 0.2, "load_ratio": 0.1}
    venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([lambda: gym.make("MDRDrive-v0", **env_kwargs)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(folder / "model.zip", device="cpu")
    assert model.action_space == gym.spaces.Discrete(len(table))
    obs, played = venv.reset(), []
    for _ in range(4):
        index, _ = model.predict(obs, deterministic=True)
        obs, *_ = venv.step(index)
        played.append(table[index[0]])
    # the package's evaluation plays the rows those indices select, in an env without the table
    policy = load_policy(folder)
    cargo = venv.envs[0].unwrapped.cargo_mass
    _, actions, _ = policy_rollout(policy, [(0.2, cargo)], periods=4)
    np.testing.assert_allclose(actions[:, 0], np.array(played), atol=1e-6)
    assert all(any(np.array_equal(a, row) for row in table) for a in played)

    # shipped: the table is copied, and the card's snippet (with the table) runs as written
    import subprocess
    import sys

    from mdr_drive_agents.benchmarks.model_card import ship

    card = ship(folder, tmp_path / "shipped").read_text()
    assert (tmp_path / "shipped" / "action_codebook.npy").exists() and f"Discrete({len(table)})" in card
    snippets = re.findall(r"```python\n(.*?)```", card, flags=re.S)
    assert "load_policy(" in snippets[0] and "action_codebook=" in snippets[1]
    for snippet in snippets:
        done = subprocess.run([sys.executable, "-c", snippet], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0 and "steady velocity" in done.stdout, done.stderr

    record = train(resume=folder, steps=64, progress_bar=False, eval_freq=10_000)  # fine-tunes over the indices
    assert record["resumes"] == 1 and record["env_kwargs"]["action_codebook"] == "action_codebook.npy"
    with pytest.raises(ValueError, match="quantum_centres"):
        DistillConfig(action_codebook=True)
    from mdr_drive_agents.student.distill import check_drawn_friction

    check_drawn_friction(DistillConfig(action_codebook=True, quantum_centres=True), friction_drawn=True)  # its fields' drives
    with pytest.raises(ValueError, match="stall_probes: not with a drawn friction"):
        check_drawn_friction(DistillConfig(stall_probes=16), friction_drawn=True)



def test_a_worth_student_is_built_from_the_teacher_and_loads_as_plain_sb3(recipe_run, tmp_path, capsys):
    """The recipe's ``worth`` student (``student.told``): the field's drives valued at random points,
    one network of their worth, written as one SB3 policy over the library's rows."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    out, _ = recipe_run
    worth = DATA / "recipe_tiny_worth.yaml"
    assert main(["recipe", str(worth), "--out", str(tmp_path / "w"), "--no-progress", "--workers", "1",
                 "--teacher", str(out / "teacher_field.npz"), "--only", "told"]) == 0
    assert "recipe: told: fraction_of_library_best_mean" in capsys.readouterr().out
    assert not (tmp_path / "w" / "sensor_policy").exists()
    assert json.loads((tmp_path / "w" / "recipe.json").read_text())["sensor_policy"] is None
    folder = tmp_path / "w" / "policy"
    run = json.loads((folder / "run.json").read_text())
    picks = run["picks_from"]
    assert picks["observation"] == "told" and picks["worth"]["steps"] == 30 and picks["points"] == 20
    assert run["env_kwargs"]["action_codebook"] == "action_codebook.npy" and 2 * picks["drives"] == picks["rows"]
    rows = np.load(folder / "action_codebook.npy")
    venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), DummyVecEnv([lambda: gym.make(
        "MDRDrive-v0", k=0.1, cargo_mass=0.02, action_codebook=rows, time_quantum=5e-6)]))
    venv.training, venv.norm_reward = False, False
    model = PPO.load(folder / "model.zip", device="cpu")
    obs = venv.reset()
    action, _ = model.predict(obs, deterministic=True)
    assert 0 <= int(action[0]) < len(rows)
    from mdr_drive_agents.policy import policy_label

    assert policy_label(folder) == "recipe policy (w/policy)"
    assert main(["recipe", str(worth), "--out", str(tmp_path / "s"), "--teacher", str(out / "teacher_field.npz"),
                 "--snapshots"]) == 2
    err = capsys.readouterr().err
    assert "--snapshots" in err and "'worth'" in err and len(err.strip().splitlines()) == 1
    assert main(["recipe", str(TINY), "--out", str(tmp_path / "t"), "--teacher", str(out / "teacher_field.npz"),
                 "--student", "worth"]) == 2  # --student names a section the YAML must have
    err = capsys.readouterr().err
    assert "needs a 'worth' section" in err and len(err.strip().splitlines()) == 1


def test_a_recipe_builds_the_sensor_policy_from_the_teachers_drives(recipe_run, tmp_path, capsys):
    """Without ``--only told``, a recipe with a ``sensor_policy`` section also writes ``OUT/sensor_policy``:
    a table of the field's drives and of searches at hidden draws started from them, then the sensor
    policy's rounds; each stage timed in recipe.json."""
    from mdr_drive_agents.policy import load_policy
    from mdr_drive_agents.teacher.drive_table import DriveTable

    out, _ = recipe_run
    worth = DATA / "recipe_tiny_worth.yaml"
    assert main(["recipe", str(worth), "--out", str(tmp_path / "b"), "--no-progress", "--workers", "1",
                 "--teacher", str(out / "teacher_field.npz"), "--sensor-tier", "encoder"]) == 0
    assert "recipe: sensor policy" in capsys.readouterr().out
    summary = json.loads((tmp_path / "b" / "recipe.json").read_text())
    assert {"student_s", "sensor_table_s", "sensor_policy_s", "total_s"} <= set(summary["stage_wall_time_s"])
    rounds = summary["sensor_policy"]["rounds"]
    assert [r["round"] for r in rounds] == [0, 1] and sum(r.get("kept", False) for r in rounds) == 1
    from mdr_drive_agents.train.sensor import round_rank

    kept = next(r for r in rounds if r.get("kept"))
    assert round_rank(kept) == max(round_rank(r) for r in rounds)  # keep_best_round: the best validation
    table = DriveTable.load(tmp_path / "b" / "drive_table.npz")
    assert table.record["library"] >= 2 and len(table.drives) <= 4
    run = json.loads((tmp_path / "b" / "sensor_policy" / "run.json").read_text())
    assert run["env_id"] == "MDRDriveSensor-v0" and "sensor_tier" not in run["env_kwargs"]  # the env default, encoder
    assert run["picks_from"]["sensor"]["sensor_tier"] == "encoder"
    policy = load_policy(tmp_path / "b" / "sensor_policy")
    np.testing.assert_array_equal(policy.codebook, table.rows)
    close = tmp_path / "close_friction.yaml"  # mu 0.2 over mu1 0.15: the default spreads overlap
    close.write_text("friction_coefficient: 0.2\nbase_friction_coefficient: 0.15\n")
    for args, says in ((["--only", "told", "--sensor-tier", "trace"], "no sensor policy is built"),
                       (["--sensor-tier", "trace"], "no sensor policy is built"),
                       (["--drive", str(close)], "the sensor policy's friction ranges mu [0.133333333333, 0.266666666667]"
                                                 " and mu1 [0.105, 0.195] overlap")):
        config = TINY if args == ["--sensor-tier", "trace"] else worth
        assert main(["recipe", str(config), "--out", str(tmp_path / "e"), "--teacher", str(out / "teacher_field.npz"),
                     *args]) == 2
        err = capsys.readouterr().err
        assert says in err and len(err.strip().splitlines()) == 1


def test_a_recipe_builds_the_student_it_names():
    from mdr_drive_agents.student.told import WorthConfig

    assert recipe.RecipeConfig(seed=0, teacher=FieldConfig(), distill=DistillConfig()).student == "distill"
    with pytest.raises(ValueError, match="student='worth' needs a 'worth' section"):
        recipe.RecipeConfig(seed=0, teacher=FieldConfig(), student="worth", distill=DistillConfig())
    with pytest.raises(ValueError, match=r"student='ppo' is not one of \['distill', 'worth'\]"):
        recipe.RecipeConfig(seed=0, teacher=FieldConfig(), student="ppo", worth=WorthConfig())
