"""The rig emulator as a real process: under /rig at 100 Hz, no reset, a second one refuses, clean stop."""

from __future__ import annotations

import time
import warnings

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from msd_bench.commands import topics
from msd_bench.graph import launch
from msd_msgs_py.contract import JOINT_STATES
from msd_msgs_py.ros import qos

with warnings.catch_warnings():  # rclpy pulls in lark, which imports the deprecated sre_* modules
    warnings.filterwarnings("ignore", "module 'sre_.*' is deprecated", DeprecationWarning)
    import lark  # noqa: F401

pytestmark = pytest.mark.e2e


def _rows_and_graph(n: int, timeout: float) -> tuple[list[JointState], int, int]:
    """n rows of /rig/joint_states, and the subscriber counts of /rig/reset and /rig/force."""
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        node = Node("e2e_rig_probe", context=ctx)
        got: list[JointState] = []
        node.create_subscription(JointState, JOINT_STATES.resolve("/rig"), got.append, qos(JOINT_STATES))
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        while len(got) < n and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        counts = node.count_subscribers("/rig/reset"), node.count_subscribers("/rig/force")
        executor.shutdown()
        node.destroy_node()
        return got, *counts
    finally:
        rclpy.try_shutdown(context=ctx)


def test_rig_process_serves_rig_without_reset_and_a_second_one_refuses(capsys):
    with launch.process_group() as procs:
        rig = procs.start("rig.py")
        rig.wait_for_line("ready", timeout=30.0)
        rows, reset_subs, force_subs = _rows_and_graph(50, timeout=20.0)
        assert len(rows) == 50 and (reset_subs, force_subs) == (0, 1)
        ys = [r.position[0] for r in rows]
        assert len(set(ys)) > 5 and max(abs(y) for y in ys) < 0.02  # at rest, read through 2 mm noise
        assert all(r.effort[0] == 0.0 for r in rows)  # no command: the drive applies nothing

        # 3 s of messages: a burst that catches up a stall averages out
        assert topics.main(["hz", "/rig/joint_states", "--count", "300"]) == 0
        rate = float(capsys.readouterr().out.rsplit("average rate: ", 1)[1].split()[0])
        assert 70 < rate < 130  # lenient: shared CPU; the conformance check measures it properly

        second = procs.start("rig.py", name="rig2")
        assert second.wait(120.0) == 2
        lines = [ln for ln in second.lines if ln.strip()]
        assert lines[-1].startswith("error: /rig/joint_states already has a publisher")
        assert "Traceback" not in second.output()
        statuses = procs.stop_all()
    assert statuses["rig"] == 0 and "shutdown: steps=" in rig.output()
