"""The plant node's sensor: measured positions out, estimated velocity, the truth on its own topic."""

from __future__ import annotations

import json
import os
import platform
import subprocess
from pathlib import Path

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, Float64

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import preset, simulate
from msd_bench.core.physics.sensor import SensorModel, sensor_rng, velocity_estimate
from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, declare_true_plant, true_plant_spec
from msd_msgs_py.contract import FORCE, JOINT_STATES, POSITION, RESET, TRUTH_JOINT_STATES
from msd_msgs_py.ros import float64, qos
from tests.nodes.conftest import spin_for, spin_until

pytestmark = pytest.mark.ros

DT = 0.01
SPREAD_OUT = os.environ.get("MSD_SENSOR_SPREAD_OUT")
"""If set, the measured spreads are also written there as JSON (for the report; never asserted on)."""


class SensorClient:
    """Listens to the measured rows, the truth rows and ``position``; plays forces in lock-step."""

    def __init__(self, ctx, executor) -> None:
        self.node = Node("sensor_client", namespace="/msd", context=ctx)
        self.force = self.node.create_publisher(Float64, FORCE.name, qos(FORCE))
        self.reset = self.node.create_publisher(Empty, RESET.name, qos(RESET))
        self.rows: list[JointState] = []
        self.truth: list[JointState] = []
        self.positions: list[float] = []
        self.node.create_subscription(JointState, JOINT_STATES.name, self.rows.append, qos(JOINT_STATES))
        self.node.create_subscription(JointState, TRUTH_JOINT_STATES.name, self.truth.append,
                                      qos(TRUTH_JOINT_STATES))
        self.node.create_subscription(Float64, POSITION.name, lambda m: self.positions.append(m.data),
                                      qos(POSITION))
        self.executor = executor
        executor.add_node(self.node)

    def wait_matched(self, truth: bool) -> None:
        def matched() -> bool:
            return (self.force.get_subscription_count() > 0
                    and (not truth or self.node.count_publishers("/msd/" + TRUTH_JOINT_STATES.name) > 0))
        assert spin_until(self.executor, matched)

    def play(self, u: np.ndarray) -> None:
        """One command per sample, each answered by a row (and a truth row) and a position."""
        for value in u:
            n, n_rows = len(self.positions), len(self.rows)
            self.force.publish(float64(float(value)))
            assert spin_until(self.executor,
                              lambda n=n, m=n_rows: len(self.positions) > n and len(self.rows) > m)

    def arrays(self, rows: list[JointState]) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
        stamps = [r.header.stamp.sec * 10**9 + r.header.stamp.nanosec for r in rows]
        return (np.array([r.position[0] for r in rows]), np.array([r.velocity[0] for r in rows]),
                np.array([r.effort[0] for r in rows]), stamps)


def _plant(ctx, executor, **sensor) -> PlantNode:
    config = PlantNodeConfig(lockstep=True, duplicate_check=0.0, **sensor)
    plant = PlantNode(true_plant_spec(), config=config, context=ctx)
    executor.add_node(plant)
    return plant


def _force(n: int, seed: int = 3) -> np.ndarray:
    """A switching force that moves the slider over much of its stroke (and hits the limits)."""
    rng = np.random.default_rng(seed)
    return np.repeat(rng.uniform(-12.0, 12.0, n // 25 + 1), 25)[:n]


def test_noisy_sensor_measures_with_the_right_spread_and_publishes_the_truth(ctx, executor):
    noise, seed, n = 0.002, 7, 1200
    _plant(ctx, executor, sensor_noise=noise, sensor_seed=seed)
    client = SensorClient(ctx, executor)
    client.wait_matched(truth=True)
    u = _force(n)
    client.play(u)
    assert spin_until(executor, lambda: len(client.truth) == n)
    spin_for(executor, 0.1)
    y, v, effort, stamps = client.arrays(client.rows)
    x, v_true, effort_true, truth_stamps = client.arrays(client.truth)
    assert len(client.rows) == len(client.truth) == len(client.positions) == n
    assert stamps == truth_stamps == [k * 10_000_000 for k in range(n)]
    # the truth topic is the emulated plant itself, bit for bit
    x_sim, v_sim, u_applied = simulate(u, preset("default"))
    assert np.array_equal(x, x_sim) and np.array_equal(v_true, v_sim)
    assert np.array_equal(effort, u_applied) and np.array_equal(effort_true, u_applied)
    # measured = truth through the one sensor model of core, one draw per sample in order
    assert np.array_equal(y, SensorModel(noise).measure(x, sensor_rng(seed)))
    err = y - x
    spread = float(np.std(err))
    assert abs(spread - noise) < 0.2 * noise, spread
    assert abs(float(np.mean(err))) < 4 * noise / np.sqrt(n)
    assert np.all(err != 0.0)
    # position is the measured x_{k+1}: the same reading as row k+1, never a second draw
    assert np.array_equal(client.positions[:-1], y[1:])
    # the velocity is the backward difference of measured positions, never the truth
    assert np.array_equal(v, velocity_estimate(y, DT))
    v_err = float(np.std(v - v_true))
    assert abs(v_err - np.sqrt(2) * noise / DT) < 0.2 * np.sqrt(2) * noise / DT, v_err
    if SPREAD_OUT:
        Path(SPREAD_OUT).write_text(json.dumps({
            "command": f"MSD_SENSOR_SPREAD_OUT={SPREAD_OUT} pytest tests/nodes/test_plant_sensor.py",
            "commit": subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                                     cwd=Path(__file__).parent).stdout.strip(),
            "machine": f"{platform.machine()} {os.cpu_count()} cores, {platform.python_version()}",
            "samples": n, "sensor_noise_m": noise, "position_error_std_m": spread,
            "position_error_mean_m": float(np.mean(err)), "velocity_error_std_mps": v_err,
            "velocity_error_std_expected_mps": float(np.sqrt(2) * noise / DT)}, indent=1) + "\n")


def test_reset_acknowledges_with_a_measured_rest_and_restarts_the_estimate(ctx, executor):
    _plant(ctx, executor, sensor_noise=0.002, sensor_seed=1)
    client = SensorClient(ctx, executor)
    client.wait_matched(truth=True)
    client.play(np.full(30, 8.0))
    n = len(client.positions)
    client.reset.publish(Empty())
    assert spin_until(executor, lambda: len(client.positions) == n + 1)
    ack = client.positions[-1]
    assert ack != 0.0 and abs(ack) < 5 * 0.002  # x_0 = 0 as the sensor reads it
    client.play(np.array([8.0, 8.0]))
    assert spin_until(executor, lambda: len(client.truth) == 32)
    after, truth_after = client.rows[-2:], client.truth[-2:]
    assert [r.header.stamp.nanosec for r in after] == [0, 10_000_000]
    assert after[0].position[0] == ack  # the acknowledged reading is row 0's
    assert after[0].velocity[0] == 0.0  # the estimate starts afresh: no difference across the reset
    assert (truth_after[0].position[0], truth_after[0].velocity[0]) == (0.0, 0.0)


def test_quantisation_lands_on_multiples_of_the_step(ctx, executor):
    q, n = 0.001, 300
    _plant(ctx, executor, sensor_quant=q, sensor_noise=0.0005, sensor_seed=2)
    client = SensorClient(ctx, executor)
    client.wait_matched(truth=True)
    client.play(_force(n, seed=5))
    assert spin_until(executor, lambda: len(client.truth) == n)
    y, v, _, _ = client.arrays(client.rows)
    x, _, _, _ = client.arrays(client.truth)
    steps = y / q
    assert np.all(np.abs(steps - np.round(steps)) < 1e-9)
    assert np.array_equal(y, SensorModel(0.0005, q).measure(x, sensor_rng(2)))
    assert len(np.unique(np.round(steps))) > 50  # the slider moved over many steps
    assert np.array_equal(v, velocity_estimate(y, DT))
    assert np.all(np.abs(v * DT / q - np.round(v * DT / q)) < 1e-6)  # velocity moves in steps of q/dt


def test_ideal_sensor_publishes_no_truth_topic(ctx, executor):
    plant = _plant(ctx, executor)
    client = SensorClient(ctx, executor)
    client.wait_matched(truth=False)
    client.play(np.full(20, 5.0))
    spin_for(executor, 0.1)
    assert client.node.count_publishers("/msd/" + TRUTH_JOINT_STATES.name) == 0 and client.truth == []
    x, v, _, _ = client.arrays(client.rows)
    x_sim, v_sim, _ = simulate(np.full(20, 5.0), preset("default"))
    assert np.array_equal(x, x_sim) and np.array_equal(v, v_sim)
    assert plant.config.sensor is None


def test_sensor_parameters_are_ranged_and_checked(ctx):
    node = PlantNode(declare_true_plant, context=ctx, parameter_overrides=[
        Parameter("lockstep", value=True), Parameter("duplicate_check", value=0.0),
        Parameter("sensor_noise", value=0.002), Parameter("sensor_quant", value=0.0005),
        Parameter("sensor_seed", value=4)])
    try:
        assert node.config.sensor == SensorModel(0.002, 0.0005)
        desc = node.describe_parameter("sensor_noise")
        assert desc.floating_point_range[0].from_value == 0.0 and "noise" in desc.description
        assert node.describe_parameter("sensor_seed").integer_range[0].to_value == 2**31 - 1
    finally:
        node.destroy_node()
    with pytest.raises(ConfigError, match="sensor_noise"):
        PlantNode(declare_true_plant, context=ctx, parameter_overrides=[
            Parameter("duplicate_check", value=0.0), Parameter("sensor_noise", value=-0.001)])
    with pytest.raises(ConfigError, match="quant"):
        PlantNodeConfig(sensor_quant=float("nan"))
