"""In-process recorder node tests: private rclpy Context, publisher in the same context."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from msd_bench.core.errors import ConfigError
from msd_bench.io.bags import bag_info, read_experiment, read_topic
from msd_bench.nodes.recorder_node import RecorderNode
from msd_msgs_py.contract import FORCE, JOINT_STATES, PLANT_NAMESPACE, POSITION, RECORDER_READY
from msd_msgs_py.ros import float64, joint_state, msg_class, qos
from tests.nodes.conftest import shutdown_context

pytestmark = [
    pytest.mark.ros,
    # rclpy's type-support import pulls in lark, which imports the deprecated sre_parse and sre_constants
    pytest.mark.filterwarnings("ignore:module 'sre_(parse|constants)' is deprecated:DeprecationWarning"),
]
REPO = Path(__file__).resolve().parents[2]
N = 200


@pytest.fixture()
def ctx() -> Iterator[Context]:
    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        shutdown_context(context)


def _spin_until(executor: SingleThreadedExecutor, cond: Callable[[], bool], timeout: float = 15.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "timed out waiting in the executor"
        executor.spin_once(timeout_sec=0.05)


def _recorder(ctx: Context, bag: Path, **params: object) -> RecorderNode:
    overrides = [Parameter("bag_path", value=str(bag))]
    overrides += [Parameter(k, value=v) for k, v in params.items()]
    return RecorderNode(context=ctx, parameter_overrides=overrides)


def test_records_200_joint_states_in_order(ctx: Context, tmp_path: Path) -> None:
    bag = tmp_path / "exp"
    rec = _recorder(ctx, bag, params_json=json.dumps({"seed": 5}))
    pub_node = Node("fake_plant", context=ctx)
    topic = JOINT_STATES.resolve(PLANT_NAMESPACE)
    pub = pub_node.create_publisher(JointState, topic, qos(JOINT_STATES))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rec)
    executor.add_node(pub_node)
    try:
        _spin_until(executor, lambda: pub.get_subscription_count() >= 1)
        for k in range(N):
            pub.publish(joint_state(10_000_000 * k, 0.01 * k, -0.5 * k, float(k % 5) - 2.0))
        _spin_until(executor, lambda: rec.message_count >= N)
        rec.close()
        assert rec.done.done()
    finally:
        executor.shutdown()
        rec.destroy_node()
        pub_node.destroy_node()
    exp, params = read_experiment(bag)
    k = np.arange(N)
    np.testing.assert_array_equal(exp.y, 0.01 * k)
    np.testing.assert_array_equal(exp.u, (k % 5) - 2.0)
    assert params == {"seed": 5}
    log_times, msgs = read_topic(bag, topic)
    assert np.all(np.diff(log_times) >= 0)  # logged in arrival order = publish order
    assert [m.velocity[0] for m in msgs] == [-0.5 * i for i in range(N)]
    assert bag_info(bag).topics == {topic: (JOINT_STATES.ros_type, N)}  # idle topics: no connection


def test_max_messages_closes_the_bag_and_completes_done(ctx: Context, tmp_path: Path) -> None:
    bag = tmp_path / "limited"
    rec = _recorder(ctx, bag, topics=[POSITION.name, FORCE.name], max_messages=30)
    pub_node = Node("fake_agent", context=ctx)
    pos = pub_node.create_publisher(msg_class(POSITION), POSITION.resolve("/msd"), qos(POSITION))
    force = pub_node.create_publisher(msg_class(FORCE), FORCE.resolve("/msd"), qos(FORCE))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rec)
    executor.add_node(pub_node)
    try:
        _spin_until(executor, lambda: pos.get_subscription_count() and force.get_subscription_count())
        for k in range(25):
            pos.publish(float64(k))
            _spin_until(executor, lambda k=k: rec.message_count >= 2 * k + 1 or rec.done.done())
            force.publish(float64(-k))
            _spin_until(executor, lambda k=k: rec.message_count >= 2 * k + 2 or rec.done.done())
        _spin_until(executor, rec.done.done)
    finally:
        executor.shutdown()
        rec.destroy_node()
        pub_node.destroy_node()
    topics = bag_info(bag).topics
    assert topics["/msd/position"] == ("std_msgs/msg/Float64", 15)
    assert topics["/msd/force"] == ("std_msgs/msg/Float64", 15)
    assert [m.data for m in read_topic(bag, "/msd/force")[1]] == [-float(k) for k in range(15)]


@pytest.mark.parametrize(
    ("params", "needle"),
    [
        ({}, "bag_path is required"),
        ({"topics": ["joint_states", "nope"]}, "topics must be among"),
        ({"params_json": "[1, 2]"}, "JSON object"),
        ({"flush_period_s": 0.0}, "flush_period_s"),
    ],
)
def test_bad_parameters_are_one_line_config_errors(
    ctx: Context, tmp_path: Path, params: dict[str, object], needle: str
) -> None:
    overrides = [Parameter(k, value=v) for k, v in params.items()]
    if "bag_path" not in params and params:
        overrides.append(Parameter("bag_path", value=str(tmp_path / "b")))
    with pytest.raises(ConfigError) as err:
        RecorderNode(context=ctx, parameter_overrides=overrides)
    assert needle in str(err.value) and "\n" not in str(err.value)
    assert not (tmp_path / "b").exists()


_SHM_PATTERNS = ("fastrtps_*", "fast_datasharing_*", "fastdds_*", "sem.fastrtps_*", "sem.fastdds_*")


def _shm_files() -> set[Path]:
    shm = Path("/dev/shm")
    return {f for pattern in _SHM_PATTERNS for f in shm.glob(pattern)} if shm.is_dir() else set()


def _in_use() -> set[str]:
    """Every /dev/shm path some live process maps or holds open (ours included)."""
    used: set[str] = set()
    for proc_dir in Path("/proc").glob("[0-9]*"):
        try:
            used.update(
                line.split(maxsplit=5)[-1].strip()
                for line in (proc_dir / "maps").read_text().splitlines()
                if "/dev/shm/" in line
            )
            used.update(os.readlink(fd) for fd in (proc_dir / "fd").iterdir())
        except OSError:
            continue
    return used


def _remove_orphan_shm(before: set[Path]) -> None:
    """Delete Fast DDS segments created during the test that no live process uses any more."""
    used = _in_use()
    for leftover in _shm_files() - before:
        if str(leftover) not in used:
            leftover.unlink(missing_ok=True)


def test_launch_script_sigterm_leaves_a_complete_bag(ctx: Context, tmp_path: Path) -> None:
    """The real process: publish to it, SIGTERM it, the bag is complete without recovery."""
    bag = tmp_path / "proc"
    before = _shm_files()
    proc = subprocess.Popen(
        [sys.executable, "launch_scripts/recorder.py", "--ros-args", "-p", f"bag_path:={bag}",
         "-p", "topics:=[position]", "-p", "params_json:='{\"run\": 1}'"],
        cwd=REPO, env={**os.environ}, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    node = Node("fake_plant_proc", context=ctx)
    pub = node.create_publisher(msg_class(POSITION), POSITION.resolve("/msd"), qos(POSITION))
    ready: list[str] = []
    node.create_subscription(msg_class(RECORDER_READY), RECORDER_READY.resolve("/msd"),
                             lambda m: ready.append(m.data), qos(RECORDER_READY))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    try:
        # The recorder announces (latched) once its readers matched, plus a grace for our side.
        _spin_until(executor, lambda: str(bag) in ready, timeout=30.0)
        for k in range(50):
            pub.publish(float64(k))
        time.sleep(1.0)  # let the reliable writer deliver before we stop the process
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=10)
            _remove_orphan_shm(before)  # a killed participant leaves its segments behind
        executor.shutdown()
        node.destroy_node()
    assert proc.returncode == 0, out
    assert "Traceback" not in out
    info = bag_info(bag)
    assert info.topics == {"/msd/position": ("std_msgs/msg/Float64", 50)}
    assert info.params == {"run": 1}
