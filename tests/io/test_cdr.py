"""The direct JointState reader agrees with rosbags field by field, and declines what it does not know."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from msd_bench.io.bags.bag_writer import typestore
from msd_bench.io.bags.cdr import joint_state

STORE = typestore()
JS = "sensor_msgs/msg/JointState"


def _msg(frame: str, names: list[str], pos: list[float], vel: list[float], eff: list[float],
         sec: int = 12, nanosec: int = 340_000_000) -> Any:
    Header = STORE.types["std_msgs/msg/Header"]
    Time = STORE.types["builtin_interfaces/msg/Time"]
    JointState = STORE.types[JS]
    return JointState(Header(Time(sec, nanosec), frame), names, np.array(pos, dtype=np.float64),
                      np.array(vel, dtype=np.float64), np.array(eff, dtype=np.float64))


CASES = [
    ("", ["slider"], [0.25], [-1.5], [10.0]),  # the plant's row
    ("base_link", ["slider"], [0.25], [-1.5], [10.0]),  # a frame id moves every later field
    ("ab", ["wheel", "slider", "arm_joint_3"], [1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]),  # a rig
    ("", ["slider"], [0.5], [], [1.0]),  # no velocity: no alignment for an empty array
    ("x", ["slider"], [], [], []),  # nothing but names
    ("", [], [], [], []),
]


@pytest.mark.parametrize("case", CASES)
def test_decodes_what_rosbags_decodes(case: tuple[Any, ...]) -> None:
    raw = bytes(STORE.serialize_cdr(_msg(*case), JS))
    ref: Any = STORE.deserialize_cdr(raw, JS)
    row = joint_state(raw)
    assert row is not None
    assert row.stamp_ns == ref.header.stamp.sec * 10**9 + ref.header.stamp.nanosec
    assert row.name == list(ref.name)
    assert row.position == tuple(ref.position)
    assert row.velocity == tuple(ref.velocity)
    assert row.effort == tuple(ref.effort)


def test_decodes_what_rclpy_publishes() -> None:
    """The bytes a recorder stores are rmw's serialization, not rosbags'."""
    pytest.importorskip("rclpy")
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState(name=["arm", "slider"], position=[0.1, -0.2], velocity=[0.3, 0.4], effort=[5.0, -6.0])
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = 7, 10_000_000, "odd"
    row = joint_state(serialize_message(msg))
    assert row is not None
    assert (row.stamp_ns, row.name, row.position, row.effort) == (
        7_010_000_000, ["arm", "slider"], (0.1, -0.2), (5.0, -6.0))


def test_declines_what_it_does_not_know() -> None:
    good = bytes(STORE.serialize_cdr(_msg(*CASES[2]), JS))
    big_endian = bytes(STORE.serialize_cdr(_msg(*CASES[2]), JS, little_endian=False))
    assert joint_state(big_endian) is None
    assert joint_state(good[:-9]) is None  # truncated inside the effort array
    assert joint_state(good + bytes(16)) is None  # trailing bytes: not this layout
    assert joint_state(good[:10]) is None
    assert joint_state(b"") is None
