"""The plant as a real process: telemetry arrives, a second plant refuses, nothing is left behind."""

from __future__ import annotations

import os
import signal
import time
import warnings
from pathlib import Path

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64

from msd_bench.commands import topics
from msd_bench.graph import launch
from msd_msgs_py.contract import PLANT_NAMESPACE, POSITION
from msd_msgs_py.ros import qos

with warnings.catch_warnings():  # rclpy pulls in lark, which imports the deprecated sre_* modules
    warnings.filterwarnings("ignore", "module 'sre_.*' is deprecated", DeprecationWarning)
    import lark  # noqa: F401

pytestmark = pytest.mark.e2e


def _gone(pid: int) -> bool:
    try:
        os.killpg(pid, 0)
    except ProcessLookupError:
        return True
    return False


def _receive_positions(n: int, timeout: float) -> list[float]:
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        node = Node("e2e_probe", context=ctx)
        got: list[float] = []
        topic = POSITION.resolve(PLANT_NAMESPACE)
        node.create_subscription(Float64, topic, lambda m: got.append(m.data), qos(POSITION))
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        while len(got) < n and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        executor.shutdown()
        node.destroy_node()
        return got
    finally:
        rclpy.try_shutdown(context=ctx)


def test_plant_process_publishes_and_a_second_one_refuses(capsys):
    with launch.process_group() as procs:
        plant = procs.start("plant.py")
        plant.wait_for_line("ready", timeout=20.0)
        positions = _receive_positions(20, timeout=20.0)
        assert len(positions) == 20 and positions == [0.0] * 20  # at rest, no command

        assert topics.main(["echo", "/msd/position", "--count", "2"]) == 0
        assert topics.main(["hz", "/msd/joint_states", "--count", "60"]) == 0
        out = capsys.readouterr().out
        assert out.count("data: 0.0\n---\n") == 2
        last = out.rsplit("average rate: ", 1)[1]
        assert float(last.split()[0]) > 0 and "window: 59" in last  # rates: see benchmarks/

        second = procs.start("plant.py", name="plant2")
        assert second.wait(120.0) == 2
        lines = [ln for ln in second.lines if ln.strip()]
        assert lines[-1].startswith("error: /msd/joint_states already has a publisher")
        assert "Traceback" not in second.output()
        statuses = procs.stop_all()
    assert statuses["plant"] == 0 and "shutdown: steps=" in plant.output()
    assert _gone(plant.pid) and _gone(second.pid)


def test_bad_parameter_exits_with_one_line():
    proc = launch.start("plant.py", ["-p", "m:=-1"])
    assert proc.wait(120.0) == 2
    time.sleep(0.1)  # let the reader thread collect the last line
    assert [ln for ln in proc.lines if ln.strip()] == [
        "error: parameter m: value m out of range Min: 0.001, Max: 1000.0, value: -1.0"
    ]


def test_sigkilled_plant_leaves_no_shared_memory():
    proc = launch.start("plant.py", ["-p", "duplicate_check:=0.0"])
    proc.wait_for_line("ready", timeout=20.0)
    status = launch.stop(proc, grace=(0.0, 0.0, 5.0))  # escalate straight to SIGKILL
    assert status == -signal.SIGKILL and _gone(proc.pid)
    own = [s for s in proc.shm_files if not s.startswith(("fastdds_port", "fastrtps_port"))]
    assert own, "the plant had a Fast DDS segment of its own"
    leftovers = [s for s in proc.shm_files if (Path("/dev/shm") / s).exists()]
    assert not [s for s in leftovers if s in own]


def test_malformed_ros_args_exit_with_one_error_line():
    proc = launch.start("plant.py", ["-p"])  # a trailing -p: rcl refuses to initialise
    assert proc.wait(120.0) == 2
    time.sleep(0.1)
    assert "Traceback" not in proc.output()
    assert [ln for ln in proc.lines if ln.startswith("error: ")] == [
        "error: failed to initialize rcl: Couldn't parse trailing -p flag. No parameter override rule found."
    ]
