"""The excitation node: waits for the plant, plays exactly the core signal, says when done."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification import excitation as exc
from msd_bench.nodes.excitation_node import ExcitationNode, ExcitationNodeConfig
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec
from msd_msgs_py.contract import FORCE, JOINT_STATES, LOCKSTEP_COMMAND_DEPTH
from msd_msgs_py.ros import qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros


def test_lockstep_plays_the_core_prbs_through_the_plant(ctx, executor):
    overrides = [
        Parameter("lockstep", value=True),
        Parameter("settle", value=0.0),
        Parameter("seed", value=7),
        Parameter("prbs.bias", value=5),  # an integer on a float field is accepted
        Parameter("prbs.n_samples", value=150),
        Parameter("prbs.settle", value=20),
        Parameter("prbs.hold", value=3),
    ]
    source = ExcitationNode(context=ctx, parameter_overrides=overrides)
    expected = exc.prbs(exc.PrbsConfig(bias=5.0, n_samples=150, settle=20, hold=3), seed=7)
    assert np.array_equal(source.signal, expected)
    executor.add_node(source)
    rows: list[JointState] = []
    probe = Node("probe", namespace="/msd", context=ctx)
    probe.create_subscription(JointState, JOINT_STATES.name, rows.append, qos(JOINT_STATES))
    executor.add_node(probe)
    spin_for(executor, 0.3)
    assert source.sent == 0  # no plant yet: nothing sent
    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    executor.add_node(plant)
    assert spin_until(executor, source.done.done, timeout=15.0)
    spin_for(executor, 0.1)
    assert source.done.result() == 0
    assert [r.effort[0] for r in rows] == list(expected)
    assert plant.k == expected.size


@pytest.mark.parametrize("window", [8, LOCKSTEP_COMMAND_DEPTH])
def test_lockstep_window_keeps_commands_in_flight_and_loses_none(ctx, executor, window):
    """Several commands ahead of the samples: the plant still steps each one once, in order."""
    overrides = [Parameter("lockstep", value=True), Parameter("settle", value=0.0),
                 Parameter("window", value=window), Parameter("seed", value=3),
                 Parameter("prbs.n_samples", value=600), Parameter("prbs.settle", value=0)]
    source = ExcitationNode(context=ctx, parameter_overrides=overrides)
    rows: list[JointState] = []
    peak = [0]

    def on_row(msg: JointState) -> None:  # how far the commands ran ahead of the samples seen so far
        rows.append(msg)
        peak[0] = max(peak[0], source.sent - len(rows))

    probe = Node("probe", namespace="/msd", context=ctx)
    probe.create_subscription(JointState, JOINT_STATES.name, on_row, qos(JOINT_STATES))
    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    for node in (source, probe, plant):
        executor.add_node(node)
    assert spin_until(executor, source.done.done, timeout=20.0)
    spin_for(executor, 0.1)
    assert source.done.result() == 0 and plant.k == source.signal.size == 600
    assert [r.effort[0] for r in rows] == list(np.clip(source.signal, -10.0, 10.0))
    assert [r.header.stamp.nanosec + r.header.stamp.sec * 10**9 for r in rows] == [
        k * 10_000_000 for k in range(600)]
    assert peak[0] > 1  # commands ran ahead (the window bounds sent - received by construction)


def test_window_above_the_plants_command_history_is_refused(ctx):
    with pytest.raises(ConfigError, match="window"):
        ExcitationNode(context=ctx,
                       parameter_overrides=[Parameter("window", value=LOCKSTEP_COMMAND_DEPTH + 1)])


def test_realtime_waits_for_a_subscriber_then_plays_the_signal(ctx, executor):
    signal = exc.steps(exc.StepsConfig(levels=(1.0, -2.0, 3.0), dwell=4))
    source = ExcitationNode(signal=signal, config=ExcitationNodeConfig(settle=0.05, dt=0.01),
                            context=ctx)
    executor.add_node(source)
    spin_for(executor, 0.3)
    assert source.sent == 0 and not source.done.done()
    got: list[float] = []
    probe = Node("probe", namespace="/msd", context=ctx)
    profile = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    probe.create_subscription(Float64, FORCE.name, lambda m: got.append(m.data), profile)
    executor.add_node(probe)
    assert spin_until(executor, source.done.done, timeout=10.0)
    spin_for(executor, 0.1)
    assert got == list(signal) and source.done.result() == 0


def test_gives_up_with_status_1_when_no_plant_appears(ctx, executor):
    source = ExcitationNode(signal=np.ones(3), config=ExcitationNodeConfig(start_timeout=0.2),
                            context=ctx)
    executor.add_node(source)
    assert spin_until(executor, source.done.done, timeout=3.0)
    assert source.done.result() == 1 and source.sent == 0


def test_unknown_signal_kind_is_a_config_error(ctx):
    with pytest.raises(ConfigError, match="signal must be one of"):
        ExcitationNode(context=ctx, parameter_overrides=[Parameter("signal", value="chirp")])


def test_pooled_endpoints_need_lockstep(ctx):
    """A free-running plant publishes between experiments: a kept subscription would carry them over."""
    with pytest.raises(ConfigError, match="pooled needs lockstep"):
        ExcitationNode(context=ctx, parameter_overrides=[Parameter("pooled", value=True)])


def test_ros2_control_face_plays_the_signal_as_command_vectors(ctx, executor):
    """Parameters choose the face: Float64MultiArray on /rig/effort_controller/commands, ours second."""
    from std_msgs.msg import Float64MultiArray

    signal = exc.steps(exc.StepsConfig(levels=(1.0, -2.0, 3.0), dwell=3))
    overrides = [Parameter("interface", value="ros2_control"),
                 Parameter("controller_joints", value=["pole", "slider_to_cart"])]
    source = ExcitationNode(signal=signal, config=ExcitationNodeConfig(settle=0.05, dt=0.01),
                            namespace="/rig", context=ctx, parameter_overrides=overrides)
    executor.add_node(source)
    got: list[list[float]] = []
    probe = Node("probe", namespace="/rig", context=ctx)
    profile = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    probe.create_subscription(Float64MultiArray, "effort_controller/commands",
                              lambda m: got.append(list(m.data)), profile)
    executor.add_node(probe)
    assert spin_until(executor, source.done.done, timeout=10.0)
    spin_for(executor, 0.1)
    assert got == [[0.0, u] for u in signal] and source.done.result() == 0


def test_reset_first_on_a_face_without_reset_is_a_config_error(ctx):
    with pytest.raises(ConfigError, match="reset_first: the ros2_control interface has no reset"):
        ExcitationNode(signal=np.ones(3), config=ExcitationNodeConfig(reset_first=True), context=ctx,
                       parameter_overrides=[Parameter("interface", value="ros2_control")])
