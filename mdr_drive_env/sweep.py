"""One executor for every sweep of independent tasks: local processes, or a Ray cluster.

    executor = Executor(workers=2)                        # local processes (default: the cores available)
    executor = Executor(ray_address="auto")               # the Ray cluster this machine belongs to
    executor = Executor(ray_address="10.0.0.5:6379")      # an existing cluster (or "ray://host:10001")
    executor = Executor(ray_address="local")              # a Ray instance started in this process
    results = executor.map(fn, tasks, "Fig. 5", store=TaskStore(out / ".tasks" / "fig5"))

``fn`` must be a module-level function (it is pickled to the workers) and each task must hold
everything its result depends on (seeds included): results are then the same, bit for bit,
whatever runs them, and ``map`` returns them in task order. With a ``TaskStore`` every finished
task's result is written to its own file as it arrives (atomically, as data: JSON, never a
pickle), so a sweep stopped by Ctrl-C or a lost node continues where it stopped (``resume=True``):
only missing tasks are computed. A stored result is used only if its file names the same task and
its checksum holds; any other file is recomputed, with a one-line warning. A task whose worker dies
is run again (``max_retries`` times): Ray retries it itself; the local pool is rebuilt and the
missing tasks resubmitted. The local pool's workers end when the process that started them ends,
however it ends.

Ray is optional (``pip install 'mdr-drive[ray]'``); the package and the local executor do not
need it. Every node of a cluster needs this package installed in the Python its Ray workers run.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import socket
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from tqdm import tqdm

from .files import atomic_path, dumps_data, loads_data, remove_temporary

#: Seconds to wait for a TCP answer from a Ray address before calling it unreachable.
CONNECT_TIMEOUT = 5.0
RAY_MISSING = "Ray is not installed: pip install 'mdr-drive[ray]' (or pip install ray)"


def available_cores() -> int:
    """CPU cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def task_key(task: Any) -> str:
    """A fingerprint of a task: a stored result is reused only for the very same task (the store's
    folder names the sweep, so the function)."""
    return hashlib.sha256(pickle.dumps(task, protocol=4)).hexdigest()


class TaskStore:
    """One file per finished task under ``folder`` (``000012.json`` holds task 12's key, its result
    as data and the checksum of both)."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)

    def path(self, index: int) -> Path:
        return self.folder / f"{index:06d}.json"

    @staticmethod
    def _digest(key: str, payload: str) -> str:
        return hashlib.sha256(f"{key}\n{payload}".encode()).hexdigest()

    def load(self, index: int, key: str):
        """(True, result) if task ``index`` with fingerprint ``key`` is stored intact, else (False,
        None): a missing file silently, a foreign, damaged or other task's file with a one-line
        warning (it is recomputed; nothing in it is run)."""
        path = self.path(index)
        try:
            stored = json.loads(path.read_text())
        except FileNotFoundError:
            return False, None
        except (OSError, ValueError) as e:
            return self._refuse(path, f"not readable as JSON ({type(e).__name__})")
        if not isinstance(stored, dict) or set(stored) != {"key", "sha256", "result"}:
            return self._refuse(path, "not a task result")
        if stored["key"] != key:
            return self._refuse(path, "another task's result")
        if self._digest(key, stored["result"]) != stored["sha256"]:
            return self._refuse(path, "its checksum does not hold")
        try:
            return True, loads_data(stored["result"])
        except ValueError as e:
            return self._refuse(path, str(e))

    @staticmethod
    def _refuse(path: Path, why: str):
        print(f"{path}: {why}; the task is computed again", file=sys.stderr)
        return False, None

    def save(self, index: int, key: str, result: Any) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        payload = dumps_data(result)
        with atomic_path(self.path(index)) as tmp:
            tmp.write_text(json.dumps({"key": key, "sha256": self._digest(key, payload), "result": payload}))

    def clear(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def task_folder(out: str | Path, resume: bool) -> Path:
    """``out/.tasks``, where a command keeps its sweeps' finished tasks (one ``TaskStore`` per sweep);
    emptied first unless ``resume``; when it is, ``out`` and it are cleared of the temporary files of
    writers that were killed. The command removes it once every output is written."""
    folder = Path(out) / ".tasks"
    if not resume:
        shutil.rmtree(folder, ignore_errors=True)
    elif Path(out).exists():
        remove_temporary(out)  # the tasks' and the outputs' (figures, tables) of writers that were killed
    return folder


def import_ray():
    """The ``ray`` module, or ``ValueError`` saying which extra installs it."""
    # something may accept TCP at an address without being Ray: give up after a few seconds, not
    # Ray's 20 (Ray reads its configuration when it is first imported)
    os.environ.setdefault("RAY_NUM_REDIS_GET_RETRIES", str(int(CONNECT_TIMEOUT)))  # one try a second
    # A cluster started by `ray start` on a machine with a Ray token (~/.ray/auth_token) requires it;
    # Ray's own driver sends it only with RAY_AUTH_MODE=token (measured with Ray 2.60)
    if "RAY_AUTH_MODE" not in os.environ and (os.environ.get("RAY_AUTH_TOKEN") or
                                              (Path.home() / ".ray" / "auth_token").exists()):
        os.environ["RAY_AUTH_MODE"] = "token"
    try:
        import ray
    except ImportError:
        raise ValueError(RAY_MISSING) from None
    return ray


def check_ray_address(address: str) -> None:
    """``ValueError`` naming ``address`` unless it is "auto", "local", or a HOST:PORT (or
    ray://HOST:PORT) that answers within ``CONNECT_TIMEOUT`` seconds."""
    if address in ("auto", "local"):
        return
    hostport = address[len("ray://"):] if address.startswith("ray://") else address
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(f"--ray-address {address!r} is not 'auto', 'local', HOST:PORT or ray://HOST:PORT")
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT).close()
    except OSError as e:
        raise ValueError(f"--ray-address {address}: no Ray cluster answers there ({e})") from None


@dataclass(frozen=True)
class Executor:
    """Runs independent tasks on local processes or on Ray.

    Attributes:
        workers: local processes (default: the cores available; 1 runs in this process). With a Ray
            address, the number of CPUs of a ``"local"`` Ray instance (default: the cores available).
        ray_address: None for local processes; "auto" (the cluster this machine is part of),
            "HOST:PORT" or "ray://HOST:PORT" (an existing cluster), or "local" (a Ray instance started
            in this process).
        max_retries: times a task whose worker died is run again.
        progress: show a progress bar.
    """

    workers: int | None = None
    ray_address: str | None = None
    max_retries: int = 3
    progress: bool = True

    def __post_init__(self) -> None:
        if self.workers is not None and (isinstance(self.workers, bool) or not isinstance(self.workers, int)
                                         or self.workers < 1):
            raise ValueError(f"--workers {self.workers!r} is outside the allowed range [1, inf)")

    @property
    def is_ray(self) -> bool:
        return self.ray_address is not None

    def check(self) -> None:
        """Fail fast (``ValueError``) if Ray is asked for and missing or its address does not answer."""
        if self.is_ray:
            import_ray()
            check_ray_address(self.ray_address)

    def map(self, fn: Callable, tasks: Sequence, desc: str, store: TaskStore | None = None,
            on_result: Callable[[int, Any], None] | None = None) -> list:
        """``[fn(t) for t in tasks]``, in task order, with a progress bar; tasks already in ``store``
        (same fingerprint) are not run again. ``on_result(index, result)`` is called here as each
        task's result arrives (e.g. to write it out)."""
        tasks = list(tasks)
        keys = [task_key(t) for t in tasks]
        results: dict[int, Any] = {}
        if store is not None:
            for i, key in enumerate(keys):
                found, value = store.load(i, key)
                if found:
                    results[i] = value
        pending = [i for i in range(len(tasks)) if i not in results]

        def done(i: int, value: Any) -> None:
            results[i] = value
            if store is not None:
                store.save(i, keys[i], value)
            if on_result is not None:
                on_result(i, value)

        t0 = time.perf_counter()
        with tqdm(total=len(tasks), initial=len(results), desc=desc, unit="task", disable=not self.progress) as bar:
            if pending:
                if self.is_ray:
                    self._ray(fn, tasks, pending, done, bar)
                elif (self.workers or available_cores()) <= 1 or len(pending) == 1:
                    for i in pending:
                        done(i, fn(tasks[i]))
                        bar.update()
                else:
                    self._local(fn, tasks, pending, done, bar)
        if self.is_ray and pending:
            wall = time.perf_counter() - t0
            print(f"{desc}: {len(pending)} tasks on Ray in {wall:.1f} s ({len(pending) / wall:.2f} tasks/s)",
                  file=sys.stderr)
        return [results[i] for i in range(len(tasks))]

    # ------------------------------------------------------------------ backends
    def _local(self, fn, tasks, pending, done, bar) -> None:
        """A process pool; if a worker dies, the pool is rebuilt and the missing tasks resubmitted. Each
        worker's batched simulators use its share of the cores (``core.batch.set_process_threads``),
        and each ends when this process ends (``start_worker``)."""
        workers = min(self.workers or available_cores(), len(pending))
        share = max(1, available_cores() // workers)
        missing, failures = list(pending), 0
        while missing:
            try:
                with ProcessPoolExecutor(max_workers=workers, initializer=start_worker,
                                         initargs=(share, os.getpid())) as pool:
                    futures = {pool.submit(fn, tasks[i]): i for i in missing}
                    while futures:
                        finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                        for f in finished:
                            i = futures.pop(f)
                            done(i, f.result())
                            missing.remove(i)
                            bar.update()
            except BrokenProcessPool:
                failures += 1
                if failures > self.max_retries:
                    raise RuntimeError(f"{len(missing)} tasks lost their worker {failures} times") from None
                print(f"a worker died; running the {len(missing)} missing tasks again", file=sys.stderr)

    def _ray(self, fn, tasks, pending, done, bar) -> None:
        ray = connect(self.ray_address, self.workers)
        remote = ray.remote(num_cpus=1, max_retries=self.max_retries)(fn)
        refs = {remote.remote(tasks[i]): i for i in pending}
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                i = refs.pop(ref)
                done(i, ray.get(ref))
                bar.update()


def start_worker(threads: int, parent: int) -> None:
    """A local pool worker's start: its batched simulators use ``threads`` cores, and it ends when
    the process ``parent`` that started it ends, however that ends (Linux: the kernel sends it
    SIGKILL then, ``PR_SET_PDEATHSIG``; a parent already gone ends it at once)."""
    import signal

    from .core.batch import set_process_threads

    set_process_threads(threads)
    if sys.platform.startswith("linux"):
        import ctypes

        PR_SET_PDEATHSIG = 1
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:  # the parent ended before the request took effect
            os._exit(1)


def connect(address: str, workers: int | None = None):
    """Connect this process to Ray at ``address`` once (``Executor`` docs); prints the cluster used."""
    ray = import_ray()
    if ray.is_initialized():
        return ray
    check_ray_address(address)
    env = {"env_vars": {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}}
    if address == "local":
        ray.init(num_cpus=workers or available_cores(), include_dashboard=False, log_to_driver=False,
                 runtime_env=env)
    else:
        try:
            ray.init(address=address, log_to_driver=False, runtime_env=env)
        except ConnectionError as e:
            raise ValueError(f"--ray-address {address}: {e}") from None
    nodes = [n for n in ray.nodes() if n.get("Alive")]
    cpus = ray.cluster_resources().get("CPU", 0)
    gcs = getattr(ray.get_runtime_context(), "gcs_address", None) or address
    print(f"Ray cluster at {gcs} (--ray-address {address}): {len(nodes)} node(s), {cpus:g} CPUs", file=sys.stderr)
    return ray


def add_executor_arguments(p, resume: bool = True) -> None:
    """``--workers``, ``--ray-address`` (and ``--resume``) on an argparse parser."""
    from .cli_args import positive_int

    p.add_argument("--workers", type=positive_int, default=None,
                   help="local processes, >= 1 (-); default: the cores available; with --ray-address local, "
                        "the CPUs of that Ray instance")
    p.add_argument("--ray-address", default=None, metavar="ADDR",
                   help="run the tasks on Ray: 'auto' (the cluster this machine belongs to), HOST:PORT or "
                        "ray://HOST:PORT (an existing cluster), or 'local' (a Ray instance in this process); "
                        "needs pip install 'mdr-drive[ray]'")
    if resume:
        p.add_argument("--resume", action="store_true",
                       help="continue an interrupted sweep in --out: reuse the tasks it finished")


def executor_from(args) -> Executor:
    """The ``Executor`` of parsed ``add_executor_arguments`` options, checked (fails fast)."""
    ex = Executor(workers=args.workers, ray_address=args.ray_address)
    ex.check()
    return ex


__all__ = ["Executor", "TaskStore", "task_folder", "add_executor_arguments", "available_cores", "check_ray_address", "connect",
           "executor_from", "task_key"]
