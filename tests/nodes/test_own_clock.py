"""rclpy's ``use_sim_time`` is refused on plant-like nodes, at start and by a SetParameters call.

The run-time case is what ``ros2 param set /msd/plant use_sim_time true`` sends:
a ``rcl_interfaces/srv/SetParameters`` request from another participant.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.graph import launch
from msd_bench.io.storage.artifacts import Provenance, save_model
from msd_bench.nodes.plant_node import PlantNode, declare_true_plant
from msd_bench.nodes.recorder_node import RecorderNode
from msd_bench.nodes.rig_node import RigNode
from msd_bench.nodes.surrogate_node import build_surrogate
from tests.nodes.conftest import spin_until

pytestmark = pytest.mark.ros
SIM_TIME = Parameter("use_sim_time", value=True)
GLM = StepModel(kernels.KIND_LINEAR, np.array([5.0, 0.02, 0.01, -1.6, 0.68, 1.0, 0.5]), name="clock test")


def _plant(ctx: Context, _tmp: Path, extra: list[Parameter[Any]]) -> Node:
    return PlantNode(declare_true_plant, context=ctx, namespace="/ownclock",
                     parameter_overrides=[Parameter("duplicate_check", value=0.0), *extra])


def _rig(ctx: Context, _tmp: Path, extra: list[Parameter[Any]]) -> Node:
    return RigNode(context=ctx, namespace="/ownclock_rig",
                   parameter_overrides=[Parameter("duplicate_check", value=0.0), *extra])


def _surrogate(ctx: Context, tmp: Path, extra: list[Parameter[Any]]) -> Node:
    path = save_model(GLM, tmp / "glm.json", Provenance(seed=1))
    return build_surrogate(context=ctx, namespace="/ownclock_surrogate", parameter_overrides=[
        Parameter("model_path", value=str(path)), Parameter("duplicate_check", value=0.0), *extra])


PLANT_LIKE = pytest.mark.parametrize("build", [_plant, _rig, _surrogate], ids=["plant", "rig", "surrogate"])


@PLANT_LIKE
def test_use_sim_time_at_start_is_one_line(ctx: Context, tmp_path: Path, build: Any) -> None:
    with pytest.raises(ConfigError, match=r"^parameter use_sim_time: /ownclock\S* paces itself"):
        build(ctx, tmp_path, [SIM_TIME])


@PLANT_LIKE
def test_use_sim_time_false_is_accepted(ctx: Context, tmp_path: Path, build: Any) -> None:
    node = build(ctx, tmp_path, [Parameter("use_sim_time", value=False)])
    assert node.get_parameter("use_sim_time").value is False


@PLANT_LIKE
def test_ros2_param_set_use_sim_time_is_refused(ctx: Context, tmp_path: Path, build: Any) -> None:
    node = build(ctx, tmp_path, [])
    client_node = Node("param_setter", context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    for n in (node, client_node):
        executor.add_node(n)
    try:
        client = client_node.create_client(SetParameters, f"{node.get_fully_qualified_name()}/set_parameters")
        assert spin_until(executor, client.service_is_ready, 10.0)
        future = client.call_async(SetParameters.Request(parameters=[SIM_TIME.to_parameter_msg()]))
        assert spin_until(executor, future.done, 10.0)
        [result] = future.result().results
    finally:
        executor.shutdown()
    assert not result.successful
    assert result.reason.startswith("parameter use_sim_time:") and "own clock" in result.reason
    assert node.get_parameter("use_sim_time").value is False
    assert not node.get_clock().ros_time_is_active  # rclpy's TimeSource never switched


def test_the_recorder_keeps_use_sim_time(ctx: Context, tmp_path: Path) -> None:
    """The recorder's documented use: stamps from /clock (nodes/recorder_node.py)."""
    rec = RecorderNode(context=ctx, parameter_overrides=[Parameter("bag_path", value=str(tmp_path / "b")),
                                                         SIM_TIME])
    assert rec.get_parameter("use_sim_time").value is True
    assert rec.set_parameters([Parameter("use_sim_time", value=False)])[0].successful


@pytest.mark.e2e
def test_a_plant_process_with_use_sim_time_exits_2_with_one_line() -> None:
    with launch.process_group() as procs:
        plant = procs.start("plant.py", ["-p", "use_sim_time:=true", "-p", "duplicate_check:=0.0",
                                         "-r", "__ns:=/ownclock_process"])
        status = plant.wait(60.0)
    errors = [ln for ln in plant.lines if "error" in ln.lower()]
    assert status == 2, plant.output()
    assert len(errors) == 1 and errors[0].startswith("error: parameter use_sim_time:"), plant.output()
    assert "Traceback" not in plant.output()

