"""The probe of the cross-distribution test, run by the *other* distribution's python.

Publishes a constant force on ``/msd/force`` at 50 Hz (well inside the plant's
0.5 s watchdog) and listens to ``/msd/joint_states`` until ``rows`` samples carry
that force as their effort — the force the plant actually applied, so each such
row proves a command crossed one way and telemetry the other. Prints one JSON
line; exit status 1 if the wanted rows did not arrive within ``timeout`` s.

    <venv>/bin/python tests/e2e/cross_probe.py FORCE ROWS TIMEOUT
"""

from __future__ import annotations

import json
import sys
import time
from importlib import metadata
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import rclpy
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from msd_msgs_py.contract import FORCE, JOINT_STATES, PLANT_NAMESPACE
from msd_msgs_py.ros import float64, qos


class Tally:
    """Counts of the rows received and of those whose effort is the probe's force."""

    def __init__(self, force: float) -> None:
        self.force = force
        self.rows = 0
        self.pushed = 0
        self.last_x = 0.0

    def __call__(self, msg: JointState) -> None:
        self.rows += 1
        self.pushed += msg.effort[0] == self.force
        self.last_x = msg.position[0]


def probe(force: float, rows: int, timeout: float) -> dict[str, object]:
    """Push and listen until ``rows`` pushed samples arrived or ``timeout`` passed."""
    node = rclpy.create_node("cross_probe")
    tally = Tally(force)
    node.create_subscription(JointState, JOINT_STATES.resolve(PLANT_NAMESPACE), tally, qos(JOINT_STATES))
    pub = node.create_publisher(Float64, FORCE.resolve(PLANT_NAMESPACE), qos(FORCE))
    node.create_timer(0.02, lambda: pub.publish(float64(force)))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    t0 = time.monotonic()
    while tally.pushed < rows and time.monotonic() - t0 < timeout:
        executor.spin_once(timeout_sec=0.05)
    seconds = time.monotonic() - t0
    executor.shutdown()
    node.destroy_node()
    return {"rclpy": metadata.version("ros-rclpy"), "rows": tally.rows, "pushed_rows": tally.pushed,
            "last_x": tally.last_x, "seconds": round(seconds, 3)}


def main() -> int:
    force, rows, timeout = float(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
    rclpy.init(args=[])
    try:
        result = probe(force, rows, timeout)
    finally:
        rclpy.try_shutdown()
    print(json.dumps(result), flush=True)
    return 0 if result["pushed_rows"] >= rows else 1


if __name__ == "__main__":
    sys.exit(main())
