"""Where a sweep's tasks run: worker processes on this machine, or a Ray cluster — one interface.

A sweep (``paper``, ``efficiency``, ``rigs``) is a list of :class:`Task`: a
module-level function and the arguments it needs, every input carried in the
arguments (records, models, configurations), the result returned by value. The
driver alone writes files (through :mod:`msd_bench.io.storage.run_dir`), so workers need
no shared filesystem and a result never depends on where it was computed.

Why our own local pool rather than ``concurrent.futures``: a worker that dies
(killed, out of memory) breaks a ``ProcessPoolExecutor`` for every task in
flight and cannot say which task it was running. Here each worker holds one
task at a time, so a death is charged to that task, which is retried on a
fresh worker a bounded number of times and said in the output. Ray is driven
the same way: ``max_retries=0`` on the remote call and the retry done here, so
both executors count, log and bound retries identically.

Every worker is single-threaded (BLAS, numba, torch): two workers on two cores
then never fight over threads, and a task's numbers do not depend on how many
threads it had. A task that raises the project's error (:class:`MsdBenchError`)
fails the sweep with that one line, never retried: a bad input stays bad.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Protocol

from msd_bench.core.errors import ConfigError, MsdBenchError

SINGLE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                 "NUMBA_NUM_THREADS": "1", "MSD_BENCH_WORKER": "1"}
"""Environment of every worker: one thread per task (read by numpy's BLAS, numba and torch at start)."""

DEFAULT_RETRIES = 2
"""How many times a task whose worker died is started again before the sweep fails."""


@dataclass(frozen=True)
class Task:
    """One unit of a sweep: ``fn(*args)`` in a worker; ``id`` names it in the run directory and the log."""

    id: str
    fn: Callable[..., Any]
    """A module-level function (workers import it by name)."""
    args: tuple[Any, ...] = ()


MAX_WORKERS = 1024
"""The most ``--workers`` a sweep accepts: more processes than any machine or cluster here has cores,
far below a number that would exhaust process tables or Ray's scheduler."""
MAX_RETRIES = 100
"""The most ``--retries``: a task whose worker died 100 times is broken, not unlucky."""


@dataclass(frozen=True)
class ExecutorOptions:
    """How a sweep is executed (``--executor``, ``--workers``, ``--ray-address``, ``--retries``)."""

    kind: str = "local"
    workers: int = 0
    """Worker processes; 0 = one per core of this machine (or of the Ray cluster)."""
    ray_address: str | None = None
    """Join this Ray cluster (``auto``, ``host:port``, ``ray://...``); None starts a local one."""
    retries: int = DEFAULT_RETRIES

    def __post_init__(self) -> None:
        if self.kind not in EXECUTORS:
            raise ConfigError(f"unknown executor {self.kind!r}; choose from {', '.join(EXECUTORS)}")
        if self.workers < 0 or self.retries < 0:
            raise ConfigError(f"--workers and --retries must be >= 0, got {self.workers} and {self.retries}")
        if self.workers > MAX_WORKERS:
            raise ConfigError(f"--workers {self.workers} is more than {MAX_WORKERS}, the most a sweep starts")
        if self.retries > MAX_RETRIES:
            raise ConfigError(f"--retries {self.retries} is more than {MAX_RETRIES}, the most a task is "
                              "restarted")
        if self.ray_address is not None and self.kind != "ray":
            raise ConfigError("--ray-address needs --executor ray")

    def worker_count(self) -> int:
        """The number of workers asked for, one per core by default."""
        return self.workers or os.cpu_count() or 1


def task_name(kind: str) -> str:
    """An agent kind as a run-directory task id may spell it: no ``+`` or ``@`` (no kind name holds ``_``)."""
    return kind.replace("+", "_").replace("@", "_at_")


class WorkerDied(MsdBenchError):
    """A task's worker died more often than the retries allow."""


OnResult = Callable[[Task, Any], None]
Log = Callable[[str], None]


class Executor(Protocol):
    """Runs tasks and hands each result to ``on_result`` in the driver, as it arrives."""

    def run(self, tasks: Sequence[Task], on_result: OnResult) -> None:
        """Run every task; raise the first task's MsdBenchError, or :class:`WorkerDied`."""

    def close(self) -> None:
        """Stop the workers (and a Ray cluster this executor started)."""


def call_task(fn: Callable[..., Any], args: tuple[Any, ...]) -> tuple[str, Any]:
    """What a worker does with one task: ``("ok", result)`` or ``("error", the project's error)``.

    Any other exception is a bug in a task function: it reaches the driver as
    ``("bug", traceback text)`` and fails the sweep loudly (no retry hides it).
    """
    try:
        return "ok", fn(*args)
    except MsdBenchError as err:
        return "error", err
    except Exception:  # a bug in a task: its traceback goes to the driver, not lost
        import traceback

        return "bug", traceback.format_exc()


def settle(task: Task, status: str, value: Any) -> Any:
    """The result of a finished task, or its error raised in the driver."""
    if status == "ok":
        return value
    if status == "error":
        raise value
    raise RuntimeError(f"task {task.id} failed with a bug in msd-bench:\n{value}")


def single_threaded() -> None:
    """Inside a worker: one thread for torch and numba too (their pools may already be up)."""
    os.environ.update(SINGLE_THREAD)
    try:
        import torch
    except ImportError:  # torch is a dependency; a trimmed install simply has nothing to limit
        pass
    else:
        torch.set_num_threads(1)


@contextmanager
def worker_environment() -> Iterator[None]:
    """The single-thread variables set while workers start (a spawned process copies the environment)."""
    saved = {k: os.environ.get(k) for k in SINGLE_THREAD}
    os.environ.update(SINGLE_THREAD)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _worker_loop(conn: Connection) -> None:
    """A local worker: receive ``(fn, args)``, send back :func:`call_task`'s answer, until ``None``."""
    single_threaded()
    while True:
        job = conn.recv()
        if job is None:
            return
        conn.send(call_task(*job))


class _Worker:
    """One local worker process and the task it holds."""

    def __init__(self, ctx: Any) -> None:
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_loop, args=(child,), daemon=True)
        with worker_environment():
            self.process.start()
        child.close()
        self.task: Task | None = None

    def give(self, task: Task) -> None:
        self.task = task
        self.conn.send((task.fn, task.args))

    def stop(self) -> None:
        with contextlib.suppress(OSError):  # already gone
            self.conn.send(None)
        self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


class LocalPool:
    """Worker processes on this machine (spawned: no numba or torch state is forked)."""

    def __init__(self, options: ExecutorOptions, log: Log) -> None:
        self.options, self.log = options, log
        self.ctx = multiprocessing.get_context("spawn")
        self.workers: list[_Worker] = []

    def run(self, tasks: Sequence[Task], on_result: OnResult) -> None:
        queue, deaths = list(tasks), dict.fromkeys((t.id for t in tasks), 0)
        while len(self.workers) < min(self.options.worker_count(), len(queue)):
            self.workers.append(_Worker(self.ctx))
        busy: dict[Any, _Worker] = {}
        try:
            while queue or busy:
                for w in self.workers:
                    if w.task is None and queue:
                        w.give(queue.pop(0))
                        busy[w.conn] = busy[w.process.sentinel] = w
                for ready in wait(list(busy)):
                    held = busy.get(ready)
                    if held is None or held.task is None:
                        continue  # its other handle was served in this round
                    self._collect(held, busy, queue, deaths, on_result)
        finally:
            self.close()

    def _collect(self, w: _Worker, busy: dict[Any, _Worker], queue: list[Task], deaths: dict[str, int],
                 on_result: OnResult) -> None:
        task = w.task
        assert task is not None
        answer = self._answer(w)
        del busy[w.conn], busy[w.process.sentinel]
        w.task = None
        if answer is None:  # the worker died holding the task: charge it, start a fresh worker
            deaths[task.id] += 1
            code = w.process.exitcode
            self.workers[self.workers.index(w)] = _Worker(self.ctx)
            w.conn.close()
            retry_or_fail(task, deaths[task.id], self.options.retries, f"exit code {code}", self.log)
            queue.insert(0, task)
            return
        on_result(task, settle(task, *answer))

    @staticmethod
    def _answer(w: _Worker) -> tuple[str, Any] | None:
        """The worker's answer, or None when it died (a dead pipe or a sentinel without data)."""
        try:
            if w.conn.poll():
                answer: tuple[str, Any] = w.conn.recv()
                return answer
        except (EOFError, OSError):
            pass
        w.process.join(timeout=5)
        return None

    def close(self) -> None:
        for w in self.workers:
            w.stop()
        self.workers = []


def retry_or_fail(task: Task, deaths: int, retries: int, why: str, log: Log) -> None:
    """Log a retry of ``task`` after its worker died, or raise :class:`WorkerDied` past ``retries``."""
    if deaths > retries:
        raise WorkerDied(f"task {task.id}: its worker died {deaths} time(s) ({why}); "
                         f"no retries left (--retries {retries})")
    log(f"task {task.id}: worker died ({why}); retry {deaths} of {retries}")


def lost_worker_errors() -> tuple[type[BaseException], ...]:
    """Ray's errors for a task whose worker, memory or node went away, not for the task's own
    failure: a crash (a segfault, SIGKILL), Ray's memory monitor killing it, its node dying, or its
    result lost with the node that held it. Each is retried like a local worker's death; in Ray 2.60
    they are siblings under ``RayError``, not subclasses of ``WorkerCrashedError``."""
    from ray import exceptions as ex

    return (ex.WorkerCrashedError, ex.OutOfMemoryError, ex.NodeDiedError, ex.ObjectLostError)


def _remote_call(fn: Callable[..., Any], args: tuple[Any, ...]) -> tuple[str, Any]:
    """The Ray task body: the local worker's, single-threaded."""
    single_threaded()
    return call_task(fn, args)


RAY_START_PATIENCE_S = 300.0
"""How long a local Ray node may take to register with its GCS. Ray 2.60 hard-codes 30 s
(``ray/_private/node.py``); on a loaded 2-core machine the raylet registered after 28 s in a run by
hand and after more than 30 s in the suite, so a local cluster failed to start although nothing was
wrong. Joining a cluster (``--ray-address``) keeps Ray's own patience: a wrong address fails fast."""


@contextmanager
def patient_node_start(ray: Any, seconds: float) -> Iterator[None]:
    """While a local cluster starts, Ray's check that its node registered waits up to ``seconds``.

    Ray polls ``ray._private.services.get_node`` (which raises ``RuntimeError`` until the node is in
    the GCS) and gives up after its fixed 30 s; here each poll itself waits, so the fixed limit counts
    from the moment the node is there. Pinned Ray (2.60.0) — the test of a local Ray sweep exercises it.
    """
    import time

    services = ray._private.services
    original = services.get_node

    def get_node(*args: Any, **kwargs: Any) -> Any:
        deadline = time.monotonic() + seconds
        while True:
            try:
                return original(*args, **kwargs)
            except RuntimeError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)

    services.get_node = get_node
    try:
        yield
    finally:
        services.get_node = original


@contextmanager
def join_as_given(ray: Any, address: str) -> Iterator[None]:
    """While ``ray.init`` joins ``address``, Ray keeps a ``host:port`` as the user gave it.

    Ray 2.60's ``canonicalize_bootstrap_address`` rewrites a loopback host (127.0.0.1,
    localhost) to the machine's external interface address, so a cluster asked for on
    loopback was joined (and its errors reported) on another address. ``auto`` and
    ``ray://`` keep Ray's own handling. Pinned Ray (2.60.0): the real-cluster test joins
    through it (tests/cluster).
    """
    from msd_bench.app.ray_probe import split_host_port

    services = ray._private.services
    original = services.canonicalize_bootstrap_address
    given = split_host_port(address) if not address.startswith("ray://") else None

    def canonical(addr: Any, temp_dir: Any = None) -> Any:
        return address if addr == address else original(addr, temp_dir)

    if given is not None:
        services.canonicalize_bootstrap_address = canonical
    try:
        yield
    finally:
        services.canonicalize_bootstrap_address = original


def start_ray(ray: Any, address: str | None, kw: dict[str, Any]) -> None:
    """``ray.init`` with the project's one-line error, and no Ray process left behind when it fails."""
    where = address or "a local cluster"
    patience = (patient_node_start(ray, RAY_START_PATIENCE_S) if address is None
                else join_as_given(ray, address))
    try:
        with patience:  # "local": a new cluster of our own, never one a `ray start` left on the machine
            ray.init(address=address if address is not None else "local", **kw)
    except (ConnectionError, ValueError, RuntimeError) as err:
        ray.shutdown()
        raise ConfigError(f"cannot start or join Ray at {where}: {_first_line(err)}") from None
    except Exception as err:  # Ray raises a bare Exception when its node times out during startup
        if "timed out during startup" not in str(err):
            raise
        ray.shutdown()
        raise ConfigError(f"cannot start or join Ray at {where}: {_first_line(err)}") from None


def _first_line(err: BaseException) -> str:
    return str(err).splitlines()[0] if str(err) else type(err).__name__


class RayExecutor:
    """Tasks as Ray remote calls: a local cluster of ``workers`` CPUs, or the cluster at ``ray_address``."""

    def __init__(self, options: ExecutorOptions, log: Log) -> None:
        import ray

        self.options, self.log, self.ray = options, log, ray
        self.started = not ray.is_initialized()
        if self.started:
            kw: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                  "configure_logging": False,
                                  "runtime_env": {"env_vars": dict(SINGLE_THREAD)}}
            if options.ray_address is None:  # a cluster of our own on this machine (its ports are open on
                # every interface: Ray 2.60 ignores the loopback hint for its servers; docs/cluster.md)
                kw.update(num_cpus=options.worker_count(), _node_ip_address="127.0.0.1")
            start_ray(ray, options.ray_address, kw)
        self.remote = ray.remote(num_cpus=1, max_retries=0)(_remote_call)

    def run(self, tasks: Sequence[Task], on_result: OnResult) -> None:
        from ray.exceptions import RayTaskError

        lost = lost_worker_errors()
        deaths = dict.fromkeys((t.id for t in tasks), 0)
        pending = {self.remote.remote(t.fn, t.args): t for t in tasks}
        while pending:
            done, _ = self.ray.wait(list(pending), num_returns=1)
            task = pending.pop(done[0])
            try:
                answer = self.ray.get(done[0])
            except lost as err:
                deaths[task.id] += 1
                why = f"Ray lost it: {type(err).__name__}"
                retry_or_fail(task, deaths[task.id], self.options.retries, why, self.log)
                pending[self.remote.remote(task.fn, task.args)] = task
                continue
            except RayTaskError as err:  # the body catches everything; this is Ray's own failure
                raise RuntimeError(f"task {task.id}: Ray failed it: {err}") from None
            on_result(task, settle(task, *answer))

    def close(self) -> None:
        if self.started and self.ray.is_initialized():
            self.ray.shutdown()


EXECUTORS: Mapping[str, Callable[[ExecutorOptions, Log], Executor]] = {
    "local": LocalPool,
    "ray": RayExecutor,
}
"""Every executor by ``--executor`` name."""


def run_tasks(tasks: Sequence[Task], options: ExecutorOptions, on_result: OnResult,
              log: Log | None = None) -> None:
    """Run ``tasks`` on the chosen executor; each result reaches ``on_result`` in the driver."""
    say = log or (lambda line: print(line, file=sys.stderr))
    if not tasks:
        return
    executor = EXECUTORS[options.kind](options, say)
    try:
        executor.run(tasks, on_result)
    finally:
        executor.close()
