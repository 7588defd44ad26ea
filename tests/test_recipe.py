"""The recipe (agents/recipe.py) end to end at CI size: the shipped policy's shape is a plain SB3 model."""

from __future__ import annotations

import json
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import mdr_drive_env  # noqa: F401
from mdr_drive_agents import recipe
from mdr_drive_agents.cycles import align_phase
from mdr_drive_agents.distill import DistillConfig
from mdr_drive_agents.drive_field import FieldConfig

TINY = Path(__file__).parent / "data" / "recipe_tiny.yaml"


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
    from mdr_drive_agents.drive_field import DriveField

    field = DriveField.load(out / "teacher_field.npz")
    assert [p["budget"] for p in field.meta["polished"]] == [8]  # the polish ran
    assert np.allclose(field.ks, [0.0, 0.15, 0.3]) and field.meta["refined_k"]["new_nodes"] == 2  # and the refinement
    assert field.meta["polished_stall"]["k_max"] == 0.15 and field.meta["polished_stall"]["nodes"] == 4  # and the last


def test_the_distilled_policy_fine_tunes_with_train_resume(recipe_run):
    import pickle

    from mdr_drive_agents.train import train

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
    assert recipe.main([str(TINY), "--out", str(out), "--no-progress", "--workers", "1"]) == 2
    assert "--resume" in capsys.readouterr().err


def test_a_saved_teacher_is_distilled_without_searching_again(recipe_run, tmp_path, capsys):
    from mdr_drive_agents.drive_field import DriveField

    out, _ = recipe_run
    assert recipe.main([str(TINY), "--out", str(tmp_path / "again"), "--no-progress", "--workers", "1",
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
    assert sorted(p.name for p in snapshot.iterdir()) == ["model.zip", "run.json", "vecnormalize.pkl"]
    final, saved = PPO.load(tmp_path / "again" / "policy" / "model.zip"), PPO.load(snapshot / "model.zip")
    for a, b in zip(final.policy.parameters(), saved.policy.parameters()):
        assert np.array_equal(a.detach().numpy(), b.detach().numpy())
    assert json.loads((snapshot / "run.json").read_text())["distilled_from"]["history"][-1]["hole_round"] == 1
    with pytest.raises(SystemExit) as exit_:
        recipe.main([str(TINY), "--out", str(tmp_path / "x"), "--teacher", str(tmp_path / "missing.npz")])
    assert exit_.value.code == 2 and "missing.npz" in capsys.readouterr().err
    (tmp_path / "bad.npz").write_text("not a field")
    assert recipe.main([str(TINY), "--out", str(tmp_path / "y"), "--teacher", str(tmp_path / "bad.npz")]) == 2
    err = capsys.readouterr().err
    assert "--teacher" in err and "bad.npz" in err and len(err.strip().splitlines()) == 1


def test_a_student_taught_with_the_phase_seam_moved_acts_in_that_env_and_reports_default_actions(recipe_run, tmp_path):
    import yaml

    from mdr_drive_agents.teacher_data import labelled_episodes, rollout
    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import Policy, policy_rollout, steady_velocity_of
    from mdr_drive_env.gym_envs.spaces import shift_phase_origin

    out, _ = recipe_run
    field = DriveField.load(out / "teacher_field.npz")
    config = yaml.safe_load(TINY.read_text())
    # the teacher's episodes, translated: the same observations bar the phase entry, the same motion
    points = [(0.05, 0.01), (0.2, 0.03), (0.25, 0.0)]
    cfg = recipe.load_recipe(TINY)["distill"]
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
    policy = Policy(tmp_path / "moved" / "policy")
    assert policy.play_kwargs == {"z_phase_origin": 0.5}
    disp, acts, _ = policy_rollout(policy, points, periods=3)
    env = gym.make("MDRDrive-v0", k=points[1][0], cargo_mass=points[1][1], max_periods=3, z_phase_origin=0.5)
    obs, _ = env.reset(seed=0)
    raw = []
    for _ in range(3):
        raw.append(policy(obs[None])[0])
        obs, _, _, _, info = env.step(raw[-1])
    assert info["displacement"] == pytest.approx(disp[-1, 1], rel=1e-5)  # played in the env it was taught in (the batched solver rounds otherwise)
    np.testing.assert_allclose(acts[:, 1], shift_phase_origin(np.array(raw), 0.5, 0.0), atol=1e-6)  # reported in default units


def test_the_shipped_teacher_field_counts_as_searched_with_the_shipped_config():
    import dataclasses

    from mdr_drive_agents.drive_field import DriveField

    root = Path(__file__).resolve().parents[1]
    field, config = DriveField.load(root / "results" / "recipe" / "teacher_field.npz"), recipe.load_recipe(
        root / "agents" / "configs" / "recipe.yaml")["teacher"]
    assert not recipe.searched_with_another_config(field, config)
    assert recipe.searched_with_another_config(field, dataclasses.replace(config, cycle_budget=701))
    assert recipe.searched_with_another_config(field, dataclasses.replace(config, friction=(0.3, 0.13)))
    older = DriveField(field.ks, field.fractions, field.trapezoid_critical, field.drives, field.velocities,
                       {"config": {key: value for key, value in json.loads(json.dumps(dataclasses.asdict(config))).items()
                                   if key not in ("friction", "refine_k")}})  # saved before those keys existed
    assert not recipe.searched_with_another_config(older, dataclasses.replace(config, refine_k=()))  # defaults count
    assert recipe.searched_with_another_config(older, config)


def test_the_student_seed_reaches_the_student_alone(recipe_run, tmp_path):
    import yaml
    from stable_baselines3 import PPO

    out, first = recipe_run
    config = yaml.safe_load(TINY.read_text())
    assert "student_seed" not in config and recipe.load_recipe(TINY)["student_seed"] == config["seed"]
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
    with pytest.raises(ValueError, match="student_sed.*student_seed \\(optional\\)"):
        recipe.load_recipe(tmp_path / "typo.yaml")


def _weights(policy_dir: Path) -> list[np.ndarray]:
    from stable_baselines3 import PPO

    return [x.detach().numpy() for x in PPO.load(policy_dir / "model.zip").policy.parameters()]


def test_an_interrupted_student_stage_resumes_after_its_first_fit_with_the_same_weights(recipe_run, tmp_path,
                                                                                        monkeypatch, capsys):
    import pickle

    import yaml

    from mdr_drive_agents import distill

    out, _ = recipe_run
    teacher = out / "teacher_field.npz"
    run = tmp_path / "run"

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    with monkeypatch.context() as m:  # Ctrl-C in the hole round, after the first fit and the DAgger round
        m.setattr(distill, "hole_round", interrupt)
        assert recipe.main([str(TINY), "--out", str(run), "--no-progress", "--teacher", str(teacher)]) == 130
    assert "first fit are kept" in capsys.readouterr().err
    saved = run / ".tasks" / "student_round0.pkl"
    assert saved.exists() and not (run / "policy").exists()
    fits = []
    real_fit = distill.fit
    monkeypatch.setattr(distill, "fit", lambda *a, **k: fits.append(a[3]) or real_fit(*a, **k))
    recipe.run(TINY, run, progress=False, resume=True, teacher=teacher)
    assert f"round 0 read from {saved}" in capsys.readouterr().out
    # the DAgger round and the hole round were fitted, round 0 was not
    tiny = recipe.load_recipe(TINY)["distill"]
    assert fits == [tiny.round_steps, tiny.hole_steps]
    assert not (run / ".tasks").exists()
    fits.clear()
    recipe.run(TINY, tmp_path / "whole", progress=False, teacher=teacher)  # (the fixture's policy is fine-tuned by
    assert fits == [tiny.steps, tiny.round_steps, tiny.hole_steps]      # another test: not the reference)
    for a, b in zip(_weights(run / "policy"), _weights(tmp_path / "whole" / "policy"), strict=True):
        np.testing.assert_array_equal(a, b)  # the resumed run's weights are the uninterrupted run's
    history = json.loads((run / "policy" / "run.json").read_text())["distilled_from"]["history"]
    assert [h.get("round", h.get("hole_round")) for h in history] == [0, 1, 1]

    # a checkpoint is used only for the round-0 settings and teacher it was fitted with
    config = yaml.safe_load(TINY.read_text())
    monkeypatch.setattr(distill, "hole_round", interrupt)
    assert recipe.main([str(TINY), "--out", str(run), "--no-progress", "--force", "--teacher", str(teacher)]) == 130
    capsys.readouterr()
    state = pickle.loads(saved.read_bytes())
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
    assert pickle.loads(saved.read_bytes())["fingerprint"]["distill"]["steps"] == 41 != state["fingerprint"]["distill"]["steps"]
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
    with pytest.raises(ValueError, match="jump_threshold"):
        DistillConfig(jump_threshold=0.0)
    with pytest.raises(ValueError, match="polish"):
        FieldConfig(polish=((0, 0.1),))
    with pytest.raises(ValueError, match="polish"):
        FieldConfig(polish=((10, 0.1, 3),))


def _synthetic_field(nk=4, ns=5):
    from mdr_drive_agents.drive_field import DriveField

    rng = np.random.default_rng(0)
    drives = np.clip(rng.normal(0.5, 0.3, (nk, ns, 2, 5)), -1.0, 1.0)
    return DriveField(np.linspace(0.0, 0.6, nk), np.linspace(0.0, 1.2, ns), np.full(nk, 0.05), drives,
                      np.zeros((nk, ns)))


def test_the_teachers_neighbourhood_grows_with_its_radius_and_stays_on_the_grid():
    field = _synthetic_field()
    inside, corner = (0.3, 0.03), (0.0, 0.0)  # a cell in the middle of the grid; the grid's first cell
    assert len(field.candidates(*inside)) == 5  # the interpolation and the cell's four corners
    assert len(field.candidates(*inside, radius=2)) == 1 + 16
    assert len(field.candidates(*corner, radius=2)) == 1 + 9  # nodes past the grid's edge left out
    first = field.candidates(*inside)
    assert np.array_equal(field.candidates(*inside, radius=2)[:5], first)  # the same five first
    with pytest.raises(ValueError, match="radius"):
        field.best([inside], radius=0)
    with pytest.raises(ValueError, match="teacher_radius"):
        DistillConfig(teacher_radius=0)


def test_polish_searches_from_each_node_and_its_distinct_neighbours_and_keeps_only_gains(monkeypatch):
    from mdr_drive_agents import field_search
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=3, ns=3)
    field.drives[1, 2] = field.drives[1, 1]  # a neighbour with the node's own drive is not a second start
    field.velocities[:] = 0.01
    seen = {}

    def fake_slice(args):  # a stand-in search: node (1, 1) finds a faster drive, (0, 0) a slower one
        nodes, budget, sigma, *_ = args
        out = []
        for k, load, starts in nodes:
            i = int(np.argmin(np.abs(field.ks - k)))
            j = int(np.argmin(np.abs(field.fractions * field.trapezoid_critical[i] - load)))
            seen[(i, j)] = len(starts)
            assert np.array_equal(starts[0], field.drives[i, j]) and (budget, sigma) == (8, 0.1)
            out.append((np.full((2, 5), 0.3), {(1, 1): 0.02, (0, 0): 0.005}.get((i, j), 0.01)))
        return out

    monkeypatch.setattr(field_search, "polish_slice", fake_slice)
    assert field.polish(8, 0.1, executor=Executor(workers=1, progress=False)) == 1
    assert len(seen) == 9 and seen[(0, 0)] == 3 and seen[(1, 0)] == 4 and seen[(1, 1)] == 4  # itself + its distinct neighbours
    assert field.velocities[1, 1] == 0.02 and np.all(field.drives[1, 1] == 0.3)
    assert field.velocities[0, 0] == 0.01 and not np.all(field.drives[0, 0] == 0.3)  # a slower drive is not taken
    assert field.meta["polished"] == [{"budget": 8, "sigma": 0.1, "changed": 1}]


def test_polishing_one_node_per_task_finds_what_one_line_per_task_finds():
    from mdr_drive_agents.field_search import map_polish_by_node, polish_slice
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=2, ns=3)
    field.trapezoid_critical[:] = 0.02
    lines = [([(*field.point(i, j)[:2], field.drives[i, j:j + 2]) for j in range(2)], 16, 0.2, 7 + 100 * i,
              field.friction) for i in range(2)]
    by_line = [polish_slice(task) for task in lines]
    by_node = map_polish_by_node(lines, "test", Executor(workers=2, progress=False))
    assert [len(line) for line in by_node] == [2, 2]
    for line_a, line_b in zip(by_line, by_node):
        for (drive_a, v_a), (drive_b, v_b) in zip(line_a, line_b):
            assert np.array_equal(drive_a, drive_b) and v_a == v_b  # the same seeds: the same drives, bit for bit


def test_a_polished_node_plays_at_the_velocity_it_records():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=2, ns=2)
    field.trapezoid_critical[:] = 0.02
    points = [field.point(i, j) for i in range(2) for j in range(2)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(4, 2, 5)).reshape(2, 2)
    before = field.velocities.copy()
    field.polish(32, 0.2, executor=Executor(workers=1, progress=False))
    assert np.all(field.velocities >= before)
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(4, 2, 5)), field.velocities.ravel())


def test_refine_k_adds_a_k_line_between_every_two_and_plays_what_it_records(monkeypatch):
    from mdr_drive_agents import blind
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=2, ns=2)
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(2) for j in range(2)],
                                          field.drives.reshape(4, 2, 5)).reshape(2, 2)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    monkeypatch.setattr(blind, "trapezoid_critical", lambda ks: np.full(len(ks), 0.03))
    field.refine_k(8, 0.1, executor=Executor(workers=1, progress=False))
    assert np.allclose(field.ks, [0.0, 0.3, 0.6]) and field.velocities.shape == (3, 2)
    assert np.allclose(field.trapezoid_critical, [0.02, 0.03, 0.02])
    assert np.array_equal(field.drives[::2], old_drives) and np.array_equal(field.velocities[::2], old_velocities)
    points = [field.point(1, j) for j in range(2)]  # the new nodes, at the new line's critical load
    assert np.allclose(open_loop_velocity(points, field.drives[1]), field.velocities[1])
    for j in range(2):  # never slower than a drive it started from: the k neighbours' drives
        started = open_loop_velocity([points[j]] * 2, old_drives[:, j])
        assert field.velocities[1, j] >= started.max() - 1e-12
    assert field.meta["refined_k"] == {"budget": 8, "sigma": 0.1, "k_max": None, "new_nodes": 2}
    assert field.refine_k(8, 0.1, executor=Executor(workers=1, progress=False), k_max=0.2) == 2  # only below k_max
    assert np.allclose(field.ks, [0.0, 0.15, 0.3, 0.6]) and field.drives.shape == (4, 2, 2, 5)
    assert np.allclose(field.trapezoid_critical, [0.02, 0.03, 0.03, 0.02])
    assert field.refine_k(8, 0.1, k_max=0.01) == 0 and len(field.ks) == 4
    with pytest.raises(ValueError, match="refine_k"):
        FieldConfig(refine_k=(0, 0.1))
    with pytest.raises(ValueError, match="refine_k"):
        FieldConfig(refine_k=(10,))
    with pytest.raises(ValueError, match="refine_k k_max"):
        FieldConfig(refine_k=(10, 0.1, 0.9))  # outside k_range


def test_refine_load_adds_load_lines_in_its_band_and_plays_what_it_records():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=2, ns=3)  # fractions 0, 0.6, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(2) for j in range(3)],
                                          field.drives.reshape(6, 2, 5)).reshape(2, 3)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    assert field.refine_load(8, 0.1, (0.5, 1.0), executor=Executor(workers=1, progress=False)) == 2  # 0.9 only
    assert np.allclose(field.fractions, [0.0, 0.6, 0.9, 1.2]) and field.velocities.shape == (2, 4)
    assert np.array_equal(field.drives[:, [0, 1, 3]], old_drives)
    assert np.array_equal(field.velocities[:, [0, 1, 3]], old_velocities)
    points = [field.point(i, 2) for i in range(2)]  # the new nodes, at 0.9 of the critical load
    assert np.isclose(points[0][1], 0.9 * 0.02)
    assert np.allclose(open_loop_velocity(points, field.drives[:, 2]), field.velocities[:, 2])
    for i in range(2):  # never slower than a drive it started from: the lighter and heavier neighbours'
        started = open_loop_velocity([points[i]] * 2, old_drives[i, 1:])
        assert field.velocities[i, 2] >= started.max() - 1e-12
    assert field.meta["refined_load"] == {"budget": 8, "sigma": 0.1, "band": [0.5, 1.0], "k_max": None,
                                          "new_nodes": 2, "searched": 2}
    i, j, _, ws = field._cell(0.0, 0.95 * 0.02)  # queries read the uneven fractions
    assert j == 2 and np.isclose(ws, (0.95 - 0.9) / 0.3)
    assert field.refine_load(8, 0.1, (1.3, 1.4)) == 0
    # above k_max the new nodes are not searched: each keeps its lighter or heavier neighbour's drive
    assert field.refine_load(8, 0.1, (0.7, 0.8), executor=Executor(workers=1, progress=False), k_max=0.3) == 1
    assert np.allclose(field.fractions, [0.0, 0.6, 0.75, 0.9, 1.2])
    upper = field.point(1, 2)
    neighbours = open_loop_velocity([upper] * 2, field.drives[1, [1, 3]])
    assert any(np.array_equal(field.drives[1, 2], align_phase(field.drives[1, b], field.drives[1, 1])) for b in (1, 3))
    assert np.isclose(field.velocities[1, 2], neighbours.max())
    assert field.meta["refined_load"]["searched"] == 1 and field.meta["refined_load"]["new_nodes"] == 2
    for bad, match in (((0, 0.1, 0.5, 1.0), "refine_load budget"), ((10, 0.1, 0.5), "refine_load"),
                       ((10, 0.1, 1.0, 0.5), "refine_load high"), ((10, 0.1, 0.5, 9.0), "refine_load high"),
                       ((10, 0.1, 0.5, 1.0, 0.9), "refine_load k_max")):
        with pytest.raises(ValueError, match=match):
            FieldConfig(refine_load=bad)


def test_refine_steep_adds_load_lines_only_where_the_velocity_falls_steeply():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=2, ns=4)  # fractions 0, 0.4, 0.8, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = np.array([[9e-3, 8e-3, 2e-3, -5e-3],    # falls by 6 mm/s from 0.4 to 0.8, then to a stall
                                 [9e-3, 7e-3, 5e-3, -1e-3]])   # 2 mm/s, then 5 (backwards counts as a stop)
    assert np.allclose(field.velocity_drops(), [[1e-3, 6e-3, 2e-3], [2e-3, 2e-3, 5e-3]])
    ex = Executor(workers=1, progress=False)
    # 0.2 (1 and 2 mm/s) and 1.0 (5 mm/s, not more) stay cells; 0.6 falls by more than 5 on line 0
    assert field.refine_load(8, 0.1, (0.1, 1.1), executor=ex, min_drop=5e-3, record="refined_steep") == 2
    assert np.allclose(field.fractions, [0.0, 0.4, 0.6, 0.8, 1.2])
    assert field.meta["refined_steep"] == {"budget": 8, "sigma": 0.1, "band": [0.1, 1.1], "k_max": None,
                                           "min_drop": 5e-3, "fractions": [0.6], "new_nodes": 2, "searched": 2}
    assert "refined_load" not in field.meta
    assert np.allclose(open_loop_velocity([field.point(i, 2) for i in range(2)], field.drives[:, 2]),
                       field.velocities[:, 2])
    before = field.fractions.copy()
    assert field.refine_load(8, 0.1, (0.1, 1.1), executor=ex, min_drop=0.05, record="refined_steep") == 0
    assert np.array_equal(field.fractions, before)
    for bad, match in (((300, 0.1, 0.6, 1.5), "refine_steep"), ((0, 0.1, 0.6, 1.5, 0.005), "refine_steep budget"),
                       ((300, 0.1, 1.0, 0.6, 0.005), "refine_steep high"), ((300, 0.1, 0.6, 1.2, 0.0), "refine_steep drop"),
                       ((300, 0.1, 0.6, 1.2, 5.0), "refine_steep drop")):
        with pytest.raises(ValueError, match=match):
            FieldConfig(refine_steep=bad)


def test_polish_stall_searches_the_nodes_either_side_of_each_stall_and_plays_what_it_records():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=3, ns=4)
    field.velocities[:] = [[3.0, 2.0, 1.0, -1.0],   # moves up to node 2: nodes 2 and 3
                           [-1.0, -2.0, -3.0, -4.0],  # moves nowhere: the lightest and the next
                           [3.0, -1.0, 2.0, 1.0]]     # moves at the heaviest: the two heaviest
    assert field.stall_nodes() == [(0, 2), (0, 3), (1, 0), (1, 1), (2, 2), (2, 3)]
    assert field.stall_nodes(k_max=0.3) == [(0, 2), (0, 3), (1, 0), (1, 1)]  # k lines 0, 0.3, 0.6
    field.trapezoid_critical[:] = 0.02
    points = [field.point(i, j) for i in range(3) for j in range(4)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(12, 2, 5)).reshape(3, 4)
    before_d, before_v = field.drives.copy(), field.velocities.copy()
    stall = field.stall_nodes()
    changed = field.polish_stall(8, 0.1, executor=Executor(workers=1, progress=False))
    assert field.meta["polished_stall"] == {"budget": 8, "sigma": 0.1, "k_max": None, "nodes": len(stall),
                                            "changed": changed}
    untouched = [(i, j) for i in range(3) for j in range(4) if (i, j) not in stall]
    for i, j in untouched:  # only the stall nodes search
        assert np.array_equal(field.drives[i, j], before_d[i, j]) and field.velocities[i, j] == before_v[i, j]
    assert np.all(field.velocities >= before_v) and changed == int((field.velocities > before_v).sum())
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(12, 2, 5)), field.velocities.ravel())
    for bad, match in (((0, 0.1), "polish_stall budget"), ((10, 0.0), "polish_stall sigma"), ((10,), "polish_stall"),
                       ((10, 0.1, 0.7), "polish_stall k_max")):
        with pytest.raises(ValueError, match=match):
            FieldConfig(polish_stall=bad)


def test_polish_band_searches_the_nodes_of_its_band_only_and_plays_what_it_records():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=3, ns=4)  # k 0, 0.3, 0.6; fractions 0, 0.4, 0.8, 1.2
    field.trapezoid_critical[:] = 0.02
    assert field.band_nodes((0.3, 0.6), (0.4, 0.8)) == [(1, 1), (1, 2), (2, 1), (2, 2)]
    assert field.band_nodes((0.1, 0.2), (0.0, 1.2)) == []
    points = [field.point(i, j) for i in range(3) for j in range(4)]
    field.velocities = open_loop_velocity(points, field.drives.reshape(12, 2, 5)).reshape(3, 4)
    before_d, before_v = field.drives.copy(), field.velocities.copy()
    band = field.band_nodes((0.3, 0.6), (0.4, 0.8))
    changed = field.polish_band(8, 0.1, (0.3, 0.6), (0.4, 0.8), executor=Executor(workers=1, progress=False))
    assert field.meta["polished_band"] == {"budget": 8, "sigma": 0.1, "k_band": [0.3, 0.6], "fraction_band": [0.4, 0.8],
                                           "starts": 2, "nodes": len(band), "changed": changed}
    for i, j in [(i, j) for i in range(3) for j in range(4) if (i, j) not in band]:
        assert np.array_equal(field.drives[i, j], before_d[i, j]) and field.velocities[i, j] == before_v[i, j]
    assert np.all(field.velocities >= before_v) and changed == int((field.velocities > before_v).sum())
    assert np.allclose(open_loop_velocity(points, field.drives.reshape(12, 2, 5)), field.velocities.ravel())
    assert field.polish_band(8, 0.1, (0.1, 0.2), (0.0, 1.2), executor=Executor(workers=1, progress=False)) == 0
    for bad, match in (((0, 0.1, 0.1, 0.3, 0.8, 1.4), "polish_band budget"), ((10, 0.0, 0.1, 0.3, 0.8, 1.4), "polish_band sigma"),
                       ((10, 0.1, 0.1, 0.3), "polish_band"), ((10, 0.1, 0.3, 0.1, 0.8, 1.4), "polish_band k_high"),
                       ((10, 0.1, 0.1, 0.7, 0.8, 1.4), "polish_band k_high"), ((10, 0.1, 0.1, 0.3, 0.8, 0.5), "polish_band high"),
                       ((10, 0.1, 0.1, 0.3, -0.1, 1.0), "polish_band low")):
        with pytest.raises(ValueError, match=match):
            FieldConfig(polish_band=bad)


def test_refine_band_searches_its_new_load_lines_in_its_k_band_only_and_from_the_bands_drives():
    from mdr_drive_agents.evaluate import open_loop_velocity
    from mdr_drive_env.sweep import Executor

    field = _synthetic_field(nk=4, ns=3)  # k 0, 0.2, 0.4, 0.6; fractions 0, 0.6, 1.2
    field.trapezoid_critical[:] = 0.02
    field.velocities = open_loop_velocity([field.point(i, j) for i in range(4) for j in range(3)],
                                          field.drives.reshape(12, 2, 5)).reshape(4, 3)
    old_drives, old_velocities = field.drives.copy(), field.velocities.copy()
    assert field.refine_band(8, 0.1, (0.2, 0.6), (0.5, 1.0), executor=Executor(workers=1, progress=False)) == 3
    assert np.allclose(field.fractions, [0.0, 0.6, 0.9, 1.2]) and field.velocities.shape == (4, 4)
    assert np.array_equal(field.drives[:, [0, 1, 3]], old_drives)  # the old nodes as they were
    assert np.array_equal(field.velocities[:, [0, 1, 3]], old_velocities)
    points = [field.point(i, 2) for i in range(4)]
    assert np.allclose(open_loop_velocity(points, field.drives[:, 2]), field.velocities[:, 2])
    # k = 0 lies outside the band: its new node keeps its lighter or heavier neighbour's drive
    assert np.isclose(field.velocities[0, 2], open_loop_velocity([points[0]] * 2, old_drives[0, 1:]).max())
    # a searched node is never slower than any drive of the band on its two load lines (wide trials),
    # here the node at k = 0.2 against the drives of k = 0.6, two k lines away
    far = open_loop_velocity([points[1]] * 2, old_drives[3, 1:])
    assert field.velocities[1, 2] >= far.max() - 1e-12
    for i in range(4):  # each new cycle in the phase closest to its lighter neighbour's
        assert np.array_equal(field.drives[i, 2], align_phase(field.drives[i, 2], field.drives[i, 1]))
    assert field.meta["refined_band"] == {"budget": 8, "sigma": 0.1, "band": [0.5, 1.0], "k_max": 0.6, "k_min": 0.2,
                                          "starts": 2, "wide_trials": True, "new_nodes": 4, "searched": 3}
    for bad, match in (((0, 0.1, 0.1, 0.3, 0.8, 1.4), "refine_band budget"), ((10, 0.1, 0.1, 0.3), "refine_band"),
                       ((10, 0.1, 0.3, 0.1, 0.8, 1.4), "refine_band k_high"),
                       ((10, 0.1, 0.1, 0.3, 0.8, 0.5), "refine_band high")):
        with pytest.raises(ValueError, match=match):
            FieldConfig(refine_band=bad)


def test_the_teachers_reach_in_load_can_differ_from_its_reach_in_k():
    from mdr_drive_agents.teacher_data import teacher_drives

    field = _synthetic_field(nk=6, ns=9)  # fractions 0, 0.15, ..., 1.2
    inside = (0.3, 0.6 * 0.05)  # the cell at k 0.24-0.36 and fractions 0.6-0.75
    assert len(field.candidates(*inside, radius=2, load_radius=3)) == 1 + 4 * 6
    assert len(field.candidates(*inside, radius=2, load_radius=2)) == len(field.candidates(*inside, radius=2))
    wide = field.candidates(*inside, radius=2, load_radius=3)
    assert all(any(np.array_equal(c, w) for w in wide) for c in field.candidates(*inside, radius=2))
    config = DistillConfig(teacher_radius=2, teacher_load_radius=3, quantum_centres=True, action_codebook=True)
    drives, _ = teacher_drives(field, [inside], config)
    assert any(np.array_equal(drives[0], w) for w in wide[1:])  # one of the grid's own drives
    with pytest.raises(ValueError, match="teacher_load_radius"):
        DistillConfig(teacher_load_radius=-1)


def test_the_raw_logit_cross_entropy_is_the_categoricals_and_needs_a_codebook():
    import torch
    from stable_baselines3 import PPO

    from mdr_drive_agents.student import policy_logits, policy_raw_logits

    table = np.random.default_rng(0).uniform(-1.0, 1.0, (7, 5))
    model = PPO("MlpPolicy", gym.make("MDRDrive-v0", action_codebook=table), device="cpu", seed=0)
    x = torch.as_tensor(np.random.default_rng(1).normal(size=(16, model.observation_space.shape[0])), dtype=torch.float32)
    labels = torch.as_tensor(np.arange(16) % 7)
    with torch.no_grad():
        raw, normalised = policy_raw_logits(model.policy, x), policy_logits(model.policy, x)
        assert not torch.allclose(raw, normalised)  # SB3 subtracts the log-sum-exp ...
        torch.testing.assert_close(torch.nn.functional.cross_entropy(raw, labels),  # ... the loss is the same
                                   torch.nn.functional.cross_entropy(normalised, labels))
    with pytest.raises(ValueError, match="raw_logits=true needs action_codebook=true"):
        DistillConfig(raw_logits=True)
    with pytest.raises(ValueError, match="raw_logits='yes' must be true or false"):
        DistillConfig(raw_logits="yes", action_codebook=True, quantum_centres=True)


def test_the_fits_logits_are_sb3s_categorical_logits_bit_for_bit_with_their_gradients():
    import torch
    from stable_baselines3 import PPO

    from mdr_drive_agents.student import policy_logits

    table = np.random.default_rng(0).uniform(-1.0, 1.0, (9, 5))
    x = torch.as_tensor(np.random.default_rng(1).normal(size=(32, 14)), dtype=torch.float32)
    labels = torch.as_tensor(np.arange(32) % 9)
    grads = []
    for logits_of in (policy_logits, lambda policy, obs: policy.get_distribution(obs).distribution.logits):
        model = PPO("MlpPolicy", gym.make("MDRDrive-v0", action_codebook=table), device="cpu", seed=0)
        logits = logits_of(model.policy, x)
        torch.nn.functional.cross_entropy(logits, labels).backward()
        grads.append((logits.detach(), [p.grad.clone() for p in model.policy.action_net.parameters()]
                      + [p.grad.clone() for p in model.policy.mlp_extractor.policy_net.parameters()]))
    (ours, our_grads), (sb3, sb3_grads) = grads
    assert torch.equal(ours, sb3)
    assert len(our_grads) == len(sb3_grads) and all(torch.equal(a, b) for a, b in zip(our_grads, sb3_grads))


def test_keeping_phases_leaves_the_nodes_a_stage_did_not_change_as_they_were():
    from mdr_drive_agents.drive_field import DriveField

    a, b = np.full(5, 0.5), np.full(5, -0.5)
    c, d = np.array([0.9, 0.9, -0.9, -0.9, 0.0]), np.array([-0.9, -0.9, 0.9, 0.9, 0.0])
    line = np.array([[a, b], [c, d], [c, d], [c, d]])  # a light drive, then a heavy family, aligned
    before = np.stack([line, line])

    def field_with(drives):
        return DriveField(np.array([0.0, 0.6]), np.linspace(0.0, 1.2, 4), np.full(2, 0.05), drives.copy(), np.zeros((2, 4)))

    field = field_with(before)
    field.align()
    assert np.array_equal(field.drives, before)
    # a stage gives node (0, 1) a new drive, closer to the light drive as written and to the heavy
    # family swapped: align's chain along the line then turns every heavier node's phase
    new = np.array([0.6 * a + 0.4 * d, 0.6 * b + 0.4 * c])
    changed = before.copy()
    changed[0, 1] = new
    chained = field_with(changed)
    chained.align()
    assert all(np.array_equal(chained.drives[0, j], before[0, j, ::-1]) for j in (2, 3))
    kept = field_with(changed)
    kept.keep_phases(before)
    untouched = [(i, j) for i in range(2) for j in range(4) if (i, j) != (0, 1)]
    assert all(np.array_equal(kept.drives[i, j], before[i, j]) for i, j in untouched)
    assert np.array_equal(kept.drives[0, 1], align_phase(new, before[0, 1]))  # the new drive, in its node's old phase
    with pytest.raises(ValueError, match="keep_phases"):
        kept.keep_phases(before[:1])


def test_a_wider_teacher_never_plays_a_slower_drive():
    field = _synthetic_field()
    points = [(0.25, 0.02), (0.45, 0.04)]
    _, narrow = field.best(points, prefer_interpolation=0.0)
    _, wide = field.best(points, prefer_interpolation=0.0, radius=2)
    assert np.all(wide >= narrow)


def test_the_imitation_error_script_compares_the_shipped_policy_with_its_teacher(capsys):
    import runpy

    root = Path(__file__).parents[1]
    main = runpy.run_path(str(root / "scripts" / "imitation_error.py"))["main"]
    assert main(["--n", "6", "--seed", "3", "--field", str(root / "results" / "recipe" / "teacher_field.npz"),
                 str(root / "agents" / "pretrained" / "ppo_generalist")]) == 0
    out = capsys.readouterr().out
    header, quantiles = out.splitlines()[:2]
    moving = int(header.split(", ")[1].split()[0])
    assert "6 points of seed 3" in header and 0 <= moving <= 6
    assert len(quantiles.split(":")[1].split("/")) == 4
    assert sum(int(line.split("|")[2]) for line in out.splitlines()[4:10]) == moving  # every point in one band


def test_the_quantum_check_counts_the_quanta_an_output_is_off_and_runs_on_the_shipped_policy(capsys):
    import runpy

    from mdr_drive_env.gym_envs.spaces import ActionMap

    root = Path(__file__).parents[1]
    script = runpy.run_path(str(root / "scripts" / "quantum_check.py"))
    amap = ActionMap()
    labels = amap.quantum_centre(np.random.default_rng(2).uniform(-0.9, 0.9, (50, 5)))
    rise = 2.0 / (amap.quanta * (amap.max_rise_fraction - amap.min_rise_fraction))
    width = np.array([0.0, rise, 0.0, rise, 2.0 / amap.quanta])  # one quantum per entry, action units
    assert np.array_equal(script["quanta_off"](labels + 0.45 * width, labels, amap), np.zeros((50, 3)))
    assert np.array_equal(script["quanta_off"](labels + 1.0 * width, labels, amap), np.ones((50, 3)))
    assert np.array_equal(script["quanta_off"](labels - 2.0 * width, labels, amap), 2 * np.ones((50, 3)))
    assert script["main"](["--points", "4", "--seed", "3", str(root / "agents" / "pretrained" / "ppo_generalist")]) == 0
    row = capsys.readouterr().out.splitlines()[-1]
    for cell in row.split("|")[2:5]:  # each entry's three shares add up to one
        assert sum(float(x) for x in cell.split("/")) == pytest.approx(1.0, abs=0.002)


def test_the_imitation_error_script_bands_the_failures_by_the_teachers_jump_near_each_point(capsys):
    import runpy

    root = Path(__file__).parents[1]
    script = runpy.run_path(str(root / "scripts" / "imitation_error.py"))
    assert script["main"](["--n", "6", "--seed", "3", "--label-spread",
                           str(root / "agents" / "pretrained" / "ppo_generalist")]) == 0
    lines = capsys.readouterr().out.splitlines()
    moving = int(lines[0].split(", ")[1].split()[0])
    start = next(i for i, line in enumerate(lines) if "jump near the point" in line)
    assert sum(int(line.split("|")[2]) for line in lines[start + 2:start + 6]) == moving
    from mdr_drive_agents.drive_field import DriveField

    field = _synthetic_field()
    points = [(0.25, 0.02), (0.45, 0.04)]
    drives, _ = field.best(points, radius=1)
    spread = script["label_spread"](field, points, drives, DistillConfig(teacher_radius=1))
    beside = [(0.24, 0.02), (0.26, 0.02), (0.25, 0.019), (0.25, 0.021)]
    others, _ = field.best(beside, radius=1)
    expected = max(min(np.abs(o - drives[0]).max(), np.abs(o - drives[0][::-1]).max()) for o in others)
    assert spread.shape == (2,) and spread[0] == pytest.approx(expected)
    uniform = DriveField(field.ks, field.fractions, field.trapezoid_critical,
                         np.broadcast_to(field.drives[0, 0], field.drives.shape), field.velocities)
    assert np.all(script["label_spread"](uniform, points, uniform.best(points)[0], DistillConfig(teacher_radius=1)) < 1e-12)  # one drive all around


def test_the_teacher_check_script_adds_the_per_point_best_of_several_policies(capsys):
    import runpy

    root = Path(__file__).parents[1]
    main = runpy.run_path(str(root / "scripts" / "teacher_check.py"))["main"]
    policies = [str(root / "agents" / "pretrained" / "ppo_generalist"),
                str(root / "agents" / "pretrained" / "ppo_sensor" / "teacher")]
    assert main(["--n", "6", "--seed", "3", "--scan-ks", "1", "--worst", *policies]) == 0
    out = capsys.readouterr().out
    rows = [line.split("|") for line in out.splitlines() if line.startswith("| ")][1:]
    assert [row[1].strip() for row in rows[:2]] == policies
    assert rows[2][1].strip().startswith("the best of these policies")
    under = [int(row[4]) for row in rows]
    assert under[2] <= min(under[:2])  # at each point the best of them is at least as fast as either
    means = [float(row[3].split("/")[0]) for row in rows]
    assert means[2] >= max(means[:2]) - 1e-12
    for path, row in zip(policies, rows):  # --worst lists every point under 0.85 or below the trapezoid
        listed = re.search(rf"\n{re.escape(path)}: (\d+) points under 0.85[^\n]*\n((?:  k = [^\n]*\n)*)", out)
        count = int(listed[1])
        assert int(row[4]) <= count <= int(row[4]) + int(row[2].split("(")[0])
        assert listed[2].count("  k = ") == count


def test_the_teacher_check_script_compares_critical_loads_with_the_best_cycles(capsys, monkeypatch):
    import runpy

    from mdr_drive_agents import blind

    root = Path(__file__).parents[1]
    # the best cycle's critical load: twice the trapezoid's (a stand-in for the CMA-ES bisection)
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: 2.0 * args[1])
    main = runpy.run_path(str(root / "scripts" / "teacher_check.py"))["main"]
    policy = str(root / "agents" / "pretrained" / "ppo_generalist")
    assert main(["--n", "4", "--seed", "3", "--scan-ks", "2", "--cycle-scan", "--workers", "1", policy]) == 0
    out = capsys.readouterr().out
    assert "the cycle's over the trapezoid's: 2.00-2.00" in out
    rows = [line.split("|") for line in out.split("Critical load over the best")[1].splitlines() if line.startswith("| ")]
    assert [row[1].strip() for row in rows[1:]] == ["the teacher", policy]
    first_table = out.split("Critical load over the best")[0]
    trapezoid_ratio = next(float(line.split("|")[6]) for line in first_table.splitlines() if line.startswith(f"| {policy}"))
    assert float(rows[2][2].split()[0]) == pytest.approx(trapezoid_ratio / 2.0, abs=0.01)  # half its min over the trapezoid's
    assert f"{policy}: under 0.97 of the best cycle's: 0." in out  # at half the best cycle's, every k is listed


def test_the_teacher_check_scan_draws_k_in_its_range_and_keeps_the_cycle_scan(capsys, monkeypatch, tmp_path):
    import runpy

    from mdr_drive_agents import blind

    root = Path(__file__).parents[1]
    calls = []
    monkeypatch.setattr(blind, "cycle_scan_task", lambda args: calls.append(args[0]) or 2.0 * args[1])
    main = runpy.run_path(str(root / "scripts" / "teacher_check.py"))["main"]
    policy = str(root / "agents" / "pretrained" / "ppo_generalist")
    scan = tmp_path / "scan.json"
    args = ["--n", "2", "--seed", "3", "--scan-ks", "2", "--scan-range", "0.1", "0.2", "--scan-seed", "5",
            "--cycle-scan", "--cycle-scan-file", str(scan), "--workers", "1", policy]
    assert main(args) == 0
    stored = json.loads(scan.read_text())
    offsets = np.random.default_rng(5).uniform(size=2)
    assert stored["k"] == calls == [round(0.1 + (i + offsets[i]) * 0.05, 6) for i in range(2)]  # one drawn k per cell
    assert stored["best_cycle_kg"] == pytest.approx([2.0 * t for t in stored["trapezoid_kg"]])
    capsys.readouterr()
    assert main(args) == 0 and len(calls) == 2  # read back, not searched again
    assert f"read from {scan}" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="another scan's k"):  # a file of other k values is not overwritten
        main([a if a != "5" else "6" for a in args])
    with pytest.raises(SystemExit):
        main(["--n", "2", "--seed", "3", "--scan-range", "0.3", "0.2", policy])
    with pytest.raises(SystemExit):  # a scan file without the scan it keeps
        main(["--n", "2", "--seed", "3", "--cycle-scan-file", str(scan), policy])


def test_the_huber_loss_fits_one_of_two_conflicting_drives_where_the_squared_error_blends_them():
    import torch

    from mdr_drive_agents.student import edge_loss

    near, far = torch.tensor([[0.02, -0.03]]), torch.tensor([[0.5, -0.8]])
    zero = torch.zeros(1, 2)
    assert float(edge_loss(near, zero, 0.05)) == pytest.approx(float(edge_loss(near, zero)))  # squared within delta
    assert float(edge_loss(far, zero, 0.05)) == pytest.approx(0.05 * ((0.5 - 0.025) + (0.8 - 0.025)))  # linear beyond
    assert float(edge_loss(torch.tensor([[1.3]]), torch.tensor([[1.0]]), 0.05)) == 0.0  # past the box's edge: free
    # one output, three samples labelled with one drive's entry (0.2) and two with another's (0.9)
    labels = torch.tensor([[0.2], [0.2], [0.2], [0.9], [0.9]])
    fitted = {}
    for delta in (0.0, 0.05):
        x = torch.zeros(1, 1, requires_grad=True)
        opt = torch.optim.Adam([x], lr=0.01)
        for _ in range(3000):
            opt.zero_grad()
            edge_loss(x.expand(5, 1), labels, delta).backward()
            opt.step()
        fitted[delta] = float(x.detach())
    assert fitted[0.0] == pytest.approx(0.48, abs=0.01)  # the mean: a blend of the two
    # the median, up to the pull of the outvoted labels (2 x delta each) on the quadratic part (3 x 2 (x - 0.2)):
    assert fitted[0.05] == pytest.approx(0.2 + 2 * 0.05 / 3, abs=0.005)  # within delta of the majority's drive


class _StepTeacher:
    """A stand-in teacher whose drive jumps from A to B at k = 0.3 (one cycle phase of B swapped:
    the comparison must not count the phase as a jump), and a constant one."""

    ks, trapezoid_critical = np.array([0.0, 0.6]), np.array([0.1, 0.1])
    A = np.array([[0.9, 0.1, 1.0, -0.2, 0.5], [0.8, 0.3, 1.0, -0.1, 0.4]])
    B = np.array([[-0.6, -0.9, 1.0, -1.0, 0.9], [1.0, 0.9, 1.0, 0.0, 1.0]])

    def __init__(self, jump=True):
        self.jump, self.calls = jump, 0

    def best(self, points, radius=1):
        self.calls += 1
        k = np.array([p[0] for p in points])
        b = np.where(np.arange(len(k)) % 2 == 0, 1, 0)  # every other B written in the swapped phase
        drives = np.where(((k >= 0.3) & self.jump)[:, None, None], np.where(b[:, None, None], self.B, self.B[::-1]), self.A)
        return drives, np.zeros(len(k))


def test_a_student_in_a_finer_time_quantum_env_is_played_and_probed_there():
    from mdr_drive_agents.distill import DistillConfig, student_velocity
    from mdr_drive_agents.student import make_student
    from mdr_drive_agents.teacher_data import rollout

    student = make_student(DistillConfig(net_arch=(8,)), 0, {"time_quantum": 5e-6}, {"n_envs": 2, "n_steps": 8, "batch_size": 16})
    assert student.time_quantum == 5e-6
    assert student.venv.venv.get_attr("action_map")[0].time_quantum == 5e-6
    on = np.array([0.5, 0.2 + 2.0 / 180, 0.8, 0.1, 0.3])
    off = on + np.array([0.0, 0.8 / 180, 0.0, 0.0, 0.0])  # 0.4 of a 10 us rise quantum: a 5 us one apart
    point = [(0.2, 0.1)]
    coarse = [rollout(point, np.zeros((1, 2, 5)), lambda obs, a=a: a[None], 6)[2] for a in (on, off)]
    fine = [rollout(point, np.zeros((1, 2, 5)), lambda obs, a=a: a[None], 6, time_quantum=5e-6)[2] for a in (on, off)]
    np.testing.assert_array_equal(coarse[0], coarse[1])
    assert not np.array_equal(fine[0], fine[1])
    student.act = lambda obs: np.tile(off, (len(obs), 1))  # the hole round measures it in its own env
    np.testing.assert_allclose(student_velocity(student, point)[0],
                               rollout(point, np.zeros((1, 2, 5)), student.act, 30, time_quantum=5e-6)[2][-10:].mean() / 2e-3)


def test_a_fit_runs_its_first_steps_in_bfloat16_and_the_rest_in_float32():
    import torch

    from mdr_drive_agents.student import adam_fit

    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(3, 32), torch.nn.ReLU(), torch.nn.Linear(32, 1))
    x = torch.randn(512, 3)
    y = (x[:, :1] > 0).float()
    dtypes = []

    def loss_of(idx):
        out = net(x[idx])
        dtypes.append(out.dtype)
        return torch.mean((out.float() - y[idx]) ** 2)

    first = float(torch.mean((net(x) - y) ** 2))
    last = adam_fit(net.parameters(), lambda: (len(x), loss_of), 40, 64, 1e-2, 0, "test", progress=False,
                    bf16_share=0.75, fused=True)
    assert dtypes == [torch.bfloat16] * 30 + [torch.float32] * 10
    assert all(p.dtype == torch.float32 for p in net.parameters())  # the weights stay float32
    assert last < first


def test_drive_difference_compares_cycles_in_their_closest_phase():
    from mdr_drive_agents.teacher_data import drive_difference

    A, B = _StepTeacher.A[None], _StepTeacher.B[None]
    assert drive_difference(B, B[:, ::-1])[0] == 0.0
    # align_phase pair by pair: each drive in the cycle phase of its own reference
    pairs = np.concatenate([B[:, ::-1], A, A[:, ::-1]])
    assert np.array_equal(align_phase(pairs, np.concatenate([B, A, A])), np.concatenate([B, A, A]))
    assert drive_difference(A, A + 0.05)[0] == pytest.approx(0.05)
    assert drive_difference(A, B)[0] == pytest.approx(np.abs(_StepTeacher.A - _StepTeacher.B).max())


def test_jump_points_bisect_towards_where_the_teachers_drive_jumps():
    from mdr_drive_agents.teacher_data import drive_difference, jump_points

    rng = np.random.default_rng(3)
    points = [(float(k), float(m)) for k, m in zip(rng.uniform(0.0, 0.6, 400), rng.uniform(0.0, 0.17, 400))]
    teacher = _StepTeacher()
    drives, _ = teacher.best(points)
    config = DistillConfig(jump_levels=3, jump_neighbours=6, load_factor=1.7)
    new_points, new_drives = jump_points(teacher, points, drives, config)
    assert teacher.calls == 1 + 3 and len(new_points) == len(new_drives) > 0
    # the pairs that straddle k = 0.3, in the nearest-neighbour graph, as the bisection's brackets
    ks = np.array([p[0] for p in points])
    widest = max(abs(a - b) for a in ks for b in ks if (a < 0.3) != (b < 0.3) and abs(a - b) < 0.1)
    new_k = np.array([p[0] for p in new_points])
    assert np.all(np.abs(new_k - 0.3) <= widest / 2 + 1e-12)  # every midpoint is inside a straddling pair
    assert (new_k < 0.3).any() and (new_k >= 0.3).any()  # on both sides
    # the last level's points are 4 times closer to the jump than the first's
    assert np.median(np.abs(new_k[-len(new_k) // 4:] - 0.3)) < np.median(np.abs(new_k[:len(new_k) // 4] - 0.3)) / 2
    expected, _ = _StepTeacher().best(new_points)
    assert np.array_equal(new_drives, expected)  # each added point carries the teacher's drive there
    assert drive_difference(drives[:1], drives[:1])[0] == 0.0
    # no jump: nothing is added and the teacher is not asked again
    flat = _StepTeacher(jump=False)
    none, none_drives = jump_points(flat, points, flat.best(points)[0], config)
    assert none == [] and none_drives.shape == (0, 2, 5) and flat.calls == 1


def test_jump_brackets_end_with_pairs_that_straddle_the_jump_closely_and_carry_its_two_drives():
    from mdr_drive_agents.teacher_data import drive_difference, jump_brackets, jump_points

    rng = np.random.default_rng(4)
    points = [(float(k), float(m)) for k, m in zip(rng.uniform(0.0, 0.6, 300), rng.uniform(0.0, 0.17, 300))]
    config = DistillConfig(jump_levels=4, jump_neighbours=6, load_factor=1.7)
    drives = _StepTeacher().best(points)[0]
    added, added_drives, (a, b, da, db) = jump_brackets(_StepTeacher(), points, drives, config)
    same, same_drives = jump_points(_StepTeacher(), points, drives, config)
    assert added == same and np.array_equal(added_drives, same_drives)  # jump_points is its first two
    assert len(a) == len(b) == len(da) == len(db) > 0
    assert np.all((a[:, 0] < 0.3) != (b[:, 0] < 0.3))  # every last bracket straddles the jump
    assert np.all(drive_difference(da, db) > config.jump_threshold)
    for ends, end_drives in ((a, da), (b, db)):  # each end carries its own drive (in either cycle phase)
        assert np.all(drive_difference(end_drives, _StepTeacher().best([tuple(x) for x in ends])[0]) == 0.0)
    # four levels halve the brackets four times: every last bracket is within 1/16 of a neighbour pair
    assert np.abs(a[:, 0] - b[:, 0]).max() <= 0.1 / 16 + 1e-12


def test_the_jump_bridges_script_counts_harmful_jumps_and_searches_bridges(capsys, tmp_path, monkeypatch):
    import runpy

    root = Path(__file__).parents[1]
    config = tmp_path / "recipe.yaml"
    text = (root / "agents" / "configs" / "recipe.yaml").read_text()
    config.write_text(text.replace("  points: 4096", "  points: 96").replace("  jump_levels: 5", "  jump_levels: 2"))
    main = runpy.run_path(str(root / "scripts" / "jump_bridges.py"))["main"]
    out = tmp_path / "bridges.md"
    args = ["--field", str(root / "results" / "recipe" / "teacher_field.npz"), "--config", str(config),
            "--samples", "2", "--iterations", "2", "--popsize", "4", "--out", str(out)]
    assert main(args) == 0
    report = capsys.readouterr().out
    assert report == out.read_text() and "Jump brackets of round 0" in report and "Bridges found:" in report
    with pytest.raises(SystemExit):  # an existing report is not overwritten silently
        main(args)
    assert "exists" in capsys.readouterr().err


def test_quantum_centres_label_the_student_with_the_teachers_waveforms_at_their_quanta_centres():
    from mdr_drive_agents.teacher_data import labelled_episodes
    from mdr_drive_agents.evaluate import ACTION_MAP

    points = [(0.1, 0.02), (0.4, 0.005)]
    teacher = _StepTeacher()
    drives = teacher.best(points)[0]
    _, plain = labelled_episodes(teacher, points, None, DistillConfig(periods=2), 0)
    _, centred = labelled_episodes(teacher, points, None, DistillConfig(periods=2, quantum_centres=True), 0)
    assert np.array_equal(plain, np.tile(drives, (2, 1, 1)))
    assert np.array_equal(centred, ACTION_MAP.quantum_centre(plain)) and not np.array_equal(centred, plain)
    same = ACTION_MAP.to_params_batch(plain.reshape(-1, 5)) == ACTION_MAP.to_params_batch(centred.reshape(-1, 5))
    assert same.all()


def test_the_teacher_check_script_scores_the_teacher_against_an_earlier_blind_search(capsys, tmp_path):
    import runpy

    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.recipe import DEFAULT_CONFIG, load_recipe

    root = Path(__file__).parents[1]
    field_path = root / "results" / "recipe" / "teacher_field.npz"
    points = [(0.1, 0.01), (0.3, 0.005), (0.5, 0.0)]
    from mdr_drive_agents.teacher_data import teacher_drives

    _, teacher = teacher_drives(DriveField.load(field_path), points, load_recipe(DEFAULT_CONFIG)["distill"])  # the script's teacher
    assert np.all(teacher >= 2e-3)
    best = teacher / np.array([1.0, 0.8, 0.5])  # the search beats the teacher by these fractions
    blind_json = tmp_path / "blind.json"
    blind_json.write_text(json.dumps({"seed": 5, "points": points, "best": [{"velocity": v} for v in best]}))
    main = runpy.run_path(str(root / "scripts" / "teacher_check.py"))["main"]
    policy = str(root / "agents" / "pretrained" / "ppo_generalist")
    assert main(["--n", "2", "--seed", "3", "--scan-ks", "1", "--field", str(field_path),
                 "--searched", str(blind_json), policy]) == 0
    out = capsys.readouterr().out
    assert "3 where the search moves >= 2 mm/s): fraction mean 0.767, min 0.500, 2 under 0.85" in out
    assert out.split("2 under 0.85")[1].splitlines()[1].startswith("  k = 0.5000")  # the worst point first
    assert "critical load" not in out.split("2 under 0.85")[1]  # the file has no scan

    # with a scan: the teacher's critical load over the stored best cycle's, the k under 0.97 named
    from mdr_drive_agents.evaluate import critical_loads_grid

    field, config = DriveField.load(field_path), load_recipe(DEFAULT_CONFIG)["distill"]
    ks = [0.2, 0.4]
    own = critical_loads_grid(ks, lambda pts: teacher_drives(field, pts, config)[1])
    scan = {"k": ks, "best cycle": [own[0.2], own[0.4] / 0.9], "trapezoid": [0.1, 0.01]}
    blind_json.write_text(json.dumps({"seed": 5, "points": points, "best": [{"velocity": v} for v in best],
                                      "critical_load_kg": scan}))
    assert main(["--n", "2", "--seed", "3", "--scan-ks", "1", "--field", str(field_path),
                 "--searched", str(blind_json), policy]) == 0
    assert "best cycle's (2 k): min 0.900, 1 at >= 0.97; under it: 0.4 (0.900)" in capsys.readouterr().out


def test_the_load_line_script_marks_where_a_policy_stalls_and_the_teacher_moves(capsys):
    import runpy

    root = Path(__file__).parents[1]
    main = runpy.run_path(str(root / "scripts" / "load_line.py"))["main"]
    policy = str(root / "agents" / "pretrained" / "ppo_generalist")
    assert main(["--k", "0.5", "--from", "0.94", "--to", "0.96", "--loads", "5", "--labels", policy]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ")][1:]
    assert len(rows) == 5
    for row in rows:
        cells = [c.strip() for c in row.split("|")[1:-1]]
        teacher, student = float(cells[2]), float(cells[3])
        assert len(cells[4].split()) == 10  # the teacher's two actions
        assert row.endswith("<<") == (teacher > 0.0 and student <= 0.0)
    with pytest.raises(SystemExit):
        main(["--k", "0.9", policy])  # outside the field's k range
    with pytest.raises(SystemExit):
        main(["--k", "0.3", "--from", "1.0", "--to", "0.5"])


def test_a_hole_is_a_probe_short_of_the_teacher_by_the_share_and_the_floor(monkeypatch):
    from mdr_drive_agents import distill

    field = _synthetic_field()
    teacher = np.array([20e-3, 20e-3, 0.7e-3, 0.7e-3, 5e-3])
    student = np.array([17e-3, 19.5e-3, -0.02e-3, 0.65e-3, 4.4e-3])
    monkeypatch.setattr(field, "best", lambda points, radius=1: (np.zeros((len(points), 2, 5)), teacher))
    monkeypatch.setattr(distill, "student_velocity", lambda student_, points: student)

    def holes(floor):
        config = DistillConfig(hole_probes=5, hole_floor=floor)
        found, probe = distill.find_holes(None, field, config, np.random.default_rng(0))
        return probe["holes"]

    assert holes(1e-3) == 1  # 3 mm/s short of 20; a stall where the teacher moves at 0.7 mm/s is not seen
    assert holes(1e-4) == 3  # ... now it is, and 0.6 mm/s short of 5 too; 0.05 of 0.7 and 0.5 of 20 are not
    with pytest.raises(ValueError, match="hole_floor"):
        DistillConfig(hole_floor=-1e-3)



def test_stall_points_lie_in_their_band_around_the_zero_crossing_of_each_k_lines_velocity():
    from mdr_drive_agents.teacher_data import stall_fractions, stall_points

    field = _synthetic_field(nk=3, ns=4)  # fractions 0, 0.4, 0.8, 1.2; k lines 0, 0.3, 0.6
    field.trapezoid_critical[:] = [0.02, 0.04, 0.08]
    field.velocities[:] = [[3.0, 2.0, 1.0, -3.0],     # crosses zero a quarter of the way from 0.8 to 1.2
                           [-1.0, -2.0, -3.0, -4.0],  # moves nowhere
                           [3.0, 2.0, 2.0, 1.0]]      # moves everywhere: its heaviest fraction
    assert np.allclose(stall_fractions(field), [0.9, 0.0, 1.2])
    points = np.array(stall_points(field, 400, np.random.default_rng(1), (0.9, 1.0)))
    stall = np.interp(points[:, 0], field.ks, [0.9 * 0.02, 0.0, 1.2 * 0.08])
    assert np.all((points[:, 0] >= 0.0) & (points[:, 0] <= 0.6))
    assert np.all(points[:, 1] >= 0.9 * stall - 1e-15) and np.all(points[:, 1] <= stall + 1e-15)
    assert points[:, 1].max() > 0.95 * 1.2 * 0.08 * 0.95  # the band is filled, not one load


def test_at_a_stall_probe_a_student_that_stalls_where_the_teacher_crawls_is_a_hole(monkeypatch):
    from mdr_drive_agents import distill

    field = _synthetic_field()
    field.velocities[:] = np.linspace(1.0, -1.0, 5)  # every k line stalls halfway
    # 2 random probes, then 3 stall probes; the teacher crawls at 0.05 mm/s at the last four
    teacher = np.array([20e-3, 0.05e-3, 0.05e-3, 0.05e-3, -0.01e-3])
    student = np.array([20e-3, -0.01e-3, -0.01e-3, 0.04e-3, -0.02e-3])
    monkeypatch.setattr(field, "best", lambda points, radius=1: (np.zeros((len(points), 2, 5)), teacher[:len(points)]))
    monkeypatch.setattr(distill, "student_velocity", lambda student_, points: student[:len(points)])
    config = DistillConfig(hole_probes=2, hole_floor=1e-4, stall_probes=3)
    found, probe = distill.find_holes(None, field, config, np.random.default_rng(0))
    # the random probe 1 is no hole (0.06 mm/s under the floor); stall probe 2 is; 3 moves; 4: neither moves
    assert probe["probes"] == 5 and probe["holes"] == 1 and probe["stall_holes"] == 1 and len(found) == 1
    no_stall = distill.find_holes(None, field, DistillConfig(hole_probes=2, hole_floor=1e-4), np.random.default_rng(0))
    assert no_stall[1]["holes"] == 0 and "stall_holes" not in no_stall[1]
    for bad, match in (((1.0, 0.9), r"stall_band\[1\]"), ((0.0, 1.0), r"stall_band\[0\]"), ((0.9,), "stall_band")):
        with pytest.raises(ValueError, match=match):
            DistillConfig(stall_band=bad)
    with pytest.raises(ValueError, match="stall_probes"):
        DistillConfig(stall_probes=-1)
    with pytest.raises(ValueError, match="stall_probes"):
        distill.find_holes(None, field, config, np.random.default_rng(0), friction=((0.2, 0.4), (0.1, 0.2)))


def test_focus_points_add_round_0_episodes_in_their_k_band_and_leave_the_default_draw_unchanged(monkeypatch):
    from mdr_drive_agents import distill as distill_module
    from mdr_drive_agents.teacher_data import draw_points

    teacher = _StepTeacher()
    config = DistillConfig(load_factor=1.7, no_load_share=0.0)
    band = draw_points(teacher, 200, np.random.default_rng(1), config, k_range=(0.22, 0.32))
    ks = np.array([p[0] for p in band])
    assert ks.min() >= 0.22 and ks.max() <= 0.32 and ks.max() - ks.min() > 0.08
    loads = np.array([p[1] for p in band])
    assert loads.min() >= 0.0 and loads.max() <= 1.7 * 0.1 and loads.max() > 0.15  # loads drawn as for `points`
    clipped = draw_points(teacher, 50, np.random.default_rng(1), config, k_range=(0.5, 0.9))  # clipped to the field
    assert max(p[0] for p in clipped) <= 0.6
    with pytest.raises(ValueError, match=r"k range \[0.7, 0.9\] lies outside the teacher's k range \[0, 0.6\]"):
        draw_points(teacher, 5, np.random.default_rng(1), config, k_range=(0.7, 0.9))
    a = draw_points(teacher, 20, np.random.default_rng(2), config)
    assert a == draw_points(teacher, 20, np.random.default_rng(2), config, k_range=None)

    seen = []  # the points round 0 asks the teacher about
    real = distill_module.teacher_drives
    monkeypatch.setattr(distill_module, "teacher_drives", lambda f, pts, c: (seen.append(list(pts)), real(f, pts, c))[1])
    tiny = dict(net_arch=(8,), points=12, periods=2, steps=2, batch=8)
    hyper = {"n_envs": 2, "n_steps": 8, "batch_size": 16}
    plain = distill_module.distill(teacher, DistillConfig(**tiny), 0, hyperparameters=hyper, progress=False)
    focused = distill_module.distill(teacher, DistillConfig(**tiny, focus_points=6, focus_k=(0.22, 0.32)), 0,
                                     hyperparameters=hyper, progress=False)
    assert [len(s) for s in seen] == [12, 18]
    assert seen[1][:12] == seen[0]  # the uniform draw is the same; the band's points follow it
    assert all(0.22 <= p[0] <= 0.32 for p in seen[1][12:])
    assert plain.history[0]["samples"] == 12 * 2 and focused.history[0]["samples"] == 18 * 2
    inner = distill_module.distill(teacher, DistillConfig(**tiny, focus_points=6, focus_k=(0.22, 0.32),
                                                          inner_focus_points=4, inner_focus_k=(0.25, 0.27)), 0,
                                   hyperparameters=hyper, progress=False)
    assert len(seen[2]) == 22 and seen[2][:18] == seen[1]  # the second band's points follow the first's
    assert all(0.25 <= p[0] <= 0.27 for p in seen[2][18:]) and inner.history[0]["samples"] == 22 * 2
    for bad in ({"focus_k": (0.7, 0.9)}, {"inner_focus_points": 3, "inner_focus_k": (0.7, 0.9)}):
        with pytest.raises(ValueError, match="lies outside the teacher's k range"):  # before any work
            distill_module.distill(teacher, DistillConfig(**tiny, **{"focus_points": 6, **bad}), 0,
                                   hyperparameters=hyper, progress=False)
    assert len(seen) == 3


@pytest.mark.parametrize("bad, name", [({"focus_points": -1}, "focus_points"), ({"focus_k": (0.3, 0.2)}, "focus_k[1]"),
                                       ({"focus_k": (0.1,)}, "focus_k"), ({"focus_k": (-0.1, 0.2)}, "focus_k[0]"),
                                       ({"inner_focus_points": -1}, "inner_focus_points"),
                                       ({"inner_focus_k": (0.3, 0.2)}, "inner_focus_k[1]")])
def test_a_bad_focus_option_is_an_error_naming_it(bad, name):
    with pytest.raises(ValueError, match=re.escape(name)):
        DistillConfig(**bad)


def test_quantum_centres_must_be_a_boolean():
    with pytest.raises(ValueError, match=r"quantum_centres='yes' must be true or false"):
        DistillConfig(quantum_centres="yes")
    assert DistillConfig(quantum_centres=True).quantum_centres is True


def test_a_codebook_student_picks_the_teachers_grid_actions_and_loads_as_plain_sb3(recipe_run, tmp_path):
    import yaml
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from mdr_drive_agents.drive_field import DriveField
    from mdr_drive_agents.evaluate import Policy, policy_rollout, run_env_kwargs
    from mdr_drive_agents.teacher_data import grid_actions
    from mdr_drive_agents.train import train

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
    policy = Policy(folder)
    cargo = venv.envs[0].unwrapped.cargo_mass
    _, actions, _ = policy_rollout(policy, [(0.2, cargo)], periods=4)
    np.testing.assert_allclose(actions[:, 0], np.array(played), atol=1e-6)
    assert all(any(np.array_equal(a, row) for row in table) for a in played)

    # shipped: the table is copied, and the card's snippet (with the table) runs as written
    import re
    import subprocess
    import sys

    from mdr_drive_agents.model_card import ship

    card = ship(folder, tmp_path / "shipped").read_text()
    assert (tmp_path / "shipped" / "action_codebook.npy").exists() and f"Discrete({len(table)})" in card
    snippet = re.findall(r"```python\n(.*?)```", card, flags=re.S)[0]
    assert "action_codebook=" in snippet
    done = subprocess.run([sys.executable, "-c", snippet], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and "steady velocity" in done.stdout, done.stderr

    record = train(resume=folder, steps=64, progress_bar=False, eval_freq=10_000)  # fine-tunes over the indices
    assert record["resumes"] == 1 and record["env_kwargs"]["action_codebook"] == "action_codebook.npy"
    with pytest.raises(ValueError, match="quantum_centres"):
        DistillConfig(action_codebook=True)
    from mdr_drive_agents.distill import check_drawn_friction

    with pytest.raises(ValueError, match="action_codebook: not with a drawn friction"):  # a friction teacher's
        check_drawn_friction(DistillConfig(action_codebook=True, quantum_centres=True), friction_drawn=True)
