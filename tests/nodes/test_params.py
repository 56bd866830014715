"""Config dataclass -> ROS parameters: docs, ranges, coercion, one-line errors; the pacer."""

from __future__ import annotations

import numpy as np
import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.node import Node
from rclpy.parameter import Parameter

from msd_bench.core.errors import ConfigError
from msd_bench.core.identification.excitation import StepsConfig
from msd_bench.core.physics.plant import PlantParams, preset
from msd_bench.nodes.params import declare_from_dataclass, field_docs
from msd_bench.nodes.plant_node import PlantNodeConfig
from msd_bench.nodes.spin import DeadlinePacer


def test_field_docs_are_read_from_the_source():
    docs = field_docs(PlantParams)
    assert docs["m"] == "Mass in kg; > 0."
    assert docs["L"].startswith("Stroke in m")
    assert set(docs) == {"m", "c", "k", "g", "h", "L", "F", "dt"}


@pytest.mark.ros
def test_declares_each_field_with_description_range_and_default(ctx):
    node = Node("p", context=ctx)
    cfg = declare_from_dataclass(node, PlantNodeConfig)
    assert cfg == PlantNodeConfig()
    desc = node.describe_parameter("watchdog_timeout")
    assert desc.description.startswith("Real-time only: seconds without a command")
    assert desc.type == ParameterType.PARAMETER_DOUBLE and desc.read_only
    assert (desc.floating_point_range[0].from_value, desc.floating_point_range[0].to_value) == (
        0.001, 60.0)
    assert node.describe_parameter("lockstep").type == ParameterType.PARAMETER_BOOL


@pytest.mark.ros
def test_overrides_with_preset_defaults_and_int_to_float_coercion(ctx):
    node = Node("p", context=ctx, parameter_overrides=[Parameter("m", value=2)])
    params = declare_from_dataclass(node, PlantParams, defaults=preset("mild"))
    assert params == preset("mild", m=2.0) and isinstance(params.m, float)


@pytest.mark.ros
def test_tuple_fields_map_to_double_arrays(ctx):
    node = Node("p", context=ctx, parameter_overrides=[
        Parameter("steps.levels", value=[1, -2, 3]), Parameter("steps.dwell", value=7)])
    cfg = declare_from_dataclass(node, StepsConfig, "steps.")
    assert cfg == StepsConfig(levels=(1.0, -2.0, 3.0), dwell=7)


@pytest.mark.ros
@pytest.mark.parametrize(
    ("cls", "override", "message"),
    [
        (PlantParams, Parameter("m", value=-1.0), "plant parameter m must be finite and > 0"),
        (PlantParams, Parameter("k", value=float("nan")), "parameter k must be finite"),
        (PlantNodeConfig, Parameter("watchdog_timeout", value=100.0), "out of range"),
        (PlantNodeConfig, Parameter("lockstep", value="yes"), "expecting type 'BOOL'"),
        (StepsConfig, Parameter("dwell", value=0), "dwell must be >= 1"),
    ],
)
def test_bad_values_become_one_line_config_errors(ctx, cls, override, message):
    node = Node("p", context=ctx, parameter_overrides=[override])
    with pytest.raises(ConfigError, match=message) as info:
        declare_from_dataclass(node, cls)
    assert "\n" not in str(info.value)


MS = 1_000_000  # ns
T0 = 100_000 * MS  # a monotonic clock at 100 s


def test_pacer_runs_one_step_per_period_and_catches_up_a_stall():
    pacer = DeadlinePacer(0.01, max_lag=0.5)
    assert pacer.due(T0) == [T0]
    assert pacer.due(T0 + 10_100_000) == [T0 + 10 * MS]  # jitter never skips a step
    assert pacer.due(T0 + 19_900_000) == [T0 + 20 * MS]  # nor doubles one
    assert len(pacer.due(T0 + 70_200_000)) == 5  # a 50 ms stall: the missed slots run as a burst
    assert pacer.due(T0 + 70_500_000) == []
    assert pacer.due(T0 + 2000 * MS) == [T0 + 2000 * MS] and pacer.reanchors == 1  # too long


def test_pacer_without_lead_runs_a_step_at_its_deadline_never_before():
    pacer = DeadlinePacer(0.01, lead=0.0)
    assert pacer.due(T0) == [T0] and pacer.next_deadline_ns == T0 + 10 * MS
    assert pacer.due(T0 + 9_900_000) == []  # 0.1 ms early: not yet
    assert pacer.due(T0 + 10_100_000) == [T0 + 10 * MS]
    assert pacer.due(T0 + 29_900_000) == [T0 + 20 * MS]  # 9.9 ms late: still one step, no burst
    assert pacer.due(T0 + 30_100_000) == [T0 + 30 * MS]


@pytest.mark.parametrize("uptime_s", [5e3, 2e5, 3e7])
def test_pacer_deadlines_stay_an_exact_grid_at_any_uptime(uptime_s):
    """Stamps come from these deadlines: a float running sum drifted off the 10 ms grid by
    1 ns within a few hundred samples at an uptime of a few days (a CI failure)."""
    pacer = DeadlinePacer(0.01, lead=0.0)
    now = round(uptime_s * 1e9)
    deadlines = []
    for _ in range(100_000):
        deadlines += pacer.due(now)
        now = pacer.next_deadline_ns + 3_000  # each wake-up 3 µs late, as the thread's
    assert len(deadlines) == 100_000 and set(np.diff(deadlines).tolist()) == {10 * MS}


def _agent_job_file(tmp_path, **run):
    import json

    from msd_bench.app.config import RunConfig
    from msd_bench.app.job import job_document

    doc = job_document("agent", RunConfig(**run), {"kind": "glm", "model_path": "m.json", "out_dir": "out"})
    path = tmp_path / "agent.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_job_file_sets_the_declared_parameters_and_a_p_beside_it_wins(ctx, tmp_path):
    from msd_bench.nodes.agent_node import AgentNodeConfig
    from msd_bench.nodes.params import declare_config

    path = _agent_job_file(tmp_path, episodes=7, steps=40)
    node = Node("p", context=ctx, parameter_overrides=[Parameter("job", value=str(path)),
                                                       Parameter("steps", value=55)])
    cfg = declare_config(node, AgentNodeConfig, "agent")
    assert (cfg.episodes, cfg.steps) == (7, 55)
    assert node.get_parameter("episodes").value == 7  # ros2 param get shows what it runs with


def test_without_a_job_file_the_parameters_alone_decide(ctx):
    from msd_bench.app.job import SHARED_DEFAULTS
    from msd_bench.nodes.agent_node import AgentNodeConfig
    from msd_bench.nodes.params import declare_config

    node = Node("p", context=ctx, parameter_overrides=[Parameter("out_dir", value="o"),
                                                       Parameter("kind", value="dyna-q")])
    cfg = declare_config(node, AgentNodeConfig, "agent")
    assert (cfg.episodes, cfg.dt, cfg.force) == (SHARED_DEFAULTS["episodes"], SHARED_DEFAULTS["dt"],
                                                 SHARED_DEFAULTS["force"])
