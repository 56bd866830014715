"""The live view (docs/live.md): a Foxglove WebSocket server whose plant rows are the plant's own.

In-process: the server's channels as a viewer sees them, the decimation and a
port in use. End to end: a lock-step plant started with ``-p live_port:=0`` is
driven by a known force sequence over its topics, and every row a client
speaking the Foxglove protocol receives is checked against core's simulation of
the same commands at the row's own sample index (the plant's bag rows are
exactly that simulation, docs/design.md §Contract); the set-point published on
``reference`` comes back on ``/plant/setpoint``.
"""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.physics.plant import PlantParams, simulate
from msd_bench.graph import launch
from msd_bench.graph.bench import BenchConfig, timed
from msd_bench.graph.live import LiveStageProgress, live_view
from msd_bench.io.reports.live_server import (
    LOG_TOPIC,
    PLANT_TOPIC,
    PROGRESS_TOPIC,
    SETPOINT_TOPIC,
    LiveError,
    LiveServer,
    WallDecimator,
    check_port,
)
from msd_msgs_py.interface import MSD_INTERFACE
from tests.graph.foxglove_client import FoxgloveClient, Received

TOPICS = [PLANT_TOPIC, SETPOINT_TOPIC, PROGRESS_TOPIC, LOG_TOPIC]
DT_NS = 10_000_000


def _joint(r: Received) -> tuple[int, float, float, float]:
    """(stamp ns, position, velocity, effort) of a received ``foxglove.JointStates``."""
    (j,) = r.value.joints
    assert j.name == "msd_slider"
    stamp = r.value.timestamp.seconds * 1_000_000_000 + r.value.timestamp.nanos
    return stamp, j.position, j.velocity, j.effort


def test_decimator_lets_one_sample_per_period_through_and_holds_the_newest() -> None:
    d = WallDecimator(period_ns=20)
    rows = [(k, float(k), 0.0, 0.0) for k in range(6)]
    passed = [d.offer(now, row) for now, row in zip((0, 5, 19, 20, 21, 50), rows, strict=True)]
    assert passed == [True, False, False, True, False, True]
    assert d.take_held() is None  # the sample at 50 went out: nothing held back
    assert not d.offer(60, rows[1]) and not d.offer(61, rows[2])
    assert d.take_held() == rows[2] and d.take_held() is None


@pytest.mark.parametrize("port", [-1, 65536, True, 3.5])
def test_a_port_out_of_range_is_one_line(port: object) -> None:
    with pytest.raises(LiveError, match=r"^--live: a TCP port is 0\.\.65535"):
        check_port(port, "--live")  # type: ignore[arg-type]


def test_a_port_in_use_is_one_line_naming_it() -> None:
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        with pytest.raises(LiveError) as err:
            LiveServer(port, "test", what="--live")
    assert str(err.value).startswith(f"--live {port}: cannot serve the live view on 127.0.0.1:{port} (")
    assert "in use" in str(err.value) and "\n" not in str(err.value)


@pytest.fixture
def server() -> Iterator[LiveServer]:
    live = LiveServer(0, "test")
    try:
        yield live
    finally:
        live.close()


def _viewer(url: str) -> FoxgloveClient:
    client = FoxgloveClient(url)
    client.wait_for_channels(TOPICS)
    client.subscribe(TOPICS)
    return client


def test_a_viewer_gets_the_channels_and_exactly_the_rows_given(server: LiveServer) -> None:
    client = _viewer(server.url)
    try:
        assert client.info["name"] == "test"
        schemas = {t: client.channels[t]["schemaName"] for t in TOPICS}
        assert schemas == {PLANT_TOPIC: "foxglove.JointStates", LOG_TOPIC: "foxglove.Log",
                           SETPOINT_TOPIC: "msd_bench.Setpoint", PROGRESS_TOPIC: "msd_bench.StageProgress"}
        deadline = time.monotonic() + 30.0
        while not server.watched and time.monotonic() < deadline:  # the server takes the subscription
            time.sleep(0.01)
        assert server.watched
        rows = [(k * DT_NS, 0.1 * k, -0.5 * k, 10.0 - k) for k in range(10)]
        server.setpoint(1.25)
        for row in rows:
            server.plant(*row)
        server.flush()
        server.progress("record", "running", item="prbs-0", done=2, total=8)
        server.log("identifying surrogates")
        got = _receive_until(client, lambda r: r.topic == LOG_TOPIC)
    finally:
        client.close()
    plant = [_joint(r) for r in got if r.topic == PLANT_TOPIC]
    assert plant[0] == rows[0] and plant[-1] == rows[-1]  # the first goes out, the newest is flushed
    assert all(p in rows for p in plant) and plant == sorted(plant)
    setpoints = [r.value for r in got if r.topic == SETPOINT_TOPIC]
    assert [s["setpoint"] for s in setpoints] == [1.25] * len(plant)
    assert [s["t"] for s in setpoints] == [p[0] * 1e-9 for p in plant]
    (progress,) = [r.value for r in got if r.topic == PROGRESS_TOPIC]
    assert progress == {"stage": "record", "state": "running", "item": "prbs-0", "done": 2, "total": 8,
                        "fraction": 0.25}
    assert got[-1].value.message == "identifying surrogates"


def _receive_until(client: FoxgloveClient, last: object, timeout: float = 30.0) -> list[Received]:
    """Messages until one for which ``last`` holds (included); fails after ``timeout`` s."""
    got: list[Received] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        r = client.receive(max(0.1, deadline - time.monotonic()))
        if r is not None:
            got.append(r)
            if last(r):  # type: ignore[operator]
                return got
    raise AssertionError(f"no final message within {timeout} s; got {[r.topic for r in got]}")


# --- end to end: a plant process serving the live view ------------------------------------------

def _commands(n: int) -> np.ndarray:
    """A known force sequence, saturating at times (commands beyond ±F are part of the contract)."""
    k = np.arange(n)
    return 12.0 * np.sin(0.013 * k) * np.cos(0.0021 * k)


@pytest.mark.e2e
def test_the_plant_and_bench_live_views_serve_the_plants_own_rows_and_the_set_point(tmp_path: Path) -> None:
    """One lock-step plant with ``live_port:=0``, and bench.py's live view (:func:`live_view`, its
    rclpy watch) in this process on the same plant: a viewer on each gets only the plant's own rows."""
    from msd_bench.gym.ros_backend import RosBackend

    with launch.process_group() as procs, live_view(0, "/msd", MSD_INTERFACE) as bench:
        plant = procs.start("plant.py", ["-p", "lockstep:=true", "-p", "live_port:=0",
                                         "-p", "duplicate_check:=0.0"])
        line = plant.wait_for_line(r"live view on ws://127\.0\.0\.1:\d+", 60.0)
        plant.wait_for_line(r"ready \(", 60.0)
        url = re.search(r"ws://127\.0\.0\.1:\d+", line).group(0)  # type: ignore[union-attr]
        assert bench is not None
        clients = {"plant": _viewer(url), "bench": _viewer(bench.url)}
        backend = RosBackend("/msd")
        reference = _ReferencePublisher()
        try:
            reference.publish(0.75, readers=2)  # the plant's live view and bench.py's watch
            with LiveStageProgress("record") as bar:
                timed(BenchConfig(run_dir=tmp_path), "record", lambda: bar.update("broad", 1, 2))
            u = _commands(20_000)
            backend.reset()
            got, k = _drive_until_seen(backend, list(clients.values()), u)
            for _ in range(200):  # and on: the last of these is flushed when the plant goes quiet
                backend.step(float(u[k]))
                k += 1
            last_stamp = (k - 1) * DT_NS
            for client in clients.values():
                got[client] += _receive_until(
                    client, lambda r: r.topic == PLANT_TOPIC and _joint(r)[0] == last_stamp)
        finally:
            reference.close()
            backend.close()
            for client in clients.values():
                client.close()
    x, v, applied = simulate(u[:k], PlantParams())
    for name, client in clients.items():
        rows = [_joint(r) for r in got[client] if r.topic == PLANT_TOPIC]
        assert len(rows) >= 2, name
        for stamp, pos, vel, eff in rows:
            i, rem = divmod(stamp, DT_NS)
            assert rem == 0 and 0 <= i < k, (name, stamp)
            assert (pos, vel, eff) == pytest.approx((x[i], v[i], applied[i]), rel=1e-12, abs=1e-12), (name, i)
        setpoints = [r.value["setpoint"] for r in got[client] if r.topic == SETPOINT_TOPIC]
        assert setpoints and set(setpoints) == {0.75}, name
    progress = [r.value for r in got[clients["bench"]] if r.topic == PROGRESS_TOPIC]
    assert [(p["stage"], p["state"], p["item"], p["done"], p["total"]) for p in progress] == [
        ("record", "running", "", 0, 0), ("record", "running", "broad", 1, 2), ("record", "done", "", 0, 0)]


def _drive_until_seen(backend: object, clients: list[FoxgloveClient],
                      u: np.ndarray) -> tuple[dict[FoxgloveClient, list[Received]], int]:
    """Step the plant with ``u`` until every viewer has a row (its subscription is then taken)."""
    got: dict[FoxgloveClient, list[Received]] = {c: [] for c in clients}
    k = 0
    while not all(any(r.topic == PLANT_TOPIC for r in rs) for rs in got.values()):
        assert k + 50 <= len(u), "a viewer received no plant row while the plant stepped the whole sequence"
        for _ in range(50):
            backend.step(float(u[k]))  # type: ignore[attr-defined]
            k += 1
        for client, rs in got.items():
            while (r := client.receive(0.01)) is not None:
                rs.append(r)
    return got, k


class _ReferencePublisher:
    """A private rclpy node publishing the agent's set-point on /msd/reference (as the agent node does)."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Float64

        from msd_msgs_py.contract import REFERENCE
        from msd_msgs_py.ros import qos

        self._msg = Float64
        self.ctx = Context()
        rclpy.init(args=[], context=self.ctx)
        self.node = rclpy.create_node("live_test_reference", context=self.ctx, start_parameter_services=False)
        self.pub = self.node.create_publisher(Float64, REFERENCE.resolve("/msd"), qos(REFERENCE))
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def publish(self, value: float, readers: int, timeout: float = 30.0) -> None:
        """Publish once ``readers`` subscriptions matched (volatile: a later reader would miss it)."""
        deadline = time.monotonic() + timeout
        while self.pub.get_subscription_count() < readers:
            assert time.monotonic() < deadline, f"fewer than {readers} readers of reference"
            self.executor.spin_once(timeout_sec=0.05)
        self.pub.publish(self._msg(data=value))

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.shutdown()


@pytest.mark.e2e
@pytest.mark.parametrize("argv", [
    ["launch_scripts/plant.py", "--ros-args", "-p", "lockstep:=true", "-p", "duplicate_check:=0.0",
     "-p", "live_port:={port}"],
    ["launch_scripts/bench.py", "--live", "{port}", "--stages", "record", "--out", "{out}"],
], ids=["plant", "bench"])
def test_a_port_in_use_stops_the_process_with_one_line(argv: list[str], tmp_path: object) -> None:
    out = os.path.join(str(tmp_path), "run")
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        args = [a.format(port=port, out=out) for a in argv]
        proc = subprocess.run([sys.executable, *args], cwd=launch.REPO_ROOT, capture_output=True, text=True,
                              timeout=120, check=False)
    errors = [ln for ln in proc.stderr.splitlines() if "error" in ln.lower()]
    assert proc.returncode == 2, proc.stderr
    assert len(errors) == 1 and f"cannot serve the live view on 127.0.0.1:{port}" in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr
    assert not os.path.exists(out)  # nothing written: the run never started


# --- the layout in docs/ -------------------------------------------------------------------------

LAYOUT = launch.REPO_ROOT / "docs" / "live-layout.json"
PATH_KEYS = ("value", "topicPath", "path", "topicToRender")
"""The keys by which the layout's panels name a topic or a message path."""


def _panel_ids(node: object) -> list[str]:
    """The panel ids a layout's mosaic tree places (its leaves)."""
    if isinstance(node, str):
        return [node]
    assert isinstance(node, dict)
    return _panel_ids(node["first"]) + _panel_ids(node["second"])


def _paths(config: object) -> list[str]:
    """Every topic or message path a panel's config names."""
    if isinstance(config, dict):
        own = [v for k, v in config.items() if k in PATH_KEYS and isinstance(v, str)]
        return own + [p for v in config.values() for p in _paths(v)]
    if isinstance(config, list):
        return [p for v in config for p in _paths(v)]
    return []


def _field_exists(client: FoxgloveClient, topic: str, fields: list[str]) -> bool:
    """Whether ``a.b[0].c`` names a field of the channel's advertised schema (protobuf or JSON)."""
    channel = client.channels[topic]
    if channel["encoding"] == "json":
        props = json.loads(channel["schema"])["properties"]
        return len(fields) == 1 and fields[0] in props
    from tests.graph.foxglove_client import _message_class

    desc = _message_class(channel["schemaName"], channel["schema"]).DESCRIPTOR
    for i, name in enumerate(fields):
        f = desc.fields_by_name.get(re.sub(r"\[\d+\]$", "", name))
        if f is None:
            return False
        if i < len(fields) - 1:
            if f.message_type is None:
                return False
            desc = f.message_type
    return True


def test_the_layout_places_every_panel_and_names_only_advertised_fields(server: LiveServer) -> None:
    layout = json.loads(LAYOUT.read_text())
    assert sorted(_panel_ids(layout["layout"])) == sorted(layout["configById"])
    panels = set(layout["configById"])
    assert {p.split("!")[0] for p in panels} >= {"Plot", "RawMessages"}  # a plot and a progress panel
    client = FoxgloveClient(server.url)
    try:
        client.wait_for_channels(TOPICS)
        paths = _paths(layout["configById"])
        topics = {p.split(".")[0] for p in paths}
        assert topics == set(TOPICS), topics
        for path in paths:
            topic, *fields = path.split(".")
            assert not fields or _field_exists(client, topic, fields), path
    finally:
        client.close()
    plotted = {p for k, c in layout["configById"].items() if k.startswith("Plot!") for p in _paths(c)}
    assert plotted == {f"{PLANT_TOPIC}.joints[0].position", f"{SETPOINT_TOPIC}.setpoint",
                       f"{PLANT_TOPIC}.joints[0].effort"}


@pytest.mark.e2e
def test_the_rig_serves_its_own_measured_rows() -> None:
    """The rig emulator with ``live_port:=0``, driven in real time: every live row equals the row of
    the same stamp the rig publishes on ``/rig/joint_states`` (measured position, applied effort)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from msd_msgs_py.contract import FORCE, JOINT_STATES
    from msd_msgs_py.ros import qos

    with launch.process_group() as procs:
        rig = procs.start("rig.py", ["-p", "live_port:=0", "-p", "duplicate_check:=0.0"])
        line = rig.wait_for_line(r"live view on ws://127\.0\.0\.1:\d+", 60.0)
        rig.wait_for_line(r"ready \(", 60.0)
        client = _viewer(re.search(r"ws://127\.0\.0\.1:\d+", line).group(0))  # type: ignore[union-attr]
        ctx = Context()
        rclpy.init(args=[], context=ctx)
        node = rclpy.create_node("live_test_rig", context=ctx, start_parameter_services=False)
        dds: dict[int, tuple[float, float]] = {}

        def on_row(m: JointState) -> None:
            dds[m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec] = (m.position[0], m.effort[0])

        node.create_subscription(JointState, JOINT_STATES.resolve("/rig"), on_row, qos(JOINT_STATES))
        force = node.create_publisher(Float64, FORCE.resolve("/rig"), qos(FORCE))
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        live_rows: list[tuple[int, float, float, float]] = []
        try:
            deadline = time.monotonic() + 90.0
            while sum(r[0] in dds for r in live_rows) < 10:
                assert time.monotonic() < deadline, f"{len(live_rows)} live rows, {len(dds)} DDS rows"
                force.publish(Float64(data=4.0 if int(time.monotonic() * 2) % 2 else -4.0))
                executor.spin_once(timeout_sec=0.01)
                while (r := client.receive(0.005)) is not None:
                    if r.topic == PLANT_TOPIC:
                        live_rows.append(_joint(r))
        finally:
            client.close()
            executor.shutdown()
            node.destroy_node()
            ctx.shutdown()
    shared = [r for r in live_rows if r[0] in dds]
    assert all((pos, eff) == dds[stamp] for stamp, pos, _vel, eff in shared), shared
    assert len({eff for *_, eff in shared}) > 1 or len({pos for _, pos, *_ in shared}) > 1  # not a still rig


# --- --live-wait -------------------------------------------------------------------------------------

@pytest.mark.parametrize(("argv", "said"), [
    (["--live-wait", "5"], "--live-wait needs --live"),
    (["--live", "0", "--live-wait", "-1"], "--live-wait -1.0: give seconds"),
    (["--live", "0", "--live-wait", "nan"], "--live-wait nan: give seconds"),
])
def test_live_wait_is_refused_in_one_line_without_live_or_as_no_duration(argv: list[str], said: str) -> None:
    from msd_bench.core.errors import ConfigError
    from msd_bench.graph.main import config, parse

    with pytest.raises(ConfigError) as err:
        config(parse(["--out", "/nonexistent/run", *argv]))
    assert str(err.value).startswith(said)


class _Viewer:
    """A live server whose viewer subscribes after ``polls`` looks (or never, with None)."""

    def __init__(self, polls: int | None) -> None:
        self.polls, self.looks = polls, 0

    @property
    def watched(self) -> bool:
        self.looks += 1
        return self.polls is not None and self.looks > self.polls


def test_live_wait_starts_once_a_viewer_subscribes_and_says_so_when_none_does() -> None:
    from msd_bench.graph.live import _await_viewer

    lines: list[str] = []
    viewer = _Viewer(polls=3)
    _await_viewer(viewer, 60.0, lines.append)  # type: ignore[arg-type]
    assert viewer.looks >= 4 and lines == ["a viewer subscribed; starting"]
    lines.clear()
    _await_viewer(_Viewer(polls=None), 0.2, lines.append)  # type: ignore[arg-type]
    assert lines == ["no viewer subscribed within --live-wait 0.2 s; starting anyway"]
