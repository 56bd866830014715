"""MsdBench-v0 over the rig emulator's ros2_control face: commands as vectors, positions from joint_states."""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator

import gymnasium
import numpy as np
import pytest

import msd_bench.gym  # noqa: F401  (registers MsdBench-v0)
from msd_bench.gym.ros_backend import RosBackendError
from msd_msgs_py.interface import make
from tests.gym.conftest import _spin

pytestmark = pytest.mark.ros
_names = itertools.count()
IFACE = make("ros2_control", controller_joints=["wheel", "slider_to_cart"])


@pytest.fixture
def r2c_rig() -> Iterator[str]:
    """A rig emulator with the ros2_control face (no sensor noise), served from a thread; yields its NS."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from msd_bench.nodes.rig_node import RigNode

    ns = f"/gymr2c{os.getpid()}_{next(_names)}"
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    values = {"duplicate_check": 0.0, "interface": "ros2_control", "sensor_noise": 0.0, "sensor_quant": 0.0,
              "controller_joints": ["wheel", "slider_to_cart"]}
    node = RigNode(namespace=ns, context=ctx,
                   parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
    yield from _spin(node, ctx, ns)


def test_episodes_over_the_ros2_control_face(r2c_rig: str) -> None:
    env = gymnasium.make("MsdBench-v0", ros_namespace=r2c_rig, ros_lockstep=False, ros_interface=IFACE,
                         episode_steps=30, target=1.0)
    obs, _ = env.reset(seed=0)
    assert abs(obs[0]) < 0.05  # came to rest (no reset on this face), wherever that is
    rows = [env.step(4) for _ in range(30)]
    xs = np.array([r[4]["x"] for r in rows])
    assert xs[-1] - xs[0] > 0.005  # +F on slider_to_cart moved it up
    assert rows[-1][3] is True
    env.close()


def test_lockstep_on_a_face_without_reset_is_one_line() -> None:
    with pytest.raises(RosBackendError, match="the ros2_control interface has no reset"):
        gymnasium.make("MsdBench-v0", ros_namespace="/nobody", ros_interface=IFACE)
