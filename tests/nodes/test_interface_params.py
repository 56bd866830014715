"""The plant interface as ROS parameters: declared per node, built from ``ros_args``, one-line errors."""

from __future__ import annotations

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter

from msd_bench.core.errors import ConfigError
from msd_bench.nodes.interface_params import declare_interface
from msd_msgs_py.interface import MSD_INTERFACE, make


@pytest.mark.ros
def test_ros_parameters_build_the_same_interface(ctx) -> None:  # type: ignore[no-untyped-def]
    i = make("ros2_control", controller_joints=["pole", "slider_to_cart"])
    overrides = [Parameter("interface", value="ros2_control"),
                 Parameter("controller_joints", value=["pole", "slider_to_cart"])]
    node = Node("p", context=ctx, parameter_overrides=overrides)
    assert declare_interface(node) == i
    assert node.describe_parameter("controller").description.startswith("ros2_control: the forward")
    assert declare_interface(Node("q", context=ctx)) == MSD_INTERFACE
    bad = Node("r", context=ctx, parameter_overrides=[Parameter("controller", value="c")])
    with pytest.raises(ConfigError, match="interface parameters: controller and controller_joints"):
        declare_interface(bad)


@pytest.mark.ros
@pytest.mark.parametrize("iface", [
    make("ros2_control", controller="arm/effort", controller_joints=["pole", "slider_to_cart"]),
    make("ros2_control", effort="commanded"),
    MSD_INTERFACE,
])
def test_ros_args_rebuild_the_interface_in_a_node(ctx, iface) -> None:  # type: ignore[no-untyped-def]
    node = Node("p", context=ctx, cli_args=["--ros-args", *iface.ros_args()])
    assert declare_interface(node) == iface
