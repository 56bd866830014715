"""Fault row "invisible health": /diagnostics at 1 Hz with counters, stalls, watchdog state, mode."""

from __future__ import annotations

import itertools
import math
import os
import signal
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64

from msd_bench.graph import launch
from msd_bench.nodes.health import StallTracker
from msd_msgs_py.contract import DIAGNOSTICS, FORCE
from msd_msgs_py.ros import qos

pytestmark = pytest.mark.e2e


def _values(msg: DiagnosticArray) -> dict[str, str]:
    return {kv.key: kv.value for kv in msg.status[0].values}


def test_plant_process_reports_health_and_logs_a_stall() -> None:
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    got: list[tuple[float, DiagnosticArray]] = []
    with launch.process_group() as procs:
        plant = procs.start("plant.py", ["-p", "duplicate_check:=0.0"])
        plant.wait_for_line(r"ready \(", 120.0)
        try:
            node = Node("health_probe", context=ctx)
            node.create_subscription(DiagnosticArray, DIAGNOSTICS.name,
                                     lambda m: got.append((time.monotonic(), m)), qos(DIAGNOSTICS))
            force = node.create_publisher(Float64, "/msd/force", qos(FORCE))
            ex = SingleThreadedExecutor(context=ctx)
            ex.add_node(node)
            deadline = time.monotonic() + 20.0
            sent = False
            stopped = False
            while time.monotonic() < deadline and len(got) < 6:
                ex.spin_once(timeout_sec=0.05)
                if len(got) >= 1 and not sent and force.get_subscription_count():
                    force.publish(Float64(data=math.nan))
                    time.sleep(0.1)  # force is keep-last 1: let the plant take the NaN first
                    force.publish(Float64(data=50.0))
                    sent = True
                if len(got) >= 3 and not stopped:
                    os.kill(plant.pid, signal.SIGSTOP)  # a 1.5 s stall of the whole process
                    time.sleep(1.5)
                    os.kill(plant.pid, signal.SIGCONT)
                    stopped = True
            ex.shutdown()
            node.destroy_node()
        finally:
            rclpy.try_shutdown(context=ctx)
        plant.wait_for_line(r"stall: no timer tick for 1\.[4-9]", 5.0)
        assert "Traceback" not in plant.output()
    assert len(got) >= 6
    gaps = [b[0] - a[0] for a, b in itertools.pairwise(got[:3])]
    assert all(0.5 < g < 1.5 for g in gaps), gaps  # 1 Hz before the stall (loaded machine: ±0.5 s)
    last = _values(got[-1][1])
    assert last["mode"] == "real-time 100 Hz"
    assert int(last["rejected"]) == 1 and int(last["saturated"]) == 1
    assert int(last["stalls"]) >= 1 and float(last["longest_stall_s"]) >= 1.4
    assert last["watchdog_state"] in {"armed", "tripped", "idle"} and int(last["watchdog"]) >= 1
    assert any(m.status[0].level == m.status[0].WARN for _, m in got)  # rejected/saturated second


def test_stall_tracker_counts_only_gaps_over_one_sample() -> None:
    s = StallTracker(0.01)
    assert s.tick(0.0) is None and s.tick(0.011) is None and s.tick(0.030) is None  # 19 ms: not a stall
    assert s.tick(0.530) == pytest.approx(0.5)
    assert (s.count, s.longest_s) == (1, pytest.approx(0.5))
