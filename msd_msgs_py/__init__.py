"""The wire contract of msd-bench: topic names, message types, QoS and conversions.

This is the only place that names a topic, a message type or a QoS profile
(docs/design.md §Contract). A real rig that speaks these topics can replace the plant.
"""

from msd_msgs_py.contract import (
    CLOCK,
    FORCE,
    JOINT_NAME,
    JOINT_STATES,
    PLANT_NAMESPACE,
    POSITION,
    REFERENCE,
    RESET,
    TopicSpec,
)

__all__ = [
    "CLOCK",
    "FORCE",
    "JOINT_NAME",
    "JOINT_STATES",
    "PLANT_NAMESPACE",
    "POSITION",
    "REFERENCE",
    "RESET",
    "TopicSpec",
]
