"""Fault rows "bad timing accepted", "shutdown" and "bench.py processes and paths", from outside."""

from __future__ import annotations

import contextlib
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from msd_bench.app.bag_identification import IdentifierConfig, identify_from_bags
from msd_bench.graph import launch
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.reader import write_experiment

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.e2e


def _bag(path: Path, t: np.ndarray, role: str) -> None:
    n = t.size
    u = np.random.default_rng(0).choice([-10.0, 0.0, 10.0], n)
    write_experiment(path, t, u, np.zeros(n), np.zeros(n), params={"role": role, "signal": "multilevel"})


def _run(argv: list[str], cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=180,
                          env=launch.ros_env(int(os.environ["ROS_DOMAIN_ID"])))


def test_identification_refuses_a_1khz_bag_naming_both_rates(tmp_path: Path) -> None:
    """In-process (the identifier node's own function); the process path is the --bags test below."""
    bags = tmp_path / "bags"
    _bag(bags / "broad", np.arange(2000, dtype=np.int64) * 1_000_000, "train")
    _bag(bags / "val", np.arange(2000, dtype=np.int64) * 10_000_000, "validation")
    cfg = IdentifierConfig(bags_dir=str(bags), models=("glm",), out_dir=str(tmp_path / "models"))
    with pytest.raises(BagError) as err:
        identify_from_bags(cfg)
    line = str(err.value)
    assert "\n" not in line and str(bags / "broad") in line and "1000 Hz" in line and "100 Hz" in line
    assert not (tmp_path / "models" / "glm.json").exists()


def test_bench_bags_with_a_killed_recording_points_at_recover(tmp_path: Path) -> None:
    bags = tmp_path / "bags"
    _bag(bags / "broad", np.arange(500, dtype=np.int64) * 10_000_000, "train")
    _bag(bags / "val", np.arange(500, dtype=np.int64) * 10_000_000, "validation")
    (bags / "broad" / "metadata.yaml").unlink()
    proc = _run([sys.executable, str(REPO / "launch_scripts" / "bench.py"), "--bags", "bags",
                 "--out", "run", "--stages", "identify", "--agents", "glm"], cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "msd-bench bag recover" in proc.stderr and str(bags / "broad") in proc.stderr
    assert "no broad-range" not in proc.stderr
    assert (tmp_path / "run").is_dir() and not (REPO / "run").exists()  # relative to the caller


@pytest.mark.parametrize(("seed", "lockstep"), [(1, False), (2, False), (3, True)])
def test_sigint_at_a_random_moment_exits_0(seed: int, lockstep: bool) -> None:
    """Real-time (rclpy's default executor) and lock-step (the events executor) alike. On a fresh
    clone the first start compiles the plant's kernels, so a stop may land in the compiler: it waits
    for the compile-before-the-first-tick block and exits as cleanly (tests/nodes/test_stops_deferred.py)."""
    delay = random.Random(seed).uniform(0.0, 3.0)
    mode = "true" if lockstep else "false"
    proc = launch.start("plant.py", ["-p", "duplicate_check:=0.0", "-p", f"lockstep:={mode}"])
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    status = proc.wait(120.0)
    assert status == 0, (delay, proc.output())
    assert "Traceback" not in proc.output() and "error:" not in proc.output()


@pytest.mark.parametrize(("seed", "sig"), [(4, signal.SIGINT), (5, signal.SIGTERM)])
def test_a_stop_during_ros_training_exits_0(seed: int, sig: signal.Signals, tmp_path: Path) -> None:
    """The agent and the surrogate spin on the events executor: a stop that lands inside one of its
    callbacks still ends both processes cleanly (not a RuntimeError out of pybind11)."""
    model = REPO / "tests" / "data" / "pinned" / "plm.json"
    with launch.process_group() as procs:
        sur = procs.start("surrogate.py", ["-p", f"model_path:={model}", "-p", "lockstep:=true",
                                           "-p", "duplicate_check:=0.0", "-r", "__ns:=/surrogate/plm"])
        agent = procs.start("agent.py", [
            "-p", "kind:=plm+improved", "-p", f"model_path:={model}", "-p", "episodes:=100",
            "-p", "steps:=1000", "-p", "via_ros:=true", "-p", "surrogate_ns:=/surrogate/plm",
            "-p", f"out_dir:={tmp_path / 'agent'}"])
        agent.wait_for_line("training 1 seed", 60.0)
        sur.wait_for_line("ready", 60.0)
        time.sleep(random.Random(seed).uniform(1.0, 2.5))  # well inside training (100,000 steps)
        for proc in (agent, sur):
            os.killpg(proc.pid, sig)
            assert proc.wait(120.0) == 0, proc.output()
            assert "Traceback" not in proc.output() and "error" not in proc.output().lower()
        assert "shutdown: steps=" in sur.output() and "trained" not in agent.output()


def test_children_die_with_a_killed_bench(tmp_path: Path) -> None:
    bench = subprocess.Popen([sys.executable, str(REPO / "launch_scripts" / "bench.py"), "--out", "run",
                              "--samples", "600", "--val-samples", "400", "--agents", "glm"],
                             cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                             env=launch.ros_env(None), start_new_session=True)
    try:
        children = _wait_for_children(bench.pid, 60.0)
        assert children, "bench.py started no node process"
        os.kill(bench.pid, signal.SIGKILL)
        bench.wait(10)
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline and any(_alive(c) for c in children):
            time.sleep(0.1)
        assert not [c for c in children if _alive(c)]
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(bench.pid, signal.SIGKILL)  # bench.py's own session, should it have survived
        bench.stderr.close()  # type: ignore[union-attr]


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def _wait_for_children(pid: int, timeout: float) -> list[int]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        kids = _children(pid)
        if kids:
            time.sleep(1.0)  # let the plant get past its imports
            return _children(pid)
        time.sleep(0.1)
    return []


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"
