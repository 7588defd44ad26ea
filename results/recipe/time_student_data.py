"""The student stage's work outside the fit, timed phase by phase with the shipped teacher and the shipped
policy as the student: round 0's teacher labels (its random and focus points, the jump bisection, the teacher's
episodes) and the hole round's probes (the teacher and the student at 10,240 points). Prints each phase's wall
time and a digest of its output, so two versions of the code can be compared for speed and for equal results.
`PYTHONPATH=. python results/recipe/time_student_data.py OUT.json` (from the repository's root)."""
import hashlib, json, sys, time
sys.path.insert(0, ".")
import mdr_drive_env  # noqa: F401  first: it pins numpy's BLAS kernels (mdr_drive_env.blas)
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize
from agents.distill import find_holes
from agents.drive_field import DriveField
from agents.evaluate import TIME_QUANTUM
from agents.recipe import load_recipe
from agents.student import Student
from agents.teacher_data import draw_points, jump_points, labelled_episodes, teacher_drives
import gymnasium as gym

recipe = load_recipe("agents/configs/recipe.yaml")
config, seed = recipe["distill"], recipe["student_seed"]
field_ = DriveField.load("results/recipe/teacher_field.npz")
policy_dir = "agents/pretrained/ppo_generalist"
run = json.load(open(f"{policy_dir}/run.json"))
env_kwargs = run.get("env_kwargs", {})
venv = VecNormalize.load(f"{policy_dir}/vecnormalize.pkl", DummyVecEnv([lambda: gym.make("MDRDrive-v0", **env_kwargs)]))
student = Student(PPO.load(f"{policy_dir}/model.zip", device="cpu"), venv,
                  z_phase_origin=float(env_kwargs.get("z_phase_origin", 0.0)),
                  time_quantum=float(env_kwargs.get("time_quantum", TIME_QUANTUM)))


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


teacher_drives(field_, draw_points(field_, 64, np.random.default_rng(0), config), config)  # compile first
out, rng = {}, np.random.default_rng(seed)
t = time.perf_counter()
points = draw_points(field_, config.points, rng, config)
for n, band in config.focus_bands():
    points += draw_points(field_, n, rng, config, k_range=band)
drives, v = teacher_drives(field_, points, config)
out["round0_teacher_labels"] = {"s": time.perf_counter() - t, "n": len(points), "digest": digest(drives, v)}
t = time.perf_counter()
extra, extra_drives = jump_points(field_, points, drives, config)
out["round0_jump_bisection"] = {"s": time.perf_counter() - t, "n": len(extra), "digest": digest(extra_drives)}
t = time.perf_counter()
obs, sample_drives = labelled_episodes(field_, points + extra, None, config, seed, student.z_phase_origin,
                                       student.time_quantum, drives=np.concatenate([drives, extra_drives]))
out["round0_teacher_episodes"] = {"s": time.perf_counter() - t, "n": len(obs), "digest": digest(obs, sample_drives)}
t = time.perf_counter()
holes, probe = find_holes(student, field_, config, rng)
out["hole_probes"] = {"s": time.perf_counter() - t, "n": probe["probes"], "digest": digest(np.array(holes, float)),
                      "holes": probe["holes"]}
for name, r in out.items():
    print(f"{name}: {r['s']:.1f} s, {r['n']} points, digest {r['digest']}", flush=True)
print(f"total: {sum(r['s'] for r in out.values()):.1f} s")
with open(sys.argv[1], "w") as f:
    json.dump(out, f, indent=1)
