"""A real local Ray cluster, started as a user would, runs ``msd-bench rigs`` through ``--ray-address``.

Two nodes on this machine (``ray start --head --port P`` given 127.0.0.1, and a second
``ray start --address 127.0.0.1:P``; ``--num-cpus 1`` each), joined at the address as given.
The sweeps' results (``rigs`` and ``paper``) must equal the local pool's bit for bit (timings
aside); killing the second node while it runs a task must cost a retry line, not the result; a
sweep stopped half-way resumes on the cluster. Each node is stopped through its own
``ray start --block`` process group (never a machine-wide ``ray stop``, which would end other
users' Ray processes too). What this proves: docs/cluster.md §A real cluster in the tests.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from msd_bench.app.ray_probe import alive_nodes
from msd_bench.core.errors import ConfigError
from tests.app.test_rigs import RIGS, _without_times
from tests.app.test_sweep_executors import PAPER, _without_run_facts

pytestmark = pytest.mark.cluster

RAY = Path(sys.executable).with_name("ray")
SWEEP = RIGS[:RIGS.index("--workers")] + RIGS[RIGS.index("--workers") + 2:]
SWEEP[SWEEP.index("--rigs") + 1] = "4"  # more tasks than the cluster's two CPUs: a node is busy when killed
ENV = {**os.environ, "RAY_AUTH_MODE": "disabled", "RAY_USAGE_STATS_ENABLED": "0"}
"""Token authentication off on both sides: whatever ~/.ray holds, the nodes and the driver agree."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _node(*args: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen([str(RAY), "start", "--block", "--num-cpus", "1", "--disable-usage-stats", *args],
                            env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, start_new_session=True)


def _stop(node: subprocess.Popen[bytes], now: bool = False) -> None:
    """End one node: its ``ray start --block`` process group (the raylet, its workers, the GCS);
    ``now``: SIGKILL at once, as a node that dies (no goodbye to the GCS)."""
    for sig in (signal.SIGKILL,) if now else (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(node.pid, sig)
        except ProcessLookupError:
            break
        try:
            node.wait(timeout=5)
        except subprocess.TimeoutExpired:
            continue
    try:
        os.killpg(node.pid, signal.SIGKILL)  # children the leader left behind
    except ProcessLookupError:
        pass
    finally:
        if node.stderr is not None:
            node.stderr.close()


def _wait_nodes(address: str, n: int, node: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        if node.poll() is not None:
            why = node.stderr.read().decode().strip().splitlines()[-1:] if node.stderr else []
            pytest.skip(f"ray start cannot run here: {why[0][:300] if why else 'it exited'}")
        try:
            if alive_nodes(address) >= n:
                return
        except ConfigError:
            pass
        time.sleep(1)
    pytest.fail(f"the Ray cluster at {address} did not reach {n} live nodes in 90 s")


@pytest.fixture(scope="module")
def cluster() -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """``(address as given, the worker node's process)``: a head and a worker on this machine."""
    if not RAY.exists():
        pytest.skip(f"no ray command beside {sys.executable}")
    port = _free_port()
    address = f"127.0.0.1:{port}"
    head = _node("--head", "--port", str(port), "--node-ip-address", "127.0.0.1", "--include-dashboard",
                 "false")
    worker = None
    try:
        _wait_nodes(address, 1, head)
        worker = _node("--address", address)
        _wait_nodes(address, 2, worker)
        yield address, worker
    finally:
        for node in (worker, head):
            if node is not None:
                _stop(node)


def _msd_bench(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "msd_bench.cli", *args], env=ENV, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)


def _rigs(out: Path) -> Any:
    return _without_times(json.loads((out / "rigs.json").read_text()))


@pytest.fixture(scope="module")
def local(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The local pool's rigs.json for the same sweep (the reference, bit for bit)."""
    out = tmp_path_factory.mktemp("local") / "out"
    proc = _msd_bench(*SWEEP, "--workers", "2", "--out", str(out))
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    return _rigs(out)


def _first_rig(proc: subprocess.Popen[str], out: Path) -> None:
    """Wait until the sweep wrote its first rig (three left, two of them running)."""
    deadline = time.monotonic() + 100
    while not list((out / "rigs").glob("rig-*.json")) and time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.2)


def _running_a_task(node: subprocess.Popen[bytes]) -> bool:
    """Whether a Ray worker started under ``node`` (a descendant of its ``ray start`` process) is
    executing a sweep task: Ray sets an executing worker's process title to ``ray::<function>``."""
    parent: dict[int, int] = {}
    titles: dict[int, str] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            titles[int(entry.name)] = (entry / "cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        parent[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    for pid, title in titles.items():
        if "_remote_call" not in title:
            continue
        up = pid
        while up > 1 and up != node.pid:
            up = parent.get(up, 0)
        if up == node.pid:
            return True
    return False


def _finish(proc: subprocess.Popen[str]) -> str:
    try:
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    return err


def test_a_sweep_killed_on_the_cluster_resumes_there_to_the_local_pools_result(
        cluster: tuple[str, subprocess.Popen[bytes]], local: Any, tmp_path: Path) -> None:
    address, _ = cluster
    args = [*SWEEP, "--executor", "ray", "--ray-address", address, "--out", str(tmp_path / "ray")]
    first = _msd_bench(*args)
    _first_rig(first, tmp_path / "ray")
    first.kill()  # the driver dies (SIGKILL): its finished rigs stay recorded
    first.communicate()
    assert not (tmp_path / "ray" / "rigs.json").exists()
    err = _finish(_msd_bench(*args))
    assert "resuming: " in err and " of 4 tasks already written, not recomputed" in err, err
    assert _rigs(tmp_path / "ray") == local


def test_paper_on_the_cluster_writes_the_tables_of_the_local_pool(
        cluster: tuple[str, subprocess.Popen[bytes]], tmp_path: Path) -> None:
    address, _ = cluster
    runs = {"local": _msd_bench(*PAPER, "--workers", "2", "--out", str(tmp_path / "local")),
            "ray": _msd_bench(*PAPER, "--executor", "ray", "--ray-address", address,
                              "--out", str(tmp_path / "ray"))}
    for proc in runs.values():
        _finish(proc)
    for name in ("table1.json", "robustness.json"):
        local, ray = (json.loads((tmp_path / d / name).read_text()) for d in runs)
        if name == "table1.json":
            assert ray["run"]["executor"] == "ray"
            local, ray = _without_run_facts(local), _without_run_facts(ray)
        assert ray == local


def test_rigs_on_a_real_cluster_equal_the_local_pool_and_survive_a_killed_node(
        cluster: tuple[str, subprocess.Popen[bytes]], local: Any, tmp_path: Path) -> None:
    """Last in the file: it kills the cluster's second node."""
    address, worker = cluster
    ray = _msd_bench(*SWEEP, "--executor", "ray", "--ray-address", address, "--retries", "3",
                     "--out", str(tmp_path / "ray"))
    try:
        deadline = time.monotonic() + 100
        while not _running_a_task(worker) and time.monotonic() < deadline:
            assert ray.poll() is None, ray.communicate()
            time.sleep(0.05)
        assert _running_a_task(worker), "the second node never ran a task"
        _stop(worker, now=True)  # while it runs a rig
    finally:
        err = _finish(ray)
    assert "worker died (Ray lost it:" in err and "retry 1 of 3" in err, err
    assert _rigs(tmp_path / "ray") == local
