"""The rig emulator's ros2_control face: Float64MultiArray commands, multi-joint joint_states, no position."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from msd_bench.core.errors import ConfigError
from msd_bench.nodes.rig_node import RigNode
from msd_msgs_py.contract import JOINT_STATES
from msd_msgs_py.interface import make
from msd_msgs_py.ros import command, qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros
IFACE = make("ros2_control", controller_joints=["wheel", "slider_to_cart"])


def r2c_rig(ctx, executor, **params) -> RigNode:  # type: ignore[no-untyped-def]
    values = {"duplicate_check": 0.0, "interface": "ros2_control",
              "controller_joints": ["wheel", "slider_to_cart"], **params}
    rig = RigNode(context=ctx, parameter_overrides=[Parameter(n, value=v) for n, v in values.items()])
    executor.add_node(rig)
    return rig


def test_ros2_control_face_on_the_wire(ctx, executor):  # type: ignore[no-untyped-def]
    rig = r2c_rig(ctx, executor, actuator_tau=0.03, delay_samples=1, friction=0.0, watchdog_timeout=0.3)
    client = Node("client", namespace="/rig", context=ctx)
    cmd = client.create_publisher(Float64MultiArray, "effort_controller/commands", qos(IFACE.command))
    rows: list[JointState] = []
    client.create_subscription(JointState, JOINT_STATES.name, rows.append, qos(JOINT_STATES))
    executor.add_node(client)
    assert spin_until(executor, lambda: cmd.get_subscription_count() > 0 and len(rows) > 5)
    spin_for(executor, 0.3)
    assert client.count_publishers("/rig/position") == 0 and client.count_subscribers("/rig/force") == 0
    assert client.count_subscribers("/rig/reset") == 0
    types = dict(client.get_topic_names_and_types())
    assert types["/rig/effort_controller/commands"] == ["std_msgs/msg/Float64MultiArray"]
    assert list(rows[-1].name) == ["pole_joint", "slider_to_cart"]  # ours is not first
    cmd.publish(command(IFACE, 4.0))  # [0.0, 4.0]: ours is the second controller joint
    assert spin_until(executor, lambda: rows[-1].effort[1] > 3.9, timeout=3.0)
    efforts = np.array([r.effort[1] for r in rows])
    first = int(np.argmax(efforts > 0))
    assert 0.0 < efforts[first] < 4.0  # measured effort: the actuator's lag shows
    assert all(r.effort[0] == 0.0 and r.position[0] == 0.0 for r in rows)  # the extra joint rests
    cmd.publish(Float64MultiArray(data=[1.0, 2.0, 3.0]))  # wrong length: refused, 4 N held
    assert spin_until(executor, lambda: rig.counters["rejected"] == 1)
    cmd.publish(command(IFACE, math.nan))
    assert spin_until(executor, lambda: rig.counters["rejected"] == 2)
    spin_for(executor, 0.1)
    assert rows[-1].effort[1] == pytest.approx(4.0, abs=0.05)  # still 4 N (not 2 N, not NaN)
    spin_for(executor, 0.6)  # no command: the watchdog cuts the drive
    assert rows[-1].effort[1] == 0.0 and rig.counters["watchdog"] == 1


def test_extra_joints_must_not_name_ours(ctx, executor):  # type: ignore[no-untyped-def]
    with pytest.raises(ConfigError, match="extra_joints must not name our joint 'slider_to_cart'"):
        r2c_rig(ctx, executor, extra_joints=["slider_to_cart"])
