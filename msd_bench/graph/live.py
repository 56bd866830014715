"""``bench.py --live``: the live view served from bench.py's own process (docs/live.md).

bench.py drives node processes and has no rclpy of its own, so the live view
brings a small one: :class:`PlantWatch`, a private rclpy context whose node
subscribes to the plant-like node's ``joint_states`` and ``reference`` and
hands them to the Foxglove server of :mod:`msd_bench.io.reports.live_server`. The stages'
progress comes from the bench itself: :func:`timed` stages report their start
and end (:func:`stage`), the stage bars their items (:class:`LiveStageProgress`)
and the ``[bench]`` lines go out as logs (:func:`log`).

Why the rows cost bench.py next to nothing although lock-step runs at
thousands of samples a second: the subscription keeps a history of one, and
the watch thread takes from it only every :data:`PERIOD_S` (50 Hz of wall
time). DDS keeps just the newest row in between, so the Python callback runs
at most 50 times a second whatever the plant's rate, and the row shown is
always the plant's newest. Reliable, so the last row before the plant goes
quiet is never lost (the plant's writer keeps its own history: a reader of
depth one never holds it back). rclpy is imported only when the live
view starts: a run without ``--live`` loads none of it.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from msd_bench.io.reports.live_server import PERIOD_S, LiveServer
from msd_bench.progress import StageProgress
from msd_msgs_py.contract import REFERENCE
from msd_msgs_py.interface import PlantInterface

_ACTIVE: list[LiveServer] = []
"""The running live view of this process (at most one): what :func:`stage` and :func:`log` feed."""


def active() -> LiveServer | None:
    """The live view bench.py serves now, or None (no ``--live``)."""
    return _ACTIVE[0] if _ACTIVE else None


def stage(name: str, state: str, seconds: float | None = None) -> None:
    """A stage started (``running``) or ended (``done``, ``failed``), if a live view is on."""
    live = active()
    if live is not None:
        live.progress(name, state, seconds=seconds)


def log(line: str) -> None:
    """One ``[bench]`` line, if a live view is on."""
    live = active()
    if live is not None:
        live.log(line)


class LiveStageProgress(StageProgress):
    """bench.py's stage bar, whose every update also goes to the live view."""

    def update(self, stage: str, done: int, total: int) -> None:
        """Show it on the bar and send it as the stage's progress (the bar's name is the stage)."""
        super().update(stage, done, total)
        live = active()
        if live is not None:
            live.progress(self._name, "running", item=stage, done=done, total=total)


class PlantWatch:
    """A thread with a private rclpy context: the plant's newest row and set-point, 50 times a second."""

    def __init__(self, live: LiveServer, namespace: str, iface: PlantInterface) -> None:
        """Subscribe under ``namespace`` (the run's plant-like node, through its face ``iface``)."""
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

        from msd_bench.dds import start_confined
        from msd_msgs_py.ros import msg_class, qos

        def session() -> tuple[Any, Any]:
            ctx = Context()
            rclpy.init(args=[], context=ctx)
            return ctx, rclpy.create_node("bench_live", context=ctx, start_parameter_services=False)

        def end(s: tuple[Any, Any]) -> None:
            s[1].destroy_node()
            s[0].shutdown()

        self._live = live
        self._joint = iface.joint
        self._rows = 0
        self._ctx, self._node = start_confined(session, end)  # loopback under LOCALHOST, as every node
        newest = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE)
        state = iface.state
        self._node.create_subscription(msg_class(state), state.resolve(namespace), self._on_row, newest)
        self._node.create_subscription(msg_class(REFERENCE), REFERENCE.resolve(namespace),
                                       lambda m: live.setpoint(m.data), qos(REFERENCE))
        self._executor = SingleThreadedExecutor(context=self._ctx)
        self._executor.add_node(self._node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="live view", daemon=True)
        self._thread.start()

    def _on_row(self, msg: Any) -> None:
        """Our joint's row of a ``joint_states`` message (a ros2_control face lists other joints too)."""
        try:
            i = list(msg.name).index(self._joint)
            x, v, u = msg.position[i], msg.velocity[i], msg.effort[i]
        except (ValueError, IndexError):  # not our joint, or a short row: nothing to show
            return
        self._rows += 1
        self._live.plant(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, x, v, u)

    def _run(self) -> None:
        """Take what is waiting (a few callbacks at most), then sleep to the next 20 ms slot; a slot
        without a new row means the plant is quiet, so the row the decimator held back goes out."""
        while not self._stop.is_set() and self._ctx.ok():
            seen = self._rows
            for _ in range(4):
                self._executor.spin_once(timeout_sec=0.0)
            if self._rows == seen:
                self._live.flush()
            self._stop.wait(PERIOD_S)

    def close(self) -> None:
        """Stop the thread, then the node and its context (its DDS participant and shm go with it)."""
        self._stop.set()
        self._thread.join(timeout=5.0)
        self._executor.shutdown()
        self._node.destroy_node()
        self._ctx.shutdown()


def _await_viewer(live: LiveServer, wait_s: float, say: Callable[[str], None] | None) -> None:
    """Block until a viewer subscribes to the plant's rows or ``wait_s`` passes; say which."""
    deadline = time.monotonic() + wait_s
    while not live.watched and time.monotonic() < deadline:
        time.sleep(0.05)
    if say is not None:
        say("a viewer subscribed; starting" if live.watched else
            f"no viewer subscribed within --live-wait {wait_s:g} s; starting anyway")


@contextmanager
def live_view(port: int | None, namespace: str, iface: PlantInterface,
              say: Callable[[str], None] | None = None, wait_s: float = 0.0) -> Iterator[LiveServer | None]:
    """Serve the live view on ``port`` (None: no live view) for the ``with`` block: the run's lifetime.

    With ``wait_s`` > 0 the block starts only once a viewer subscribes to the plant's rows, or after
    ``wait_s`` seconds without one (said in a line): an emulated record of a few seconds would be
    over before a viewer started by hand, or a script, has connected.
    A port in use is a one-line :class:`msd_bench.io.reports.live_server.LiveError` before any stage starts.
    """
    if port is None:
        yield None
        return
    live = LiveServer(port, "msd-bench", what="--live")
    watch: PlantWatch | None = None
    try:
        watch = PlantWatch(live, namespace, iface)
        _ACTIVE.append(live)
        if say is not None:
            say(f"live view on {live.url} (Foxglove/Lichtblick: docs/live.md)")
        if wait_s > 0.0:
            _await_viewer(live, wait_s, say)
        yield live
    finally:
        _ACTIVE.clear()
        if watch is not None:
            watch.close()
        live.close()
