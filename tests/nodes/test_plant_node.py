"""The plant node against the core: lock-step bit-exactness, bad commands, watchdog, reset."""

from __future__ import annotations

import itertools
import math
import threading
import time

import numpy as np
import pytest
import rclpy
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64

from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.plant import preset, simulate
from msd_bench.nodes.plant_node import (
    EXIT_TICK_FAILED,
    GraphConflictError,
    ModelSpec,
    PlantNode,
    PlantNodeConfig,
    true_plant_spec,
)
from msd_msgs_py.contract import CLOCK, FORCE, JOINT_STATES, POSITION, RESET
from msd_msgs_py.ros import float64, qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros

LOCKSTEP = PlantNodeConfig(lockstep=True, duplicate_check=0.0)


class Client:
    """A test-side node speaking the plant contract under /msd."""

    def __init__(self, ctx, executor) -> None:
        self.node = Node("client", namespace="/msd", context=ctx)
        self.force = self.node.create_publisher(Float64, FORCE.name, qos(FORCE))
        self.reset = self.node.create_publisher(Empty, RESET.name, qos(RESET))
        self.rows: list[JointState] = []
        self.positions: list[float] = []
        self.clocks: list[int] = []
        self.node.create_subscription(JointState, JOINT_STATES.name, self.rows.append, qos(JOINT_STATES))
        self.node.create_subscription(
            Float64, POSITION.name, lambda m: self.positions.append(m.data), qos(POSITION)
        )
        self.node.create_subscription(
            Clock, CLOCK.name, lambda m: self.clocks.append(m.clock.sec * 10**9 + m.clock.nanosec),
            qos(CLOCK),
        )
        self.executor = executor
        executor.add_node(self.node)

    def wait_matched(self) -> None:
        assert spin_until(self.executor, lambda: self.force.get_subscription_count() > 0)

    def send_and_wait(self, u: float) -> None:
        n, n_rows = len(self.positions), len(self.rows)
        self.force.publish(float64(u))
        assert spin_until(self.executor, lambda: len(self.positions) > n and len(self.rows) > n_rows)


def make_plant(ctx, executor, spec: ModelSpec | None = None, config=LOCKSTEP) -> PlantNode:
    plant = PlantNode(spec or true_plant_spec(), config=config, context=ctx)
    executor.add_node(plant)
    return plant


def test_lockstep_answers_n_commands_with_n_samples_matching_simulate(ctx, executor):
    plant = make_plant(ctx, executor)
    client = Client(ctx, executor)
    client.wait_matched()
    u = np.concatenate([np.full(30, 8.0), [15.0, -12.0], np.full(20, -10.0), np.linspace(-3, 3, 28)])
    for value in u:
        client.send_and_wait(float(value))
    spin_for(executor, 0.1)  # nothing more may arrive
    x, v, u_applied = simulate(u, preset("default"))
    assert len(client.rows) == len(u) == len(client.positions) == len(client.clocks)
    assert np.array_equal([r.position[0] for r in client.rows], x)
    assert np.array_equal([r.velocity[0] for r in client.rows], v)
    assert np.array_equal([r.effort[0] for r in client.rows], u_applied)
    x_next = StepModel(kernels.KIND_PLANT, preset("default").as_array()).simulate(
        np.append(u_applied, 0.0))[1:]
    assert np.array_equal(client.positions, x_next)
    dt_ns = 10_000_000
    assert [r.header.stamp.sec * 10**9 + r.header.stamp.nanosec for r in client.rows] == [
        k * dt_ns for k in range(len(u))
    ]
    assert client.clocks == [(k + 1) * dt_ns for k in range(len(u))]
    assert plant.counters["saturated"] == 2 and plant.counters["rejected"] == 0


def test_lockstep_rejects_non_finite_without_stepping(ctx, executor):
    plant = make_plant(ctx, executor)
    client = Client(ctx, executor)
    client.wait_matched()
    for n, bad in enumerate((math.nan, math.inf, -math.inf), start=1):
        client.force.publish(float64(bad))  # keep-last 1: one command in flight at a time
        assert spin_until(executor, lambda n=n: plant.counters["rejected"] == n)
    spin_for(executor, 0.1)
    assert client.rows == [] and plant.k == 0
    client.send_and_wait(4.0)
    assert client.rows[0].effort[0] == 4.0 and client.rows[0].header.stamp.sec == 0
    x, _, _ = simulate(np.array([4.0, 0.0]), preset("default"))
    assert client.positions == [x[1]]


def test_reset_returns_to_rest_at_sample_zero(ctx, executor):
    plant = make_plant(ctx, executor)
    client = Client(ctx, executor)
    client.wait_matched()
    for _ in range(5):
        client.send_and_wait(10.0)
    assert client.positions[-1] > 0
    n_before = len(client.positions)
    client.reset.publish(Empty())
    assert spin_until(executor, lambda: plant.k == 0 and len(client.positions) == n_before + 1)
    assert client.positions[-1] == 0.0  # the lock-step acknowledgement: x_0 after a reset
    client.send_and_wait(10.0)
    last = client.rows[-1]
    assert (last.position[0], last.velocity[0], last.header.stamp.nanosec) == (0.0, 0.0, 0)
    assert client.positions[-1] == client.positions[0]


def test_arx_model_reports_finite_difference_velocity(ctx, executor):
    # x[k+1] = 0.5 u[k] + 1.5 x[k] - 0.6 x[k-1]: a stable second-order linear model
    model = StepModel(kernels.KIND_LINEAR, np.array([5.0, 0.5, 0.0, -1.5, 0.6, 0.0, 0.0]), name="glm")
    make_plant(ctx, executor, ModelSpec(model, dt=0.01, force_limit=2.0))
    client = Client(ctx, executor)
    client.wait_matched()
    for u in (1.0, 1.0, 3.0, 0.0):
        client.send_and_wait(u)
    xs = [r.position[0] for r in client.rows]
    assert [r.effort[0] for r in client.rows] == [1.0, 1.0, 2.0, 0.0]
    assert xs == [0.0, *client.positions[:-1]]
    expected_v = [0.0] + [(b - a) / 0.01 for a, b in itertools.pairwise(xs)]
    assert [r.velocity[0] for r in client.rows] == pytest.approx(expected_v, rel=1e-12)


def test_realtime_holds_last_safe_force_and_watchdog_drops_to_zero(ctx, executor):
    cfg = PlantNodeConfig(watchdog_timeout=0.15, duplicate_check=0.0)
    plant = make_plant(ctx, executor, config=cfg)
    client = Client(ctx, executor)
    client.wait_matched()
    client.force.publish(float64(3.0))
    assert spin_until(executor, lambda: any(r.effort[0] == 3.0 for r in client.rows))
    client.force.publish(float64(math.nan))
    assert spin_until(executor, lambda: plant.counters["rejected"] == 1)
    client.force.publish(float64(25.0))
    assert spin_until(executor, lambda: any(r.effort[0] == 10.0 for r in client.rows))
    spin_for(executor, 0.4)
    efforts = [r.effort[0] for r in client.rows]
    first = efforts.index(3.0)
    tail = efforts[first:]
    # 3 N held (nan rejected, never applied), then 10 N (saturated), then the watchdog's 0 N
    assert set(tail) == {3.0, 10.0, 0.0} and math.nan not in tail
    assert tail[-1] == 0.0 and tail.index(0.0) > tail.index(10.0)
    assert plant.counters == {**plant.counters, "rejected": 1, "saturated": 1, "watchdog": 1}
    stamps = np.diff([r.header.stamp.sec * 10**9 + r.header.stamp.nanosec for r in client.rows])
    assert np.all(stamps == 10_000_000)  # scheduled sample times: evenly spaced


def test_second_plant_on_same_namespace_refuses_to_start(ctx, executor):
    make_plant(ctx, executor)
    with pytest.raises(GraphConflictError, match="already has a publisher"):
        PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=1.0),
                  node_name="plant2", context=ctx)
    # a plant under another namespace is fine
    other = PlantNode(true_plant_spec(), config=PlantNodeConfig(duplicate_check=0.2),
                      namespace="/other", context=ctx)
    other.destroy_node()


REALTIME = PlantNodeConfig(duplicate_check=0.0)


def _sample_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "plant samples"]


def test_realtime_sample_thread_starts_on_the_first_spin_and_ends_with_the_node(ctx, executor):
    plant = make_plant(ctx, executor, config=REALTIME)
    time.sleep(0.1)
    assert plant.counters["steps"] == 0 and not _sample_threads()  # built, not spun: silent
    assert spin_until(executor, lambda: plant.counters["steps"] >= 5)
    assert len(_sample_threads()) == 1
    plant.close()  # what a stopped process does first: the counters it logs are final
    steps = plant.counters["steps"]
    assert not _sample_threads()
    time.sleep(0.05)
    assert plant.counters["steps"] == steps
    plant.destroy_node()  # a second stop is a no-op


def test_realtime_sample_thread_ends_when_the_context_shuts_down(ctx, executor):
    make_plant(ctx, executor, config=REALTIME)
    assert spin_until(executor, lambda: len(_sample_threads()) == 1)
    rclpy.try_shutdown(context=ctx)  # a signal's path: the context goes first, nodes later
    deadline = time.monotonic() + 2.0
    while _sample_threads() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not _sample_threads()


def test_realtime_step_that_raises_ends_the_node_with_a_failure_status(ctx, executor, capfd):
    plant = make_plant(ctx, executor, config=REALTIME)

    def broken(_t_sched: float) -> None:
        raise RuntimeError("step exploded")

    plant._tick = broken  # type: ignore[method-assign]
    assert spin_until(executor, plant.done.done)
    assert plant.done.result() == EXIT_TICK_FAILED
    assert "RuntimeError: step exploded" in capfd.readouterr().err
    assert not _sample_threads()
