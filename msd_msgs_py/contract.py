"""Topic names, ROS type names and QoS settings, free of any rclpy import.

The names here are *relative* (no leading slash) so every plant-like node —
the emulated plant under ``/msd``, a surrogate under ``/surrogate/plm``, a rig
driver — speaks the same contract under its own namespace; ``/clock`` is the
one absolute topic. Bag tooling imports this module without ROS installed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class TopicSpec:
    """One topic of the contract."""

    name: str
    """Relative name under the plant-like node's namespace (absolute for /clock)."""
    ros_type: str
    """ROS 2 interface name as rosbag2 stores it, e.g. ``std_msgs/msg/Float64``."""
    depth: int
    """Keep-last history depth of the reliable QoS profile."""
    doc: str
    """What the topic carries."""
    latched: bool = False
    """Transient-local durability: a late subscriber still gets the last message."""

    def resolve(self, namespace: str) -> str:
        """Absolute topic name under ``namespace`` (``/msd`` -> ``/msd/position``)."""
        if self.name.startswith("/"):
            return self.name
        return f"{namespace.rstrip('/')}/{self.name}"


PLANT_NAMESPACE = "/msd"
"""Namespace of the emulated plant (and of a real rig that replaces it)."""

SURROGATE_ROOT = "/surrogate"
"""Parent namespace of every surrogate node."""


def surrogate_namespace(name: str) -> str:
    """``/surrogate/<name>`` with ``name`` made a valid ROS namespace token.

    A model kind name such as ``nlarx-paper`` is not one (rcl refuses
    ``-r __ns:=/surrogate/nlarx-paper``): it becomes ``nlarx_paper``.
    """
    token = re.sub(r"\W", "_", name).strip("_") or "model"
    return f"{SURROGATE_ROOT}/{'m_' + token if token[0].isdigit() else token}"

JOINT_NAME = "msd_slider"
"""The one joint name in ``joint_states``."""

TELEMETRY_DEPTH = 1000
"""Reliable keep-last depth of ``position`` and ``/clock``: 10 s at 100 Hz."""

RECORD_DEPTH = 20_000
"""Depth of ``joint_states``, the topic bags are made of: 200 s at 100 Hz, or a whole lock-step
experiment of 13,000 samples that a slower recorder drains later, so bags lose nothing."""

POSITION = TopicSpec("position", "std_msgs/msg/Float64", TELEMETRY_DEPTH, "position x in m, 100 Hz")
JOINT_STATES = TopicSpec(
    "joint_states",
    "sensor_msgs/msg/JointState",
    RECORD_DEPTH,
    "stamped position (m), velocity (m/s), effort = force actually applied (N) over the next sample",
)
TRUTH_JOINT_STATES = TopicSpec(
    "truth/joint_states",
    "sensor_msgs/msg/JointState",
    RECORD_DEPTH,
    "scoring only: the emulator's noise-free row k (true position and velocity, effort as in "
    "joint_states, same stamp), published only while a sensor model measures joint_states "
    "(by the rig emulator only with publish_truth)",
)
FORCE = TopicSpec(
    "force", "std_msgs/msg/Float64", 1, "force command in N; non-finite rejected, saturated at ±F"
)
LOCKSTEP_COMMAND_DEPTH = 256
"""Depth of a lock-step plant's command subscription (and of an open-loop excitation's publisher): the
commands an excitation may have in flight before their samples come back. In real time only the
latest command matters (depth 1); in lock-step each command is one step, so none may be dropped."""
REFERENCE = TopicSpec("reference", "std_msgs/msg/Float64", 1, "set-point for the agent, m")
RESET = TopicSpec(
    "reset", "std_msgs/msg/Empty", 1, "return the plant-like node to rest at the origin, sample 0"
)
RECORDER_READY = TopicSpec(
    "recorder/ready", "std_msgs/msg/String", 1,
    "bag path of a recorder whose readers have all matched their publishers (latched)", latched=True,
)
PLANT_CLAIM = TopicSpec(
    "plant_claim", "std_msgs/msg/String", 1,
    "JSON {start_ns, pid, token, node, sent_ns, established} of a plant-like node serving this "
    "namespace, re-sent every second (latched); of the claims heard during a node's start-up window "
    "the earliest keeps the namespace, and a claim first heard later (or an established one) never "
    "stops a serving node", latched=True,
)
ESTOP = TopicSpec(
    "estop", "std_msgs/msg/Empty", 10,
    "latch the supervisor's e-stop (anyone may; always honoured): 0 N until cleared",
)
ESTOP_CLEAR = TopicSpec(
    "estop_clear", "std_msgs/msg/String", 10,
    "clear the supervisor's e-stop: the decimal latch count it reports on /diagnostics, nothing else",
)
DIAGNOSTICS = TopicSpec(
    "/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", 10,
    "health of every plant-like node at 1 Hz: counters, stall gaps, watchdog state, mode",
)
CLOCK = TopicSpec("/clock", "rosgraph_msgs/msg/Clock", TELEMETRY_DEPTH, "sim time, lock-step mode only")

TIME_TYPE = "builtin_interfaces/msg/Time"
"""Type of a header stamp and of ``/clock``'s time (a field type, not a topic's)."""
HEADER_TYPE = "std_msgs/msg/Header"
"""Type of ``joint_states``' header (a field type, not a topic's)."""
MULTI_ARRAY_LAYOUT_TYPE = "std_msgs/msg/MultiArrayLayout"
"""Type of a ``Float64MultiArray`` command's layout field (a field type, not a topic's)."""

ALL_TOPICS = (POSITION, JOINT_STATES, TRUTH_JOINT_STATES, FORCE, REFERENCE, RESET, CLOCK)
