"""The rig emulator node: the plant's contract under /rig, real time only, no reset, imperfect."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from msd_bench.core.physics.plant import PlantParams
from msd_bench.nodes.plant_node import GraphConflictError
from msd_bench.nodes.rig_node import RigNode
from msd_msgs_py.contract import FORCE, JOINT_NAME, JOINT_STATES, POSITION, TRUTH_JOINT_STATES
from msd_msgs_py.ros import float64, qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros
REPO = Path(__file__).resolve().parents[2]


def make_rig(ctx, executor, namespace: str = "/rig", **params: Any) -> RigNode:
    overrides = [Parameter(n, value=v) for n, v in {"duplicate_check": 0.0, **params}.items()]
    rig = RigNode(context=ctx, namespace=namespace, parameter_overrides=overrides)
    executor.add_node(rig)
    return rig


def stamp_ns(msg: JointState) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


class Client:
    """A test-side node speaking the plant contract under /rig."""

    def __init__(self, ctx, executor) -> None:
        self.node = Node("client", namespace="/rig", context=ctx)
        self.force = self.node.create_publisher(Float64, FORCE.name, qos(FORCE))
        self.rows: list[JointState] = []
        self.arrivals: list[float] = []
        self.truth: list[JointState] = []
        self.positions: list[float] = []
        self.node.create_subscription(JointState, JOINT_STATES.name, self._on_row, qos(JOINT_STATES))
        self.node.create_subscription(JointState, TRUTH_JOINT_STATES.name, self.truth.append,
                                      qos(TRUTH_JOINT_STATES))
        self.node.create_subscription(Float64, POSITION.name, lambda m: self.positions.append(m.data),
                                      qos(POSITION))
        self.executor = executor
        executor.add_node(self.node)
        assert spin_until(executor, lambda: self.force.get_subscription_count() > 0)

    def _on_row(self, msg: JointState) -> None:
        self.rows.append(msg)
        self.arrivals.append(time.monotonic())

    def efforts(self) -> list[float]:
        return [r.effort[0] for r in self.rows]


def test_rig_serves_the_contract_without_reset_clock_or_truth(ctx, executor):
    make_rig(ctx, executor)
    client = Client(ctx, executor)
    assert spin_until(executor, lambda: len(client.rows) >= 20)
    graph = client.node
    spin_for(executor, 0.3)  # let discovery settle before asserting absences
    assert graph.count_subscribers("/rig/force") == 1
    assert graph.count_subscribers("/rig/reset") == 0
    assert graph.count_publishers("/clock") == 0
    assert graph.count_publishers("/rig/truth/joint_states") == 0
    assert graph.count_publishers("/rig/joint_states") == 1 and graph.count_publishers("/rig/position") == 1
    row = client.rows[-1]
    assert list(row.name) == [JOINT_NAME] and len(row.position) == len(row.velocity) == len(row.effort) == 1
    types = dict(graph.get_topic_names_and_types())
    assert types["/rig/joint_states"] == ["sensor_msgs/msg/JointState"]


def test_rate_is_100_hz_with_regular_stamps_despite_jitter(ctx, executor):
    make_rig(ctx, executor, jitter=0.004)
    client = Client(ctx, executor)
    assert spin_until(executor, lambda: len(client.rows) >= 5)
    n0, t0 = len(client.rows), time.monotonic()
    spin_for(executor, 2.0)
    rate = (len(client.rows) - n0) / (time.monotonic() - t0)
    assert 70 < rate < 130  # lenient: the CPU is shared; check-rig measures the rate properly
    stamps = np.diff([stamp_ns(r) for r in client.rows])
    assert np.all(stamps == 10_000_000)  # acquisition times: exactly regular, jitter or not
    lateness = np.array(client.arrivals) - np.array([stamp_ns(r) for r in client.rows]) * 1e-9
    assert np.ptp(lateness) > 0.0  # arrivals are not a fixed offset from the stamps


def test_effort_is_the_delayed_lagged_force_and_truth_is_opt_in(ctx, executor):
    make_rig(ctx, executor, delay_samples=2, actuator_tau=0.03, friction=0.0, publish_truth=True)
    client = Client(ctx, executor)
    assert spin_until(executor, lambda: len(client.truth) >= 5)
    client.force.publish(float64(4.0))
    assert spin_until(executor, lambda: any(e > 3.9 for e in client.efforts()), timeout=3.0)
    spin_for(executor, 0.3)
    e = np.array(client.efforts())
    first = int(np.argmax(e > 0))
    rise = e[first:first + 15]
    assert np.all(np.diff(rise) > 0) and rise[0] < 4.0
    gaps = 4.0 - rise
    assert np.allclose(-0.01 / np.log(gaps[1:] / gaps[:-1]), 0.03, rtol=1e-6)  # the lag's tau
    truth = {stamp_ns(m): m for m in client.truth}
    paired = [(r, truth[stamp_ns(r)]) for r in client.rows if stamp_ns(r) in truth]
    assert len(paired) > 20
    assert all(r.effort[0] == t.effort[0] for r, t in paired)
    assert any(r.position[0] != t.position[0] for r, t in paired)  # measured is not the truth
    assert max(abs(r.position[0] - t.position[0]) for r, t in paired) < 0.02  # 2 mm noise, 10 σ


def test_watchdog_disables_the_drive_and_non_finite_commands_are_rejected(ctx, executor):
    rig = make_rig(ctx, executor, watchdog_timeout=0.2, actuator_tau=0.0)
    client = Client(ctx, executor)
    client.force.publish(float64(3.0))
    assert spin_until(executor, lambda: 3.0 in client.efforts())
    client.force.publish(float64(math.nan))
    assert spin_until(executor, lambda: rig.counters["rejected"] == 1)
    client.force.publish(float64(25.0))
    assert spin_until(executor, lambda: 10.0 in client.efforts())
    spin_for(executor, 0.5)
    tail = client.efforts()[client.efforts().index(3.0):]
    assert set(tail) == {3.0, 10.0, 0.0} and all(math.isfinite(e) for e in tail)
    assert tail[-1] == 0.0 and tail.index(0.0) > tail.index(10.0)
    assert rig.counters["rejected"] == 1 and rig.counters["saturated"] == 1 and rig.counters["watchdog"] == 1
    zero_at = client.rows[len(client.efforts()) - len(tail) + tail.index(0.0)]
    last_ten = client.rows[len(client.efforts()) - len(tail) + tail.index(10.0)]
    gap = (stamp_ns(zero_at) - stamp_ns(last_ten)) * 1e-9
    assert gap < 0.2 + 0.15  # watchdog timeout plus lenient scheduling slack; no lag after the cut


def test_second_node_on_the_namespace_refuses_to_start(ctx, executor):
    make_rig(ctx, executor)
    with pytest.raises(GraphConflictError, match="already has a publisher"):
        RigNode(context=ctx, node_name="rig2",
                parameter_overrides=[Parameter("duplicate_check", value=1.0)])


@pytest.mark.parametrize(("args", "needle"), [
    (["-p", "friction:=-1.0"], "friction"),
    (["-p", "jitter:=0.02"], "below the sample time"),
    (["-p", "delay_sample:=2"], "did you mean delay_samples"),
    (["-p", "lockstep:=true"], "real time only"),
    (["-p", "population_seed:=-1"], "population_seed"),
    (["-p", "population_seed:=2147483648"], "population_seed"),
    (["-p", "population_seed:=abc"], "population_seed"),
    (["-p", "family:=scaeld"], "unknown rig family 'scaeld' (did you mean 'scaled'?)"),
])
def test_bad_parameters_are_one_line_errors_in_a_real_process(args, needle):
    proc = subprocess.run([sys.executable, "launch_scripts/rig.py", "--ros-args", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and needle in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr


def test_a_population_seed_serves_that_member_and_explicit_parameters_win(ctx, executor):
    from dataclasses import replace

    from msd_bench.core.rigs.population import draw
    member = draw(1001)
    rig = make_rig(ctx, executor, "/pop_a", population_seed=1001)
    assert rig.served() == member and rig.rig.params == member.params
    assert rig.rig.imperfections == member.imperfections
    assert rig._sensor_text().startswith(member.line() + " (population member)")
    rig.destroy_node()
    other = 1 - member.imperfections.delay_samples if member.imperfections.delay_samples < 2 else 0
    rig = make_rig(ctx, executor, "/pop_b", population_seed=1001, delay_samples=other, m=2.0)
    want = replace(member, params=replace(member.params, m=2.0),
                   imperfections=replace(member.imperfections, delay_samples=other))
    assert rig.served() == want
    assert "explicit delay_samples, m" in rig._sensor_text()
    rig.destroy_node()
    rig = make_rig(ctx, executor, "/pop_c", population_seed=1001, preset="default")
    assert rig.served().params == PlantParams() and rig.served().imperfections == member.imperfections
    rig.destroy_node()


def test_a_family_member_is_served_with_its_units_beyond_the_usual_ranges(ctx: Any, executor: Any) -> None:
    from msd_bench.core.rigs.families import draw
    from msd_bench.nodes.plant_node import PLANT_RANGES

    seed = next(s for s in range(1000, 1100) if PLANT_RANGES["F"][1] < draw("scaled", s).params.F)
    member = draw("scaled", seed)  # a force limit beyond the usual range: the range widens to hold it
    rig = make_rig(ctx, executor, "/fam_a", family="scaled", population_seed=seed)
    assert rig.served() == member and rig.rig.params == member.params
    assert rig.rig.imperfections == member.imperfections
    assert rig._sensor_text().startswith(member.line() + " (population member)")
    assert "[scaled: length x" in rig._sensor_text()
    rig.destroy_node()


def test_a_stage_is_served_with_its_offset_force_and_rate(ctx: Any, executor: Any) -> None:
    from msd_bench.core.rigs.families import draw

    member = draw("stage", 1000)
    rig = make_rig(ctx, executor, "/fam_s", family="stage", population_seed=1000)
    assert rig.served() == member and rig.rig.params == member.params and rig.imperfections.offset != 0.0
    assert rig._sensor_text().startswith(member.line() + " (population member)")
    rig.destroy_node()


def test_a_stages_drive_holds_it_under_its_loop_unless_told_to_run_bare(ctx: Any, executor: Any) -> None:
    """A stage member's drive adds its stated loop's force to every command (the effort moves with no
    command at all: the loop answers the offset force); stiffness and damping 0 run it bare (0 N)."""
    from msd_bench.core.rigs.families import draw

    member = draw("stage", 1000)
    held = make_rig(ctx, executor, "/hold_a", family="stage", population_seed=1000)
    assert held.hold == member.hold and held.served().hold == member.hold
    assert "held by kp" in held._sensor_text()
    bare = make_rig(ctx, executor, "/hold_b", family="stage", population_seed=1000, hold_stiffness=0.0,
                    hold_damping=0.0)
    assert bare.hold is None and "held by" not in bare._sensor_text()
    rows: dict[str, list[JointState]] = {"/hold_a": [], "/hold_b": []}
    probe = Node("probe", context=ctx)
    for ns, got in rows.items():
        probe.create_subscription(JointState, f"{ns}/{JOINT_STATES.name}", got.append, qos(JOINT_STATES))
    executor.add_node(probe)
    assert spin_until(executor, lambda: min(len(r) for r in rows.values()) >= 200, timeout=30.0)
    assert any(r.effort[0] != 0.0 for r in rows["/hold_a"])
    assert all(r.effort[0] == 0.0 for r in rows["/hold_b"])
    for node in (held, bare, probe):
        node.destroy_node()


def test_the_default_rig_is_the_reserved_member(ctx, executor):
    from msd_bench.core.physics.plant import PRESETS
    from msd_bench.core.rigs.rig import RigImperfections
    rig = make_rig(ctx, executor)
    assert rig.served().params == PRESETS["rig"] and rig.imperfections == RigImperfections()
    assert rig._sensor_text().startswith("rig 0: ")


def test_a_sample_the_middleware_refuses_is_dropped_not_fatal(ctx: Any, executor: Any) -> None:
    """At 1 kHz on a loaded machine a reliable reader that stops reading made publish raise in the sample
    thread, which ended the rig under every other reader: the sample is dropped and counted instead."""
    from rclpy._rclpy_pybind11 import RCLError

    node = make_rig(ctx, executor, f"/droprig{os.getpid()}")

    class _Refusing:
        def publish(self, _msg: Any) -> None:
            raise RCLError("Failed to publish: cannot publish data")

    node._pub_js = _Refusing()  # type: ignore[assignment]
    before = node._dropped
    node._tick(time.monotonic_ns())
    node._tick(time.monotonic_ns())
    assert node._dropped >= before + 2 and node.context.ok()
