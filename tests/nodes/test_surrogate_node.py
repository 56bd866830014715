"""The surrogate node: a served artifact equals StepModel.simulate in lock-step; bad paths give one line."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.validate_namespace import validate_namespace
from std_msgs.msg import Float64

from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.graph import launch
from msd_bench.graph.bench import BenchConfig, agent_job, surrogate_args
from msd_bench.io.storage.artifacts import ArtifactError, Provenance, load_model, save_model
from msd_bench.nodes.surrogate_node import build_surrogate, surrogate_namespace
from msd_msgs_py.contract import CLOCK, FORCE, JOINT_STATES, POSITION
from msd_msgs_py.contract import surrogate_namespace as surrogate_namespace_for
from msd_msgs_py.ros import float64, msg_class, qos
from tests.nodes.conftest import spin_until

pytestmark = pytest.mark.ros

# x[k+1] = 0.02 u[k] + 0.01 u[k-1] + 1.6 x[k] - 0.68 x[k-1] around (u0, y0) = (1, 0.5); poles 0.8 ± 0.2j
GLM = StepModel(kernels.KIND_LINEAR, np.array([5.0, 0.02, 0.01, -1.6, 0.68, 1.0, 0.5]), name="glm test")


def _overrides(path: object, **extra: object) -> list[Parameter]:
    values = {"model_path": str(path), "lockstep": True, "duplicate_check": 0.0, **extra}
    return [Parameter(k, value=v) for k, v in values.items()]


def test_served_artifact_answers_lockstep_commands_like_simulate(ctx, executor, tmp_path):
    path = save_model(GLM, tmp_path / "glm.json", Provenance(seed=3))
    node = build_surrogate(context=ctx, parameter_overrides=_overrides(path, force_limit=4.0))
    executor.add_node(node)
    assert node.get_namespace() == surrogate_namespace(GLM) == "/surrogate/glm_test"
    client = Node("client", namespace=node.get_namespace(), context=ctx)
    executor.add_node(client)
    pub = client.create_publisher(Float64, FORCE.name, qos(FORCE))
    positions: list[float] = []
    rows: list = []
    client.create_subscription(Float64, POSITION.name, lambda m: positions.append(m.data), qos(POSITION))
    client.create_subscription(msg_class(JOINT_STATES), JOINT_STATES.name, rows.append, qos(JOINT_STATES))
    assert spin_until(executor, lambda: pub.get_subscription_count() > 0)

    u = np.random.default_rng(7).uniform(-6.0, 6.0, 60)  # some beyond ±4 N: saturated
    for k, value in enumerate(u):
        pub.publish(float64(value))
        assert spin_until(executor, lambda k=k: len(positions) > k and len(rows) > k)
    applied = np.clip(u, -4.0, 4.0)
    model = load_model(path)
    assert np.array_equal(positions, model.simulate(np.append(applied, 0.0))[1:])
    assert np.array_equal([r.effort[0] for r in rows], applied)
    assert np.array_equal([r.position[0] for r in rows], model.simulate(applied))
    assert node.counters["saturated"] == int(np.sum(np.abs(u) > 4.0)) > 0


def test_missing_model_path_is_one_config_line(ctx):
    with pytest.raises(ConfigError, match=r"^SurrogateConfig parameters: model_path is required") as err:
        build_surrogate(context=ctx, parameter_overrides=[])
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("content", "match"), [
    (None, "no such artifact"),
    ("{not json", "not valid JSON"),
    ('{"schema": "other"}', "not a msd-bench/model artifact"),
])
def test_bad_model_path_is_one_artifact_line(ctx, tmp_path, content, match):
    path = tmp_path / "model.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ArtifactError, match=match) as err:
        build_surrogate(context=ctx, parameter_overrides=_overrides(path))
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)


@pytest.mark.e2e
def test_launch_script_exits_with_one_line_on_a_missing_artifact(tmp_path):
    proc = launch.start("surrogate.py", ["-p", f"model_path:={tmp_path / 'nope.json'}"])
    assert proc.wait(120.0) == 2
    assert [ln for ln in proc.lines if ln.strip()] == [f"error: {tmp_path / 'nope.json'}: no such artifact"]


@pytest.mark.parametrize(("extra", "owns"), [({}, False), ({"publish_clock": True}, True)])
def test_a_lockstep_surrogate_leaves_clock_to_the_plant_unless_asked(ctx, executor, tmp_path, extra, owns):
    """One /clock owner per graph: the plant publishes sim time, a surrogate beside it does not."""
    path = save_model(GLM, tmp_path / "glm.json", Provenance(seed=3))
    node = build_surrogate(context=ctx, parameter_overrides=_overrides(path, **extra))
    executor.add_node(node)
    client = Node("client", namespace=node.get_namespace(), context=ctx)
    executor.add_node(client)
    pub = client.create_publisher(Float64, FORCE.name, qos(FORCE))
    rows: list = []
    client.create_subscription(msg_class(JOINT_STATES), JOINT_STATES.name, rows.append, qos(JOINT_STATES))
    assert spin_until(executor, lambda: pub.get_subscription_count() > 0)
    pub.publish(float64(1.0))
    assert spin_until(executor, lambda: len(rows) == 1)  # it steps in lock-step all the same
    assert node.get_parameter("publish_clock").value is owns
    owners = [i.node_name for i in client.get_publishers_info_by_topic(CLOCK.name)]
    assert owners == (["surrogate"] if owns else [])


@pytest.mark.parametrize("kind", ["glm", "nlarx-paper", "nlarx-improved+robust"])
def test_via_ros_surrogate_and_agent_agree_on_a_valid_namespace(tmp_path, kind):
    """bench.py --via-ros starts the surrogate and points the agent at it: one valid namespace for both
    (``/surrogate/nlarx-paper`` is not one: rcl refuses to start on it)."""
    cfg = BenchConfig(tmp_path, RunConfig(agents=(kind,)), via_ros=True)
    model = agent_kind(kind).surrogate
    ns = next(a.split(":=")[1] for a in surrogate_args(cfg, model) if a.startswith("__ns:="))
    assert validate_namespace(ns) and ns == surrogate_namespace_for(model)
    assert agent_job(cfg, kind)["params"]["surrogate_ns"] == ns
