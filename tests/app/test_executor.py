"""The sweep executor: the same results on every executor, bounded retries of a dead worker, one-line
errors, and a killed sweep that resumes without recomputing what it wrote."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from msd_bench.app.executor import ExecutorOptions, Task, WorkerDied, run_tasks
from msd_bench.core.errors import ConfigError
from tests.app import executor_tasks as tasks

ROOT = Path(__file__).resolve().parents[2]


def _collect(task_list: list[Task], options: ExecutorOptions) -> tuple[dict[str, Any], list[str]]:
    got: dict[str, Any] = {}
    log: list[str] = []
    run_tasks(task_list, options, lambda t, r: got.__setitem__(t.id, r), log.append)
    return got, log


ON_RAY = pytest.param("ray", marks=pytest.mark.cluster)
"""The Ray half of a test run on both executors: the cluster tier's (docs/testing.md §Tiers)."""


def test_local_pool_runs_every_task_single_threaded() -> None:
    got, _ = _collect([Task(f"t{i}", tasks.square, (i,)) for i in range(5)], ExecutorOptions(workers=2))
    assert got == {f"t{i}": {"x": i, "square": i * i, "omp": "1"} for i in range(5)}


@pytest.mark.cluster  # Ray's start alone is tens of seconds on two cores: the cluster tier
@pytest.mark.usefixtures("ray_cluster")
def test_local_and_ray_give_the_same_results() -> None:
    jobs = [Task(f"t{i}", tasks.square, (i,)) for i in range(4)]
    local, _ = _collect(jobs, ExecutorOptions(workers=2))
    ray, _ = _collect(jobs, ExecutorOptions(kind="ray", workers=2))
    assert ray == local


@pytest.mark.parametrize("kind", ["local", ON_RAY])
def test_a_task_whose_worker_dies_is_retried_and_said(kind: str, tmp_path: Path,
                                                       request: pytest.FixtureRequest) -> None:
    if kind == "ray":
        request.getfixturevalue("ray_cluster")
    jobs = [Task("dies", tasks.die_first, (str(tmp_path / "marker"), 7)), Task("fine", tasks.square, (3,))]
    got, log = _collect(jobs, ExecutorOptions(kind=kind, workers=2))
    assert got["dies"] == 7 and got["fine"]["square"] == 9
    assert [line for line in log if "task dies: worker died" in line and "retry 1 of 2" in line]


def test_a_worker_that_always_dies_fails_the_sweep_in_one_line() -> None:
    with pytest.raises(WorkerDied, match=r"task doomed: its worker died 2 time\(s\).*--retries 1") as err:
        _collect([Task("doomed", tasks.die_always, (1,))], ExecutorOptions(workers=1, retries=1))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("kind", ["local", ON_RAY])
def test_the_projects_error_in_a_task_fails_the_sweep_with_that_line(kind: str,
                                                                     request: pytest.FixtureRequest) -> None:
    if kind == "ray":
        request.getfixturevalue("ray_cluster")
    with pytest.raises(ConfigError, match=r"^task input 5 is not allowed$"):
        _collect([Task("bad", tasks.refuse, (5,))], ExecutorOptions(kind=kind, workers=1))


@pytest.mark.parametrize(("kw", "message"), [
    ({"kind": "slurm"}, "unknown executor 'slurm'; choose from local, ray"),
    ({"workers": -1}, "--workers and --retries must be >= 0"),
    ({"ray_address": "auto"}, "--ray-address needs --executor ray"),
])
def test_bad_executor_options_are_one_line_errors(kw: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExecutorOptions(**kw)


def _driver(out: Path, release: Path) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "tests.app.sweep_driver", str(out), str(release)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)


def _wait_until(cond: Any, proc: subprocess.Popen[str]) -> None:
    while not cond():
        assert proc.poll() is None, proc.communicate()[0]
        time.sleep(0.05)


def test_a_killed_sweep_resumes_without_recomputing_its_tasks(tmp_path: Path) -> None:
    out, release = tmp_path / "run", tmp_path / "release"
    first = _driver(out, release)
    records = [out / "tasks" / "t0.json", out / "tasks" / "t1.json"]
    _wait_until(lambda: all(r.exists() for r in records), first)
    os.killpg(first.pid, signal.SIGKILL)  # the driver and its workers, as a lost machine would
    first.communicate()
    assert not (out / "complete").exists() and not (out / "tasks" / "t2.json").exists()
    before = {p.name: p.stat().st_mtime_ns for p in (out / "parts").iterdir()}
    release.write_text("go")
    second = _driver(out, release)
    log, _ = second.communicate(timeout=300)
    assert second.returncode == 0, log
    assert "resuming: 2 of 4 tasks already written, not recomputed" in log
    assert {n: (out / "parts" / n).stat().st_mtime_ns for n in before} == before
    fresh = _driver(tmp_path / "fresh", release)
    fresh.communicate(timeout=300)
    assert fresh.returncode == 0
    fresh_sum = json.loads((tmp_path / "fresh" / "sum.json").read_text())
    assert json.loads((out / "sum.json").read_text()) == fresh_sum
    assert json.loads((out / "sum.json").read_text()) == {"sum": 0 + 10 + 20 + 30}


class _FakeRay:
    """Enough of the ``ray`` module for start_ray: a get_node that is ready after ``ready_after`` polls."""

    def __init__(self, init_error: BaseException | None = None, ready_after: int = 0) -> None:
        self.init_error, self.polls, self.ready_after, self.shut = init_error, 0, ready_after, False
        self.address: str | None = None
        services = type("services", (), {})()
        services.get_node = self._get_node
        self._private = type("private", (), {"services": services})()

    def _get_node(self, *_: Any) -> str:
        self.polls += 1
        if self.polls <= self.ready_after:
            raise RuntimeError("node info not available yet")
        return "node"

    def init(self, address: str | None = None, **_: Any) -> None:
        self.address = address
        if self.init_error is not None:
            raise self.init_error
        assert self._private.services.get_node() == "node"  # Ray's own poll, once: it waits inside

    def shutdown(self) -> None:
        self.shut = True


def test_a_slow_local_node_start_is_waited_for_within_the_patience() -> None:
    from msd_bench.app.executor import start_ray

    ray = _FakeRay(ready_after=2)  # Ray's single poll would have raised; the patient one polls again
    start_ray(ray, None, {})
    assert ray.polls == 3 and not ray.shut
    assert ray.address == "local"  # a cluster of our own, never one a stale /tmp/ray file names
    assert ray._private.services.get_node.__func__ is _FakeRay._get_node


@pytest.mark.parametrize("error", [Exception("The current node timed out during startup. This could happen"),
                                   ConnectionError("could not connect to 10.0.0.1:6379")])
def test_ray_failing_to_start_is_one_line_and_leaves_no_cluster(error: BaseException) -> None:
    from msd_bench.app.executor import start_ray

    ray = _FakeRay(init_error=error)
    with pytest.raises(ConfigError, match=r"^cannot start or join Ray at a local cluster: [^\n]+$"):
        start_ray(ray, None, {})
    assert ray.shut


def test_an_unknown_failure_of_ray_is_not_disguised() -> None:
    from msd_bench.app.executor import start_ray

    with pytest.raises(Exception, match="something else"):
        start_ray(_FakeRay(init_error=Exception("something else")), None, {})


class _LosingRay:
    """Ray's scheduling surface, losing each task's first attempt with ``error``."""

    def __init__(self, error: BaseException) -> None:
        self.error, self.calls = error, 0

    def wait(self, refs: list[Any], num_returns: int) -> tuple[list[Any], list[Any]]:
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref: tuple[Any, ...]) -> tuple[str, Any]:
        self.calls += 1
        if self.calls == 1:
            raise self.error
        fn, args = ref
        return "ok", fn(*args)


def _lost_errors() -> list[BaseException]:
    from ray import exceptions as ex

    return [ex.WorkerCrashedError(), ex.OutOfMemoryError("killed by the memory monitor"),
            ex.NodeDiedError("node died"), ex.ObjectLostError("ab" * 14, "owner", "call site")]


@pytest.mark.parametrize("error", _lost_errors(), ids=lambda e: type(e).__name__)
def test_a_task_ray_loses_to_memory_a_node_or_a_crash_is_retried_and_said(error: BaseException) -> None:
    from msd_bench.app.executor import RayExecutor

    ex = object.__new__(RayExecutor)  # the scheduling loop alone: no cluster is started
    ex.ray, ex.options, log = _LosingRay(error), ExecutorOptions(kind="ray", retries=1), []
    ex.log = log.append
    ex.remote = type("Remote", (), {"remote": staticmethod(lambda fn, args: (fn, args))})()
    got: dict[str, Any] = {}
    ex.run([Task("t3", tasks.square, (3,))], lambda t, r: got.__setitem__(t.id, r))
    assert got["t3"]["square"] == 9
    assert log == [f"task t3: worker died (Ray lost it: {type(error).__name__}); retry 1 of 1"]
