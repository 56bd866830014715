"""The plant interface description: defaults, validation, conversions, CLI and ROS parameters."""

from __future__ import annotations

import argparse
import math

import pytest

from msd_bench.core.errors import InterfaceError, MsdBenchError
from msd_msgs_py import interface as iface_mod
from msd_msgs_py.contract import FORCE, JOINT_NAME, POSITION, RESET
from msd_msgs_py.interface import (
    MSD_INTERFACE,
    InterfaceParams,
    PlantInterface,
    add_cli_options,
    from_cli,
    make,
)


def parse(argv: list[str]) -> PlantInterface:
    parser = argparse.ArgumentParser()
    add_cli_options(parser)
    return from_cli(parser.parse_args(argv))


def test_msd_face_is_todays_contract() -> None:
    i = make()
    assert i == MSD_INTERFACE
    assert (i.command, i.position, i.reset) == (FORCE, POSITION, RESET)
    assert i.joint == JOINT_NAME and i.effort == "commanded" and i.effort_is_commanded
    assert i.command_values(3.5) == [3.5]
    assert i.command_force([2.0]) == 2.0


def test_ros2_control_defaults() -> None:
    i = make("ros2_control")
    assert (i.controller, i.joint, i.controller_joints, i.effort) == (
        "effort_controller", "slider_to_cart", ("slider_to_cart",), "measured")
    assert i.command.name == "effort_controller/commands"
    assert i.command.ros_type == "std_msgs/msg/Float64MultiArray"
    assert i.command.resolve("/rig") == "/rig/effort_controller/commands"
    assert i.state.resolve("/rig") == "/rig/joint_states"
    assert i.position is None and i.reset is None and not i.effort_is_commanded


def test_command_vector_follows_the_controller_joint_order() -> None:
    i = make("ros2_control", controller_joints=["pole", "slider_to_cart", "wheel"])
    assert i.joint_index == 1
    assert i.command_values(-4.0) == [0.0, -4.0, 0.0]
    assert i.command_force([9.0, -4.0, 7.0]) == -4.0
    assert i.command_force([1.0, 2.0]) is None  # wrong length: the controller ignores it


def test_pick_our_joint_from_a_multi_joint_message() -> None:
    i = make("ros2_control")
    s = i.pick(["pole", "slider_to_cart"], [0.1, 0.2], [1.1, 1.2], [5.0, 6.0])
    assert (s.position, s.velocity, s.effort) == (0.2, 1.2, 6.0)
    s = i.pick(["pole", "slider_to_cart"], [0.1, 0.2], [], [5.0])  # arrays may be short or empty
    assert s.position == 0.2 and math.isnan(s.velocity) and math.isnan(s.effort)


def test_pick_absent_joint_is_one_line() -> None:
    absent = r"joint 'slider_to_cart' is not in joint_states \(has \['pole'\]\)"
    with pytest.raises(InterfaceError, match=absent):
        make("ros2_control").pick(["pole"], [0.1], [0.0], [0.0])
    with pytest.raises(InterfaceError, match="no position"):
        make("ros2_control").pick(["slider_to_cart"], [], [], [])
    # msd: a single-joint message is ours whatever its name; several need ours by name
    assert MSD_INTERFACE.pick(["cart"], [0.3], [0.0], [1.0]).position == 0.3
    with pytest.raises(InterfaceError, match="msd_slider"):
        MSD_INTERFACE.pick(["a", "b"], [0.1, 0.2], [0, 0], [0, 0])


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"interface": "canopen"}, "interface must be one of msd, ros2_control"),
    ({"interface": "msd", "controller": "c"}, "ros2_control options"),
    ({"interface": "ros2_control", "effort": "guessed"}, "effort must be one of"),
    ({"interface": "ros2_control", "controller": "/abs"}, "not a relative ROS name"),
    ({"interface": "ros2_control", "controller_joints": ("a", "b")}, "not among the controller joints"),
    ({"interface": "ros2_control", "controller_joints": ("slider_to_cart",) * 2}, "twice"),
    ({"interface": "ros2_control", "joint": "a b"}, "space"),
])
def test_inconsistent_descriptions_are_one_line_errors(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(InterfaceError, match=message) as err:
        InterfaceParams(**kwargs).resolve()  # type: ignore[arg-type]
    assert isinstance(err.value, MsdBenchError) and "\n" not in str(err.value)


def test_cli_options() -> None:
    i = parse(["--interface", "ros2_control", "--controller", "effort_controller",
               "--joint", "slider_to_cart", "--controller-joints", "pole,slider_to_cart"])
    assert i.controller_joints == ("pole", "slider_to_cart") and i.joint_index == 1
    assert parse([]) == MSD_INTERFACE
    assert parse(["--interface", "ros2_control", "--effort", "commanded"]).effort == "commanded"
    assert parse(i.cli_args()) == i  # round trip
    with pytest.raises(InterfaceError, match="empty name"):
        parse(["--interface", "ros2_control", "--controller-joints", "a,,slider_to_cart"])


def test_params_round_trip_and_description() -> None:
    i = make("ros2_control", controller="arm/effort", controller_joints=["x", "slider_to_cart"])
    assert i.params().resolve() == i
    assert i.as_dict()["command_topic"] == "arm/effort/commands"
    assert "/rig/arm/effort/commands" in i.describe("/rig")
    assert iface_mod.INTERFACE_KINDS == ("msd", "ros2_control")
