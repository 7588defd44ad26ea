"""The fast node solver against closed forms, the reference solver and its own batched path."""

import dataclasses
import os

import gymnasium as gym
import numpy as np
import pytest

from mdr_drive_env.bench_accuracy import (
    ACCURACY_KS,
    ACCURACY_MASSES,
    MAX_DEPTH,
    accuracy_report,
    accuracy_waveforms,
    grid_displacements,
)
from mdr_drive_env.core import (
    Contact,
    DriveParams,
    DriveSimulator,
    Numerics,
    Waveform,
    mindlin_tangential_force,
    normal_force_analytic,
    numerics_preset,
)
from mdr_drive_env.core import kernel as K
from mdr_drive_env.core.batch import BatchedDriveSimulator
from mdr_drive_env.core.fast_kernel import node_weights
from tests import DATA

REFERENCE = DATA / "reference_paper.npz"
FAST = numerics_preset("fast")


@pytest.mark.parametrize("k", [0.0, 0.3, 0.9])
@pytest.mark.parametrize("power", [1.0, 1.5, 2.0])
def test_node_weights_integrate_the_normal_force_exactly(k, power):
    g = 6e-6 * (np.arange(12) / 10.0) ** power
    w, left, _, _ = node_weights(g, k, 2.5e-3, 1.0)
    for last in (4, 10):  # contact ending exactly on a node: the sum is Eq. 8 with C_N = 1
        d = g[last]
        f = np.dot(w[:last], d - g[:last]) + left[last] * 0.0
        assert f == pytest.approx(normal_force_analytic(d, k, 2.5e-3, 1.0, 1.0), rel=1e-12)


@pytest.mark.parametrize("k", [0.0, 0.5])
def test_fast_solver_normal_force_is_eq8_at_every_step(k):
    sim = DriveSimulator(DriveParams.paper(k=k), FAST)
    r = sim.step(Waveform.paper(), record_every=1)
    p = sim.params
    exact = [normal_force_analytic(d, k, 2.5e-3, p.normal_stiffness_prefactor, 1.0) for d in r.trace[:, K.T_Z]]
    np.testing.assert_allclose(r.trace[:, K.T_FZ], exact, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("k", [0.0, 0.6])
def test_fast_solver_tangential_loading_converges_to_mindlin(k):
    params = dataclasses.replace(DriveParams.paper(k=k), drive=dataclasses.replace(DriveParams().drive,
                                                                                     slider_mass=1e30))
    depth, period = 4e-6, 1e-3
    lam = params.slip_ratio
    c_n, c_t = params.normal_stiffness_prefactor, params.tangential_stiffness_prefactor
    errors = []
    for nodes in (16, 64):
        sim = DriveSimulator(params, Numerics(1e-6, method="nodes", nodes=nodes), max_depth=depth * 1.05)
        r = sim.step_knots([0.0, period], [0.0, 1.2 * lam * depth], [0.0, period], [depth, depth], record_every=25)
        err = max(abs(row[K.T_FX] - mindlin_tangential_force(row[K.T_X], depth, k, 2.5e-3, c_n, c_t, 1.0, 0.3))
                  / (0.3 * row[K.T_FZ]) for row in r.trace)
        errors.append(err)
        assert r.trace[-1, K.T_FX] == pytest.approx(0.3 * r.trace[-1, K.T_FZ], rel=1e-12)  # full slip
    assert errors[1] < 5e-3 and errors[1] < errors[0]


def test_fast_solver_coulomb_bound_with_random_waveforms(rng):
    sim = DriveSimulator(DriveParams.paper(k=0.3, cargo_mass=0.05), FAST)
    _, wfs = accuracy_waveforms(6, seed=int(rng.integers(1 << 30)))
    for wf in wfs:
        tr = sim.step(wf, record_every=1).trace
        assert np.all(np.abs(tr[:, K.T_FX]) <= 0.3 * tr[:, K.T_FZ] * (1 + 1e-12) + 1e-300)


def test_base_stick_has_no_chatter():
    """Pressed indenter, fixed x, a load below mu1 F_z: the slider stays exactly at rest."""
    sim = DriveSimulator(DriveParams.paper(k=0.0, cargo_mass=0.5), FAST)  # F_m = 4.9 N < mu1 F_z ~ 8 N
    r = sim.step_knots([0.0, 2e-3], [0.0, 0.0], [0.0, 2e-3], [5e-6, 5e-6], record_every=1)
    assert 0.1 * r.trace[0, K.T_FZ] > 0.5 * 9.81
    assert np.all(r.trace[:, K.T_SLIDER_V] == 0.0) and np.all(r.trace[:, K.T_SLIDER_X] == 0.0)
    ref = DriveSimulator(DriveParams.paper(k=0.0, cargo_mass=0.5), "default")  # the paper's sgn(V) chatters
    tr = ref.step_knots([0.0, 2e-3], [0.0, 0.0], [0.0, 2e-3], [5e-6, 5e-6], record_every=1).trace
    assert np.any(tr[:, K.T_SLIDER_V] != 0.0)


def test_fast_solver_energy_balance():
    sim = DriveSimulator(DriveParams.paper(k=0.2, cargo_mass=0.1), FAST)
    tot = np.zeros(4)
    for wf in (Waveform.paper(), Waveform.paper(), Waveform(z_phase=0.25)):
        r = sim.step(wf)
        tot += [r.indenter_work_x, r.indenter_dissipation, r.base_dissipation, r.load_work]
    e_t, _ = sim.elastic_energy()
    residual = tot[0] - (sim.kinetic_energy() + e_t + tot[1] + tot[2] + tot[3])
    assert abs(residual / tot[0]) < 0.02


def test_reference_cache_matches_the_current_paper_preset():
    data = np.load(REFERENCE)
    actions, wfs = accuracy_waveforms()
    assert np.array_equal(data["actions"], actions)
    for ki, mi, wi in ((1, 2, 0), (3, 1, 7)):  # k = 0.2, m = 0.1 paper waveform; k = 0.5, m = 0.05 random
        sim = DriveSimulator(DriveParams.paper(k=ACCURACY_KS[ki], cargo_mass=ACCURACY_MASSES[mi]), "paper",
                             max_depth=MAX_DEPTH)
        d = [r.displacement for r in sim.run(wfs[wi], 3)]
        np.testing.assert_allclose(d, data["displacement"][ki, mi, wi, :3], rtol=1e-12, atol=1e-18)


def test_fast_solver_within_tolerance_of_the_paper_preset_on_the_grid():
    """max(0.15 um, 0.5 %) per period, 5 k x 5 loads x 21 waveforms x 10 periods (issue 4)."""
    data = np.load(REFERENCE)
    actions, _ = accuracy_waveforms()
    report = accuracy_report(grid_displacements(FAST, actions, workers=1, progress=False), data["displacement"])
    assert report["max_error_over_tolerance"] <= 1.0, report


def test_batched_solver_equals_single_simulators_bit_for_bit(rng):
    n = 6
    params = [DriveParams.paper(k=float(rng.uniform(0, 0.7)), cargo_mass=float(rng.uniform(0, 0.3))) for _ in range(n)]
    batch = BatchedDriveSimulator(n)
    for i, p in enumerate(params):
        batch.set_params(i, p)
    sims = [DriveSimulator(p, "fast") for p in params]
    for _ in range(4):
        wf = np.column_stack([rng.uniform(0, 30e-6, n), rng.integers(10, 190, n) * 1e-5, rng.uniform(0, 6e-6, n),
                              rng.integers(10, 190, n) * 1e-5, rng.integers(0, 200, n) / 200])
        out = batch.step(wf, 2e-3)
        for i, s in enumerate(sims):
            r = s.step_params(*wf[i], 2e-3)
            assert out[i, K.O_DISPLACEMENT] == r.displacement
            assert out[i, K.O_PEAK_FX] == r.peak_tangential_force


@pytest.mark.parametrize("num_threads", [1, 2])
def test_vector_env_equals_single_envs_across_autoresets(num_threads):
    n, kw = 3, dict(k=(0.0, 0.5), cargo_mass=(0.0, 0.3), max_periods=4)
    venv = gym.make_vec("MDRDrive-v0", num_envs=n, vectorization_mode="vector_entry_point", num_threads=num_threads,
                        **kw)
    singles = [gym.make("MDRDrive-v0", numerics="fast", **kw) for _ in range(n)]
    obs, _ = venv.reset(seed=5)
    np.testing.assert_array_equal(obs, [e.reset(seed=5 + i)[0] for i, e in enumerate(singles)])
    done = [False] * n
    rng = np.random.default_rng(1)
    for _ in range(10):
        a = rng.uniform(-1, 1, (n, 5)).astype(np.float32)
        o, r, te, tr, _ = venv.step(a)
        for i, e in enumerate(singles):
            if done[i]:  # NEXT_STEP autoreset: this step resets, reward 0
                so, sr, st = e.reset()[0], 0.0, False
            else:
                so, sr, _, st, _ = e.step(a[i])
            done[i] = st
            np.testing.assert_array_equal(o[i], so)
            assert r[i] == sr and tr[i] == st and not te[i]


def test_vector_env_rejects_the_grid_solver_and_bad_sizes():
    with pytest.raises(ValueError, match="fast solver"):
        gym.make_vec("MDRDrive-v0", num_envs=2, vectorization_mode="vector_entry_point", numerics="default")
    with pytest.raises(ValueError, match="num_envs"):
        gym.make_vec("MDRDrive-v0", num_envs=0, vectorization_mode="vector_entry_point")


def test_sb3_adapter_trains_and_reports_terminal_observations():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from mdr_drive_agents.vec_env import BatchedVecEnv

    venv = BatchedVecEnv(4, seed=0, max_periods=3)
    obs = venv.reset()
    assert obs.shape == (4, 14)
    for _ in range(3):
        obs, rewards, dones, infos = venv.step(np.zeros((4, 5), dtype=np.float32))
    assert dones.all() and all("terminal_observation" in i and i["TimeLimit.truncated"] for i in infos)
    assert np.all(obs[:, 13] == 0.0)  # already reset: episode fraction 0
    PPO("MlpPolicy", venv, n_steps=16, batch_size=32, verbose=0).learn(64)


def test_no_contact_base_stick_without_contact_force():
    """Without contact (z = 0) there is no base friction in the paper's model: the load pulls the slider back."""
    params = dataclasses.replace(DriveParams.paper(cargo_mass=0.1), contact=Contact())
    sim = DriveSimulator(params, FAST)
    r = sim.step_knots([0.0, 2e-3], [0.0, 0.0], [0.0, 2e-3], [0.0, 0.0])
    assert r.displacement == pytest.approx(-0.5 * 0.981 / 0.05 * 2e-3**2, rel=1e-9)


def test_batched_results_do_not_depend_on_the_thread_count(rng):
    from mdr_drive_env.core.batch import MAX_THREADS, MIN_DRIVES_PER_THREAD, BatchedDriveSimulator

    n = 5 * MIN_DRIVES_PER_THREAD + 1  # enough drives for up to 5 threads, in chunks of unequal size
    waveforms = np.column_stack([rng.uniform(0, 30e-6, n), rng.integers(5, 196, n) * 1e-5, rng.uniform(0, 6e-6, n),
                                 rng.integers(5, 196, n) * 1e-5, rng.integers(0, 200, n) / 200])
    outs = []
    for threads in (1, 2, 3, 5):  # more threads than this machine's cores too
        sim = BatchedDriveSimulator(n, num_threads=threads)
        for i in range(n):
            sim.set_params(i, DriveParams.paper(k=0.6 * i / n, cargo_mass=0.02 * (i % 4)))
        outs.append(np.array([sim.step(waveforms, 2e-3).copy() for _ in range(4)]))
    single = DriveSimulator(DriveParams.paper(k=0.6 * 7 / n, cargo_mass=0.02 * 3), "fast")
    for t in range(4):  # drive 7 of the batch is a single simulator with its waveform
        r = single.step_params(*waveforms[7], 2e-3)
        assert outs[-1][t, 7, K.O_DISPLACEMENT] == r.displacement
    for other in outs[1:]:
        np.testing.assert_array_equal(other, outs[0])
    with pytest.raises(ValueError, match="num_threads"):
        BatchedDriveSimulator(2, num_threads=0)
    with pytest.raises(ValueError, match="num_threads"):
        BatchedDriveSimulator(2, num_threads=MAX_THREADS + 1)


def test_copied_params_step_as_set_params_does_bit_for_bit(rng):
    """open_loop_displacements builds each distinct point's model once and copies it to the drives
    that share it (a search plays many drives at one point): the same results as setting each."""
    n = 6
    waveforms = np.column_stack([rng.uniform(0, 30e-6, n), rng.integers(5, 196, n) * 1e-5, rng.uniform(0, 6e-6, n),
                                 rng.integers(5, 196, n) * 1e-5, rng.integers(0, 200, n) / 200])
    models = [DriveParams.paper(k=0.3, cargo_mass=0.05), DriveParams.paper(k=0.45, cargo_mass=0.01)]
    set_each, copied = BatchedDriveSimulator(n), BatchedDriveSimulator(n)
    for i in range(n):
        set_each.set_params(i, models[i % 2])
    copied.set_params(0, models[0])
    copied.set_params(1, models[1])
    for i in range(2, n):
        copied.copy_params(i, i % 2)
    assert copied.params == set_each.params
    for _ in range(3):
        np.testing.assert_array_equal(copied.step(waveforms, 2e-3), set_each.step(waveforms, 2e-3))
    copied.copy_params(2, 1)  # a copy resets the drive, as set_params does
    assert copied.state[2].tolist() == [0.0] * len(copied.state[2]) and copied.params[2] is models[1]
    with pytest.raises(RuntimeError, match="drive 1 has no params"):
        BatchedDriveSimulator(2).copy_params(0, 1)


def test_batched_action_map_equals_the_scalar_one(rng):
    from mdr_drive_env.gym_envs.spaces import ActionMap

    amap = ActionMap(time_step=5e-6)
    actions = np.concatenate([rng.uniform(-1.3, 1.3, (2000, 5)), rng.integers(-2, 3, (500, 5)) / 2])
    scalar = np.array([[p.x_amplitude, p.x_rise_time, p.z_amplitude, p.z_rise_time, p.z_phase]
                       for p in (amap.to_params(a) for a in actions)])
    np.testing.assert_array_equal(amap.to_params_batch(actions), scalar)
    with pytest.raises(ValueError, match="not finite"):
        amap.to_params_batch(np.array([[0, 0, np.nan, 0, 0]]))


def _batch_displacements(_=None):
    from mdr_drive_env.core.batch import BatchedDriveSimulator

    sim = BatchedDriveSimulator(4)
    for i in range(4):
        sim.set_params(i, DriveParams.paper(k=0.1 * i, cargo_mass=0.05))
    return sim.step(np.tile([30e-6, 1.9e-3, 6e-6, 1.7e-3, 0.0], (4, 1)), 2e-3)[:, K.O_DISPLACEMENT].copy()


def test_processes_forked_after_a_parallel_batch_still_run_it():
    """The sweeps fork worker processes; a threading layer that is not fork-safe (GNU OpenMP) kills them."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    here = _batch_displacements()
    with ProcessPoolExecutor(2, mp_context=mp.get_context("fork")) as pool:
        for there in pool.map(_batch_displacements, range(2)):
            np.testing.assert_array_equal(there, here)


def _batched_displacements(n: int, threads: int) -> np.ndarray:
    from mdr_drive_env.core.batch import BatchedDriveSimulator

    sim = BatchedDriveSimulator(n, num_threads=threads)
    for i in range(n):
        sim.set_params(i, DriveParams.paper(k=0.05 * i, cargo_mass=0.01 * i))
    waveforms = np.tile([20e-6, 1.8e-3, 5e-6, 1.5e-3, 0.1], (n, 1))
    return np.array([sim.step(waveforms, 2e-3)[:, K.O_DISPLACEMENT].copy() for _ in range(3)])


def _batched_displacements_into(queue, n: int, threads: int) -> None:
    queue.put(_batched_displacements(n, threads))


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork()")
def test_batched_threads_work_in_a_forked_child():
    """The sweeps fork worker processes: a child forked after the parent used the helper threads steps
    the batched solver on threads of its own (with the parent's pool, whose threads the child does not
    have, it would wait forever)."""
    import multiprocessing
    import queue as queues

    n = 4 * 4
    here = _batched_displacements(n, 2)  # the parent's helper threads exist now
    ctx = multiprocessing.get_context("fork")
    results = ctx.Queue()
    child = ctx.Process(target=_batched_displacements_into, args=(results, n, 2))
    child.start()
    try:
        there = results.get(timeout=60)
    except queues.Empty:
        there = None
    child.join(5)
    if child.is_alive():
        child.kill()
    assert there is not None, "the forked child did not finish stepping the batched solver"
    np.testing.assert_array_equal(there, here)


def test_default_threads_honour_numba_num_threads(monkeypatch):
    """The Ray sweeps set NUMBA_NUM_THREADS=1 per task: the batched solver then uses one thread."""
    import numba

    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 1)
    from mdr_drive_env.core import batch

    assert batch.default_threads() == 1
    assert batch.BatchedDriveSimulator(4).num_threads == 1
