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
from msd_bench.io.bags.reader import bag_info, read_experiment, read_topic
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


@pytest.mark.parametrize("extra", [
    [],
    # sim-time logging: the positions wait for a stamp that never comes and are written while closing
    ["-p", "topics:=[joint_states,position]", "-p", "log_time:=stamp"],
], ids=["arrival", "held-until-close"])
def test_launch_script_sigterm_leaves_a_complete_bag(ctx: Context, tmp_path: Path, extra: list[str]) -> None:
    """The real process: publish to it, SIGTERM it, the bag is complete without recovery."""
    bag = tmp_path / "proc"
    before = _shm_files()
    proc = subprocess.Popen(
        [sys.executable, "launch_scripts/recorder.py", "--ros-args", "-p", f"bag_path:={bag}",
         "-p", "topics:=[position]", "-p", "params_json:='{\"run\": 1}'", *extra],
        cwd=REPO, env={**os.environ}, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    node = Node("fake_plant_proc", context=ctx)
    pub = node.create_publisher(msg_class(POSITION), POSITION.resolve("/msd"), qos(POSITION))
    # A silent joint_states publisher: the recorder announces ready once every reader matched.
    node.create_publisher(JointState, JOINT_STATES.resolve("/msd"), qos(JOINT_STATES))
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


def _lockstep_recording(ctx: Context, bag: Path, topics: list[str], steps: int) -> str:
    """Record ``steps`` lock-step samples of the plant; return the JointState type hash rclpy reports."""
    from std_msgs.msg import Float64

    from msd_bench.nodes.plant_node import PlantNode, PlantNodeConfig, true_plant_spec

    plant = PlantNode(true_plant_spec(), config=PlantNodeConfig(lockstep=True, duplicate_check=0.0),
                      context=ctx)
    rec = _recorder(ctx, bag, topics=topics)
    client = Node("stepper", context=ctx)
    force = client.create_publisher(Float64, FORCE.resolve(PLANT_NAMESPACE), qos(FORCE))
    answers: list[float] = []
    client.create_subscription(Float64, POSITION.resolve(PLANT_NAMESPACE), lambda m: answers.append(m.data),
                               qos(POSITION))
    executor = SingleThreadedExecutor(context=ctx)
    for node in (plant, rec, client):
        executor.add_node(node)
    try:
        wanted = 2 if FORCE.name in topics else 1  # the plant, and the recorder if it records force
        _spin_until(executor, lambda: force.get_subscription_count() >= wanted and not rec._unmatched)
        deadline = time.monotonic() + 0.5  # let the plant's side match the recorder too
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.02)
        for k in range(steps):
            force.publish(float64(5.0 * np.sin(0.05 * k)))
            _spin_until(executor, lambda k=k: len(answers) > k)
        _spin_until(executor, lambda: rec.message_count >= steps * len(topics))
        type_hash = str(client.get_publishers_info_by_topic(JOINT_STATES.resolve(PLANT_NAMESPACE))[0]
                        .topic_type_hash)
        rec.close()
    finally:
        executor.shutdown()
        for node in (rec, client, plant):
            node.destroy_node()
    return type_hash


@pytest.mark.parametrize(("topics", "span_samples"), [
    (["joint_states"], N - 1),  # rows 0..N-1: the span between the first and the last stamp
    (["joint_states", "position", "force", "/clock"], N),  # /clock runs on to N·dt: samples × 10 ms
])
def test_lockstep_bag_is_timed_in_sim_time_with_rosbag2_metadata(
    ctx: Context, tmp_path: Path, topics: list[str], span_samples: int
) -> None:
    import yaml
    from mcap.reader import make_reader

    from msd_bench.io.bags.bag_writer import ros_distro

    bag = tmp_path / "lockstep"
    type_hash = _lockstep_recording(ctx, bag, topics, N)
    topic = JOINT_STATES.resolve(PLANT_NAMESPACE)
    log_times, msgs = read_topic(bag, topic)
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in msgs]
    assert stamps == [10_000_000 * k for k in range(N)]
    assert log_times.tolist() == stamps  # logged at the sample's own (sim) time
    info = bag_info(bag)
    assert info.duration_s == pytest.approx(span_samples * 0.01, abs=1e-9)
    for name in topics:
        t, _ = read_topic(bag, name if name.startswith("/") else f"{PLANT_NAMESPACE}/{name}")
        assert t.size == N and t.min() >= 0 and t.max() <= N * 10_000_000  # all inside the sim span
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["ros_distro"] == ros_distro() != "rosbags"
    assert meta["duration"]["nanoseconds"] == span_samples * 10_000_000
    by_topic = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in meta["topics_with_message_count"]}
    offered = by_topic[topic]["offered_qos_profiles"]
    assert len(offered) == 1  # the plant is the one publisher
    assert (offered[0]["reliability"], offered[0]["durability"]) == ("reliable", "volatile")
    assert offered[0]["deadline"] == {"sec": 9223372036, "nsec": 854775807}  # infinite, as rmw says
    assert by_topic[topic]["type_description_hash"] == type_hash
    with (bag / "lockstep.mcap").open("rb") as fh:
        channels = make_reader(fh).get_summary().channels.values()
        channel = next(c for c in channels if c.topic == topic)
    assert channel.metadata["topic_type_hash"] == type_hash  # what the running rclpy reports
    assert yaml.safe_load(channel.metadata["offered_qos_profiles"]) == offered


@pytest.mark.parametrize(("log_time", "t0", "resolved"), [
    ("receive", 0, "receive"),  # forced: arrival times even for sim-time stamps
    ("stamp", 1_700_000_000 * 10**9, "stamp"),  # forced: the stamps even for wall-clock ones
    ("auto", 0, "stamp"),  # stamps from 0, no /clock discovered: a lock-step graph all the same
    ("auto", None, "receive"),  # stamps on the wall clock: a real-time node, rosbag2's arrival times
])
def test_log_time_modes(ctx: Context, tmp_path: Path, log_time: str, t0: int | None, resolved: str) -> None:
    bag = tmp_path / log_time
    rec = _recorder(ctx, bag, log_time=log_time, topics=[JOINT_STATES.name, POSITION.name])
    pub_node = Node("fake_plant_rt", context=ctx)
    js = pub_node.create_publisher(JointState, JOINT_STATES.resolve(PLANT_NAMESPACE), qos(JOINT_STATES))
    pos = pub_node.create_publisher(msg_class(POSITION), POSITION.resolve(PLANT_NAMESPACE), qos(POSITION))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rec)
    executor.add_node(pub_node)
    t0 = time.time_ns() if t0 is None else t0
    try:
        _spin_until(executor, lambda: js.get_subscription_count() >= 1 and pos.get_subscription_count() >= 1)
        pos.publish(float64(-1.0))  # before any stamp: held until the first one in stamp mode
        _spin_until(executor, lambda: len(rec._held) == 1 or rec.message_count == 1)
        assert len(rec._held) == (0 if log_time == "receive" else 1)  # auto waits for a stamp to decide
        for k in range(20):
            js.publish(joint_state(t0 + 10_000_000 * k, 0.0, 0.0, 0.0))
            pos.publish(float64(k))
        _spin_until(executor, lambda: rec.message_count >= 41)
        rec.close()
    finally:
        executor.shutdown()
        rec.destroy_node()
        pub_node.destroy_node()
    log_js, _ = read_topic(bag, JOINT_STATES.resolve(PLANT_NAMESPACE))
    log_pos, _ = read_topic(bag, POSITION.resolve(PLANT_NAMESPACE))
    stamps = [t0 + 10_000_000 * k for k in range(20)]
    assert rec._log_time == resolved
    if resolved == "stamp":
        assert log_js.tolist() == stamps
        assert set(log_pos.tolist()) <= set(stamps)  # each at the newest stamp seen
    else:
        assert log_js.tolist() != stamps and log_js.min() > time.time_ns() - 120 * 10**9  # arrival times


def test_bad_log_time_is_a_one_line_error(ctx: Context, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="log_time must be one of auto, receive, stamp"):
        _recorder(ctx, tmp_path / "b", log_time="wall")
    with pytest.raises(ConfigError, match="needs a stamped topic"):
        _recorder(ctx, tmp_path / "c", log_time="stamp", topics=[POSITION.name])


def test_messages_waiting_for_a_stamp_are_kept_on_close(ctx: Context, tmp_path: Path) -> None:
    """Sim-time logging holds unstamped messages until a stamp comes; if none ever does, none is lost."""
    bag = tmp_path / "held"
    rec = _recorder(ctx, bag, log_time="stamp", topics=[JOINT_STATES.name, POSITION.name])
    pub_node = Node("fake_agent_held", context=ctx)
    pos = pub_node.create_publisher(msg_class(POSITION), POSITION.resolve(PLANT_NAMESPACE), qos(POSITION))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rec)
    executor.add_node(pub_node)
    try:
        _spin_until(executor, lambda: pos.get_subscription_count() >= 1)
        for k in range(5):
            pos.publish(float64(k))
            _spin_until(executor, lambda k=k: len(rec._held) == k + 1)
        assert rec.message_count == 0
        rec.close()
    finally:
        executor.shutdown()
        rec.destroy_node()
        pub_node.destroy_node()
    log_times, msgs = read_topic(bag, POSITION.resolve(PLANT_NAMESPACE))
    assert [m.data for m in msgs] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert np.all(np.diff(log_times) > 0)  # their own arrival times


def test_records_a_ros2_control_face_that_identification_reads(ctx: Context, tmp_path: Path) -> None:
    """joint_states with another joint first and Float64MultiArray commands: the bag rebuilds the force."""
    from msd_bench.io.bags.bag_interface import read_interface_experiment
    from msd_msgs_py.interface import make
    from msd_msgs_py.ros import command, joint_states

    iface = make("ros2_control", controller_joints=["pole", "slider_to_cart"])
    bag = tmp_path / "r2c"
    rec = _recorder(ctx, bag, topics=["joint_states", "effort_controller/commands"], namespace="/rig",
                    interface="ros2_control", controller_joints=["pole", "slider_to_cart"])
    rig = Node("fake_rig", context=ctx)
    state = rig.create_publisher(JointState, "/rig/joint_states", qos(JOINT_STATES))
    cmd = rig.create_publisher(msg_class(iface.command), iface.command.resolve("/rig"), qos(iface.command))
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(rec)
    executor.add_node(rig)
    forces = [float(k % 7) - 3.0 for k in range(N)]
    t0 = time.time_ns()  # a real-time rig stamps on the wall clock: log times are arrival times
    try:
        _spin_until(executor, lambda: state.get_subscription_count() and cmd.get_subscription_count())
        for k in range(N):  # command k, then row k: the recorder logs them in that order
            cmd.publish(command(iface, forces[k]))
            # the first command waits inside the recorder until a stamped row decides the log times
            _spin_until(executor, lambda k=k: rec.message_count + len(rec._held) >= 2 * k + 1)
            state.publish(joint_states(t0 + 10_000_000 * k, ["pole", "slider_to_cart"], [9.0, 0.001 * k],
                                       [0.0, 0.0], [0.0, forces[k - 1] if k else 0.0]))
            _spin_until(executor, lambda k=k: rec.message_count >= 2 * k + 2)
        rec.close()
    finally:
        executor.shutdown()
        rec.destroy_node()
        rig.destroy_node()
    assert bag_info(bag).topics["/rig/effort_controller/commands"] == ("std_msgs/msg/Float64MultiArray", N)
    exp, _, src = read_interface_experiment(bag, iface, "/rig", force_input="held")
    np.testing.assert_array_equal(exp.u, forces)
    np.testing.assert_array_equal(exp.y, 0.001 * np.arange(N))
    assert src.source == "held" and src.agreement is not None  # effort k = command k-1: one sample late
    assert (src.agreement.delay_samples, src.agreement.fit_percent) == (1, pytest.approx(100.0))


def test_a_command_topic_of_another_controller_is_refused(ctx: Context, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"topic arm/commands is not the command topic .*effort_controller"):
        _recorder(ctx, tmp_path / "x", topics=["joint_states", "arm/commands"], interface="ros2_control")
