"""The live view's server: a Foxglove WebSocket server on 127.0.0.1 and its channels (docs/live.md).

No rclpy here: the same server runs inside ``bench.py`` (fed by a small
subscriber, :mod:`msd_bench.graph.live`) and inside a plant or rig process (fed
by the node's own step, ``-p live_port:=PORT``). What goes out:

``/plant/joint_states``  ``foxglove.JointStates`` (protobuf): joint ``msd_slider``
                         with position x_k, velocity v_k and effort u_k (the
                         force applied over the sample, after saturation: the
                         command), stamped with the row's own stamp t_k;
``/plant/setpoint``      JSON ``{"t", "setpoint"}``: the latest set-point (m),
                         repeated with every plant sample so a plot draws a line;
``/bench/progress``      JSON ``{"stage", "state", "item", "done", "total",
                         "fraction", "seconds"}``: bench.py's stages and bars;
``/bench/log``           ``foxglove.Log``: bench.py's progress lines.

Why decimated: in lock-step the plant steps thousands of times a second and a
viewer needs a plot, not every sample. :class:`WallDecimator` lets through at
most one sample per :data:`PERIOD_S` of wall time (50 Hz), and the newest
sample held back is sent by :meth:`LiveServer.flush`, so the last state before
the plant goes quiet is always shown. Every sample that goes out is the plant's
own row, unchanged.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

from msd_bench.core.errors import MsdBenchError

HOST = "127.0.0.1"
"""The server binds loopback only: the bench's telemetry is not for the network."""
DEFAULT_PORT = 8765
"""Foxglove's usual port (``bench.py --live`` without a number)."""
EPHEMERAL = 0
"""Port 0: the OS picks a free port; the chosen one is printed (what tests use)."""
OFF = -1
"""``live_port`` of a node without a live view (the parameter's default)."""
PERIOD_S = 0.02
"""Wall-time decimation: at most one plant sample per 20 ms (50 Hz) goes out."""
JOINT = "msd_slider"
"""The joint name the live view shows (the contract's joint)."""
PLANT_TOPIC = "/plant/joint_states"
SETPOINT_TOPIC = "/plant/setpoint"
PROGRESS_TOPIC = "/bench/progress"
LOG_TOPIC = "/bench/log"
SUBPROTOCOL = "foxglove.sdk.v1"
"""The WebSocket subprotocol foxglove-sdk 0.30 accepts (it refuses ``foxglove.websocket.v1`` alone)."""

SETPOINT_SCHEMA: dict[str, Any] = {
    "type": "object", "title": "msd_bench.Setpoint",
    "properties": {"t": {"type": "number", "description": "stamp of the plant sample it goes with, s"},
                   "setpoint": {"type": "number", "description": "the agent's set-point, m"}}}
PROGRESS_SCHEMA: dict[str, Any] = {
    "type": "object", "title": "msd_bench.StageProgress",
    "properties": {"stage": {"type": "string"}, "state": {"type": "string"}, "item": {"type": "string"},
                   "done": {"type": "integer"}, "total": {"type": "integer"},
                   "fraction": {"type": "number"}, "seconds": {"type": "number"}}}


class LiveError(MsdBenchError):
    """The live view could not start (a port in use, a port out of range): one line."""


def check_port(port: int, what: str) -> int:
    """``port`` if it is one a server can bind (0: ephemeral), else a one-line :class:`LiveError`."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise LiveError(f"{what}: a TCP port is 0..65535 (0 picks a free one), got {port!r}")
    return port


@dataclass
class WallDecimator:
    """At most one sample per ``period_ns`` of monotonic time; remembers the newest one held back.

    Why wall time and not every Nth sample: lock-step runs at whatever rate the
    middleware allows (thousands per second, or a few hundred under load) and
    real time at 100 Hz; a fixed wall rate gives the viewer the same plot rate
    in every mode.
    """

    period_ns: int = round(PERIOD_S * 1e9)
    """Minimum spacing (ns) of two samples let through."""
    _next_ns: int = 0
    held: tuple[int, float, float, float] | None = field(default=None, repr=False)
    """The newest sample not let through (cleared when one goes out)."""

    def offer(self, now_ns: int, sample: tuple[int, float, float, float]) -> bool:
        """Whether ``sample`` goes out now; if not it is held as the newest pending one."""
        if now_ns >= self._next_ns:
            self._next_ns = now_ns + self.period_ns
            self.held = None
            return True
        self.held = sample
        return False

    def take_held(self) -> tuple[int, float, float, float] | None:
        """The sample held back (and forget it): what :meth:`LiveServer.flush` sends."""
        held, self.held = self.held, None
        return held


class LiveServer:
    """One Foxglove WebSocket server of this process with the live view's channels."""

    def __init__(self, port: int, name: str, what: str = "live_port") -> None:
        """Bind ``127.0.0.1:port`` (``what`` names the option in the one-line error)."""
        import foxglove
        from foxglove.channels import JointStatesChannel, LogChannel

        check_port(port, what)
        self._ctx = foxglove.Context()
        try:
            self._server = foxglove.start_server(name=name, host=HOST, port=port, context=self._ctx)
        except RuntimeError as exc:  # the SDK's FoxgloveError: "Failed to bind port: Address already in use"
            raise LiveError(f"{what} {port}: cannot serve the live view on {HOST}:{port} "
                            f"({str(exc).removeprefix('FoxgloveError: ')})") from None
        self._plant = JointStatesChannel(PLANT_TOPIC, context=self._ctx)
        self._setpoint_ch = foxglove.Channel(SETPOINT_TOPIC, schema=SETPOINT_SCHEMA, context=self._ctx)
        self._progress = foxglove.Channel(PROGRESS_TOPIC, schema=PROGRESS_SCHEMA, context=self._ctx)
        self._log = LogChannel(LOG_TOPIC, context=self._ctx)
        self._decimator = WallDecimator()
        self._setpoint: float | None = None
        self._closed = False

    @property
    def port(self) -> int:
        """The port the server listens on (the OS's choice when started with 0)."""
        return int(self._server.port)

    @property
    def url(self) -> str:
        """What a viewer opens: ``ws://127.0.0.1:PORT``."""
        return f"ws://{HOST}:{self.port}"

    @property
    def watched(self) -> bool:
        """Whether a viewer is subscribed to the plant's rows (nobody watching: nothing is encoded)."""
        return bool(self._plant.has_sinks())

    def plant(self, stamp_ns: int, x: float, v: float, u: float) -> None:
        """Offer plant row k (stamp t_k, x_k, v_k, applied force u_k); sent if the decimator lets it."""
        sample = (int(stamp_ns), float(x), float(v), float(u))
        if self._decimator.offer(time.monotonic_ns(), sample):
            self._send(sample)

    def flush(self) -> None:
        """Send the newest plant sample held back by the decimator, if any (called ~1 Hz)."""
        held = self._decimator.take_held()
        if held is not None:
            self._send(held)

    def setpoint(self, value: float) -> None:
        """The agent's newest set-point (m): sent with every plant sample from now on."""
        if math.isfinite(value):
            self._setpoint = float(value)

    def progress(self, stage: str, state: str, item: str = "", done: int = 0, total: int = 0,
                 seconds: float | None = None) -> None:
        """One stage's progress: ``state`` running/done, ``done`` of ``total`` items, the current item."""
        msg: dict[str, Any] = {"stage": stage, "state": state, "item": item, "done": int(done),
                               "total": int(total), "fraction": done / total if total > 0 else 0.0}
        if seconds is not None:
            msg["seconds"] = float(seconds)
        self._progress.log(msg)

    def log(self, line: str) -> None:
        """One of bench.py's progress lines as a ``foxglove.Log`` (level info)."""
        from foxglove.messages import Log, LogLevel

        self._log.log(Log(level=LogLevel.Info, message=line, name="bench"))

    def close(self) -> None:
        """Send what the decimator holds, then stop the server (idempotent): the run is over."""
        if self._closed:
            return
        self._closed = True
        self.flush()
        self._server.stop()

    def _send(self, sample: tuple[int, float, float, float]) -> None:
        from foxglove.messages import JointState, JointStates, Timestamp

        if not self.watched:
            return
        stamp_ns, x, v, u = sample
        stamp = Timestamp(sec=stamp_ns // 1_000_000_000, nsec=stamp_ns % 1_000_000_000)
        self._plant.log(JointStates(timestamp=stamp, joints=[
            JointState(name=JOINT, position=x, velocity=v, effort=u)]))
        if self._setpoint is not None:
            self._setpoint_ch.log({"t": stamp_ns * 1e-9, "setpoint": self._setpoint})


def start_live(port: int, name: str, what: str = "live_port") -> LiveServer | None:
    """A started :class:`LiveServer`, or None for :data:`OFF` (a node's default)."""
    if port == OFF:
        return None
    return LiveServer(port, name, what)
