"""The sweep executor (mdr_drive_env/sweep.py): local processes and Ray give the serial results, lost
workers are replaced, interrupted sweeps resume without recomputing, bad addresses fail fast."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mdr_drive_env.sweep import Executor, TaskStore, check_ray_address

ray = pytest.importorskip("ray")
ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray workers get these task functions by value


def square_sim(task):
    """A real simulation task: the steady velocity of the trapezoid at (k, cargo mass)."""
    from mdr_drive_env.core import DriveParams, steady_velocity

    k, m = task
    return steady_velocity(DriveParams.paper(k=k, cargo_mass=m), rule="paper").velocity


def counted(task):
    """Appends its task to a log file (so a test can count runs), returns a pure function of the task."""
    value, log = task
    with open(log, "a") as f:
        f.write(f"{value}\n")
    if value == "stop":
        raise KeyboardInterrupt
    return np.sin(float(value)) * 1e3


def dies_once(task):
    """Kills its own worker process the first time task 3 runs (a marker file remembers)."""
    value, marker = task
    if value == 3 and not os.path.exists(marker):
        Path(marker).write_text("died")
        os._exit(1)
    return value * value


TASKS = [(k, m) for k in (0.0, 0.3) for m in (0.0, 0.1)]


@pytest.fixture(scope="module")
def serial():
    return Executor(workers=1, progress=False).map(square_sim, TASKS, "serial")


def test_local_processes_equal_serial(serial):
    assert Executor(workers=2, progress=False).map(square_sim, TASKS, "local") == serial


def batch_threads(_task):
    """The threads a batched simulator gets by default in the process that runs this task."""
    from mdr_drive_env.core import batch

    return batch.default_threads(), batch.BatchedDriveSimulator(16).num_threads


def test_local_workers_share_the_cores_among_their_batched_simulators():
    """Two workers on this machine's cores: each worker's batched simulators take its share (one
    thread each on two cores), and this process keeps its own default."""
    from mdr_drive_env.core import batch
    from mdr_drive_env.sweep import available_cores

    here = batch.default_threads()
    share = max(1, available_cores() // 2)
    assert Executor(workers=2, progress=False).map(batch_threads, [0, 1, 2], "threads") == [(share, share)] * 3
    assert batch.default_threads() == here
    with pytest.raises(ValueError, match=r"threads=0 is outside the allowed range \[1, 256\]"):
        batch.set_process_threads(0)


def test_local_pool_replaces_a_dead_worker(tmp_path):
    tasks = [(i, str(tmp_path / "marker")) for i in range(6)]
    assert Executor(workers=2, progress=False).map(dies_once, tasks, "local") == [i * i for i in range(6)]
    assert (tmp_path / "marker").exists()


def test_interrupted_sweep_resumes_without_recomputing(tmp_path):
    log = tmp_path / "log.txt"
    store = TaskStore(tmp_path / "tasks")
    tasks = [(v, str(log)) for v in ("0.1", "0.2", "stop", "0.4")]
    with pytest.raises(KeyboardInterrupt):
        Executor(workers=1, progress=False).map(counted, tasks, "first", store=store)
    assert log.read_text().split() == ["0.1", "0.2", "stop"]
    tasks[2] = ("0.3", str(log))  # the task that was stopped, now runnable (a new task: a new key)
    out = Executor(workers=1, progress=False).map(counted, tasks, "again", store=store)
    assert log.read_text().split() == ["0.1", "0.2", "stop", "0.3", "0.4"]  # only what was missing
    assert out == [np.sin(v) * 1e3 for v in (0.1, 0.2, 0.3, 0.4)]


def test_store_ignores_a_result_of_another_task(tmp_path):
    store = TaskStore(tmp_path)
    store.save(0, "key-a", 1.0)
    assert store.load(0, "key-a") == (True, 1.0)
    assert store.load(0, "key-b") == (False, None)
    assert store.load(1, "key-a") == (False, None)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_address_fails_fast():
    port = _free_port()
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=f"127.0.0.1:{port}"):
        check_ray_address(f"127.0.0.1:{port}")
    with pytest.raises(ValueError, match="HOST:PORT"):
        check_ray_address("not-an-address")
    assert time.perf_counter() - t0 < 10


def test_cli_unreachable_address_is_one_line_exit_2(tmp_path):
    port = _free_port()
    r = subprocess.run([sys.executable, "-m", "mdr_drive_env.cli", "reproduce", "--numerics", "fast", "--quick",
                        "--ray-address", f"127.0.0.1:{port}", "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and f"127.0.0.1:{port}" in r.stderr
    assert not (tmp_path / "out" / "fig5.csv").exists()


@pytest.mark.xdist_group("ray")
class TestRay:
    """One local Ray instance, then a two-node cluster on this machine."""

    def test_local_ray_equals_serial_and_retries_a_dead_worker(self, serial, tmp_path):
        ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            assert Executor(ray_address="auto", progress=False).map(square_sim, TASKS, "ray") == serial
            tasks = [(i, str(tmp_path / "marker")) for i in range(6)]
            assert Executor(ray_address="auto", progress=False).map(dies_once, tasks, "ray") == [i * i for i in range(6)]
            assert (tmp_path / "marker").exists()  # a worker did die, and its task ran again
        finally:
            ray.shutdown()

    def test_two_node_cluster_equals_serial(self, serial):
        from ray.cluster_utils import Cluster

        cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
        cluster.add_node(num_cpus=1)
        try:
            ray.init(address=cluster.address, log_to_driver=False)
            assert len([n for n in ray.nodes() if n["Alive"]]) == 2
            assert Executor(ray_address=cluster.address, progress=False).map(square_sim, TASKS, "cluster") == serial
        finally:
            ray.shutdown()
            cluster.shutdown()

    def test_cli_reproduce_on_a_ray_head_writes_the_local_csvs(self, tmp_path):
        """The user-facing check: `ray start --head` on this machine, then reproduce on it."""
        port = _free_port()
        ray_cli = Path(sys.executable).with_name("ray")
        head = subprocess.Popen([str(ray_cli), "start", "--head", "--block", f"--port={port}", "--num-cpus=2",
                                 "--include-dashboard=false"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            deadline = time.time() + 60
            while True:
                try:
                    socket.create_connection(("127.0.0.1", port), timeout=1).close()
                    break
                except OSError:
                    assert time.time() < deadline, "ray start --head did not come up"
                    time.sleep(0.5)
            cmd = [sys.executable, "-m", "mdr_drive_env.cli", "reproduce", "--numerics", "fast", "--quick"]
            local = subprocess.run(cmd + ["--workers", "1", "--out", str(tmp_path / "local")], capture_output=True,
                                   text=True, timeout=300)
            assert local.returncode == 0, local.stderr
            on_ray = subprocess.run(cmd + ["--ray-address", f"127.0.0.1:{port}", "--out", str(tmp_path / "ray")],
                                    capture_output=True, text=True, timeout=300)
            assert on_ray.returncode == 0, on_ray.stderr
            assert "Ray cluster at" in on_ray.stderr and "tasks on Ray" in on_ray.stderr
            for name in ("fig3.csv", "fig5.csv"):
                assert (tmp_path / "ray" / name).read_bytes() == (tmp_path / "local" / name).read_bytes()
            assert not (tmp_path / "ray" / ".tasks").exists()  # the per-task files are removed once done
        finally:
            head.terminate()
            head.wait(timeout=60)


def test_local_workers_end_with_the_process_that_started_them(tmp_path):
    """A sweep killed with SIGKILL leaves no worker behind (its workers ask the kernel to end them with it)."""
    import signal
    import subprocess
    import textwrap

    script = tmp_path / "sweep.py"
    script.write_text(textwrap.dedent("""
        import os, sys, time
        from mdr_drive_env.sweep import Executor

        def slow(x):
            open(os.path.join(sys.argv[1], str(os.getpid())), "w").close()
            time.sleep(120)
            return x

        if __name__ == "__main__":
            Executor(workers=2, progress=False).map(slow, [1, 2, 3, 4], "slow")
    """))
    pids = tmp_path / "pids"
    pids.mkdir()
    parent = subprocess.Popen([sys.executable, str(script), str(pids)])
    deadline = time.time() + 60
    while len(list(pids.iterdir())) < 2 and time.time() < deadline:
        time.sleep(0.1)
    workers = [int(p.name) for p in pids.iterdir()]
    assert len(workers) == 2
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    deadline = time.time() + 20
    while any(_alive(pid) for pid in workers) and time.time() < deadline:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/status") as f:
            return "zombie" not in f.read()
    except FileNotFoundError:
        return False


def test_resume_removes_the_temporary_files_of_killed_writers(tmp_path):
    from mdr_drive_env.sweep import task_folder

    folder = tmp_path / ".tasks" / "fig5"
    folder.mkdir(parents=True)
    (folder / ".000003.json.ab12cd34.json").write_text("half a task")
    (tmp_path / ".fig5.png.x1y2z3w4.png").write_text("half a figure")
    (folder / "000001.json").write_text("{}")
    task_folder(tmp_path, resume=True)
    assert not (folder / ".000003.json.ab12cd34.json").exists() and not (tmp_path / ".fig5.png.x1y2z3w4.png").exists()
    assert (folder / "000001.json").exists()
