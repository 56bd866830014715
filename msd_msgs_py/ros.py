"""rclpy-side helpers of the contract: QoS profiles, message classes, conversions.

Imported only by nodes (it needs rclpy); bag code uses :mod:`msd_msgs_py.contract`.
"""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64, Float64MultiArray, String

from msd_msgs_py.contract import JOINT_NAME, TopicSpec
from msd_msgs_py.interface import PlantInterface

MESSAGE_CLASSES = {
    "std_msgs/msg/Float64": Float64,
    "std_msgs/msg/Float64MultiArray": Float64MultiArray,
    "std_msgs/msg/String": String,
    "std_msgs/msg/Empty": Empty,
    "sensor_msgs/msg/JointState": JointState,
    "rosgraph_msgs/msg/Clock": Clock,
    "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray,
}


def qos(spec: TopicSpec, depth: int | None = None) -> QoSProfile:
    """Reliable keep-last QoS of the topic's depth, or ``depth`` (transient-local if latched, else volatile).

    A deeper history on one side stays compatible with the other side's: depth is not matched."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=spec.depth if depth is None else depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if spec.latched else DurabilityPolicy.VOLATILE,
    )


def msg_class(spec: TopicSpec) -> type:
    """The generated Python class of the topic's type."""
    cls: type = MESSAGE_CLASSES[spec.ros_type]
    return cls


def nanoseconds_to_stamp(ns: int, stamp: object) -> None:
    """Fill a ``builtin_interfaces/Time`` in place from integer nanoseconds."""
    stamp.sec = int(ns // 1_000_000_000)  # type: ignore[attr-defined]
    stamp.nanosec = int(ns % 1_000_000_000)  # type: ignore[attr-defined]


def joint_state(stamp_ns: int, x: float, v: float, effort: float) -> JointState:
    """The plant's stamped telemetry sample."""
    msg = JointState()
    nanoseconds_to_stamp(stamp_ns, msg.header.stamp)
    msg.name = [JOINT_NAME]
    msg.position = [float(x)]
    msg.velocity = [float(v)]
    msg.effort = [float(effort)]
    return msg


def float64(value: float) -> Float64:
    """A ``std_msgs/Float64``."""
    return Float64(data=float(value))


def clock(stamp_ns: int) -> Clock:
    """A ``rosgraph_msgs/Clock`` at ``stamp_ns``."""
    msg = Clock()
    nanoseconds_to_stamp(stamp_ns, msg.clock)
    return msg


def command(iface: PlantInterface, u: float) -> Float64 | Float64MultiArray:
    """The command that asks ``iface``'s plant for force ``u`` on our joint (others get 0.0): the face's
    message type with the face's payload."""
    msg: Float64 | Float64MultiArray = msg_class(iface.command)(data=iface.command_data(u))
    return msg


def command_force(iface: PlantInterface, msg: Float64 | Float64MultiArray) -> float | None:
    """Our joint's force in a received command; None when the controller would ignore it (wrong length)."""
    if isinstance(msg, Float64):
        return float(msg.data)
    return iface.command_force(list(msg.data))


def joint_states(stamp_ns: int, names: list[str], x: list[float], v: list[float],
                 effort: list[float]) -> JointState:
    """A stamped multi-joint JointState (a joint state broadcaster's message)."""
    msg = JointState()
    nanoseconds_to_stamp(stamp_ns, msg.header.stamp)
    msg.name = list(names)
    msg.position = [float(a) for a in x]
    msg.velocity = [float(a) for a in v]
    msg.effort = [float(a) for a in effort]
    return msg
