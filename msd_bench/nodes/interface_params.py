"""The plant interface as ROS parameters of each node that talks to a plant.

See docs/ros2-control.md §Parameters.

One call per node: the five parameters ``interface``, ``controller``, ``joint``,
``controller_joints`` and ``effort`` are declared from
:class:`msd_msgs_py.interface.InterfaceParams` (so ``ros2 param describe`` shows
their documentation) and resolved into a complete
:class:`~msd_msgs_py.interface.PlantInterface`; an inconsistent set is one
ConfigError line.
"""

from __future__ import annotations

from rclpy.node import Node

from msd_bench.core.errors import ConfigError, InterfaceError
from msd_bench.nodes.params import declare_from_dataclass
from msd_msgs_py.interface import InterfaceParams, PlantInterface


def declare_interface(node: Node, defaults: InterfaceParams | None = None) -> PlantInterface:
    """Declare the interface parameters on ``node`` and return the interface they describe."""
    params = declare_from_dataclass(node, InterfaceParams, defaults=defaults)
    try:
        return params.resolve()
    except InterfaceError as exc:
        raise ConfigError(f"interface parameters: {exc}") from None
