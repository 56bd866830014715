"""Recorder node: chosen contract topics into one rosbag2 (MCAP) bag per experiment.

A thin adapter: subscriptions take the serialized CDR bytes (``raw=True``) and
hand them to :class:`~msd_bench.io.bags.reader.BagRecorder` unchanged, stamped with
the node clock (sim time in lock-step mode). The bag is closed when the node
closes (Ctrl-C, SIGTERM through :mod:`.spin`) or when a limit is reached, which
also completes ``done`` so the process exits. A timer flushes the open chunk
while topics are idle, so a SIGKILL loses at most about ``flush_period_s``.

Log times (``log_time``). ``receive`` is rosbag2's: the node clock when the
message arrives. ``stamp`` is sim time for a lock-step graph, where the node
clock means nothing (a lock-step experiment of 130 s of samples runs in a few
seconds of wall clock): a stamped message (``joint_states``, ``/clock``) is
logged at the time it carries, and an unstamped one (``position``, ``force``)
at the newest sim time seen so far (one that arrives before any is held until
the first). So a lock-step bag's log times equal its header stamps and its
``duration`` is the sampled span. ``auto`` (default) decides at the first
stamped message: ``stamp`` when ``use_sim_time`` is set or the stamp is a day
or more from the wall clock (lock-step stamps count from 0), else ``receive``;
a recording of unstamped topics only is ``receive``. (Not "a /clock publisher
exists": any lock-step node anywhere in the domain publishes one.)

Each topic's ``offered_qos_profiles`` are the profiles its publishers offer in
the graph when its first message is written, as ``ros2 bag record`` stores them.

A write error (full or read-only storage) stops the recording: the bag is
closed with what reached the disk whole (:class:`~msd_bench.io.bags.bag_writer.BagWriteError`
says how much), one error line is logged, and the process exits with
:data:`EXIT_WRITE_ERROR`.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any, ClassVar

from rclpy._rclpy_pybind11 import InvalidHandle, RCLError
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription
from rclpy.task import Future
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from std_msgs.msg import String

from msd_bench.core.errors import ConfigError
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_writer import STAMPED_TYPES, BagRecorder, leading_stamp
from msd_bench.nodes import endpoints
from msd_bench.nodes.interface_params import declare_interface
from msd_bench.nodes.params import check_job_used, declare_config
from msd_msgs_py.contract import (
    ALL_TOPICS,
    FORCE,
    JOINT_STATES,
    PLANT_NAMESPACE,
    POSITION,
    RECORD_DEPTH,
    RECORDER_READY,
    TopicSpec,
)
from msd_msgs_py.interface import COMMANDS_TYPE, PlantInterface
from msd_msgs_py.ros import msg_class, qos

_SPECS = {spec.name: spec for spec in ALL_TOPICS}

LOG_TIMES = ("auto", "receive", "stamp")
"""Values of ``log_time`` (module docstring)."""

SIM_TIME_GAP_NS = 86_400 * 1_000_000_000
"""A stamp a day or more away from the wall clock was not taken on it: the graph runs on sim time."""

ROLE = "recorder"
"""The recorder's job role (:mod:`msd_bench.app.job`): bench.py hands it ``-p job:=<file>``."""

EXIT_WRITE_ERROR = 1
"""Exit status of a recorder whose storage refused a write (the bag is closed, shorter)."""


@dataclass(frozen=True)
class RecorderConfig:
    """What to record and where; one ROS parameter per field."""

    bag_path: str = ""
    """Bag directory to create (must not exist); required."""
    topics: tuple[str, ...] = (JOINT_STATES.name, POSITION.name, FORCE.name)
    """Contract topic names to record, relative to ``namespace`` (``/clock`` is absolute); a
    ros2_control face's command topic is ``<controller>/commands`` (docs/ros2-control.md §Face)."""
    namespace: str = PLANT_NAMESPACE
    """Namespace of the plant-like node whose topics are recorded."""
    params_json: str = "{}"
    """Experiment parameters as a JSON object, stored in the bag."""
    max_duration_s: float = 0.0
    """Stop after this long from the first message (monotonic clock); 0 = no limit."""
    ready_grace_s: float = 0.5
    """Seconds between all readers matching and announcing ``recorder/ready``."""
    max_messages: int = 0
    """Stop after this many messages over all topics; 0 = no limit."""
    flush_period_s: float = 1.0
    """Longest time recorded data stays in memory only (what a SIGKILL can lose)."""
    log_time: str = "auto"
    """Log times: ``receive`` (node clock on arrival), ``stamp`` (sim time from the stamps) or
    ``auto`` (``stamp`` when use_sim_time is set or a /clock publisher exists, else ``receive``)."""
    pooled: bool = False
    """In a served process, keep the subscriptions (already matched) for the next job's bag
    (:mod:`msd_bench.nodes.endpoints`). Only for lock-step plants, which publish nothing between
    experiments: a free-running plant's samples would wait in the reader for the next bag."""

    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "max_duration_s": (0.0, 1e6),
        "max_messages": (0, 2**31 - 1),
        "flush_period_s": (0.05, 60.0),
        "ready_grace_s": (0.0, 30.0),
    }

    def __post_init__(self) -> None:
        if not self.bag_path:
            raise ConfigError("bag_path is required (the bag directory to create)")
        unknown = [t for t in self.topics if t not in _SPECS and not t.endswith("/commands")]
        if not self.topics or unknown:
            raise ConfigError(f"topics must be among {sorted(_SPECS)} or <controller>/commands, "
                              f"got {list(self.topics)}")
        if self.log_time not in LOG_TIMES:
            raise ConfigError(f"log_time must be one of {', '.join(LOG_TIMES)}, got {self.log_time!r}")
        if self.log_time == "stamp" and not any(s.ros_type in STAMPED_TYPES for s in self.specs()):
            raise ConfigError("log_time stamp needs a stamped topic among the topics (joint_states, /clock)")
        self.params()

    def params(self) -> dict[str, Any]:
        """The experiment parameters as a dict."""
        try:
            value = json.loads(self.params_json)
        except json.JSONDecodeError as exc:
            raise ConfigError(f"params_json is not valid JSON: {exc.msg}") from None
        if not isinstance(value, dict):
            raise ConfigError("params_json must be a JSON object")
        return value

    def specs(self, iface: PlantInterface | None = None) -> tuple[TopicSpec, ...]:
        """The contract entries of the recorded topics; ``<controller>/commands`` is ``iface``'s.

        Without ``iface`` a command topic is described by its type only (enough to
        validate the log-time choice); the node checks it against its interface.
        """
        known = dict(_SPECS)
        for t in self.topics:
            if t in known:
                continue
            if iface is None:
                known[t] = TopicSpec(t, COMMANDS_TYPE, FORCE.depth, "commands")
            elif iface.command.name == t:
                known[t] = iface.command
            else:
                raise ConfigError(f"topic {t} is not the command topic of the plant interface "
                                  f"({iface.command.name}); set controller to match")
        return tuple(known[t] for t in self.topics)


class RecorderNode(Node):
    """Records the configured topics until closed or a limit is reached."""

    events_executor = True
    """A lock-step experiment streams thousands of samples a second: the events executor (:mod:`.spin`)
    hands each to its callback without rebuilding a wait set per message."""

    def __init__(self, **node_kwargs: Any) -> None:
        self._recorder: BagRecorder | None = None  # set first: destroy_node() may run on a failed init
        self._held: list[tuple[str, str, bytes, int]] = []
        """(topic, type, data, arrival ns) of unstamped messages waiting for a sim time or a decision."""
        super().__init__("recorder", **node_kwargs)
        self.config = declare_config(self, RecorderConfig, ROLE)
        self.interface = declare_interface(self)
        check_job_used(self)  # a stray job field is refused before the bag is created
        self._specs = self.config.specs(self.interface)
        self.done: Future[int] = Future()
        self._recorder = BagRecorder(
            self.config.bag_path,
            params=self.config.params(),
            flush_period_s=self.config.flush_period_s,
        ).open()
        self._started: float | None = None
        self._written = 0
        self._log_time: str | None = None if self.config.log_time == "auto" else self.config.log_time
        self._sim_ns: int | None = None
        """Newest sim time seen in a stamp (``stamp`` log times)."""
        self._expects_stamps = any(spec.ros_type in STAMPED_TYPES for spec in self._specs)
        self._offered: dict[str, list[Qos]] = {}
        self._subs: dict[str, Subscription[Any] | endpoints.PooledSubscription] = {}
        self._unmatched: set[str] = set()
        for spec in self._specs:
            self._subscribe(spec)
        self._timer = self.create_timer(self.config.flush_period_s / 2, self._on_timer)
        self._ready_pub = endpoints.create_publisher(
            self, String, RECORDER_READY.resolve(self.config.namespace), qos(RECORDER_READY),
            pooled=self.config.pooled)
        self._match_timer = self.create_timer(0.02, self._on_match_poll)
        self.get_logger().info(f"recording {list(self.config.topics)} to {self.config.bag_path}")

    def _subscribe(self, spec: TopicSpec) -> None:
        topic = spec.resolve(self.config.namespace)

        def on_message(data: bytes) -> None:
            self._record(topic, spec.ros_type, data)

        profile = qos(spec)  # commands are keep-last 1: a lagging recorder would drop them
        profile.depth = max(profile.depth, RECORD_DEPTH)
        self._subs[topic] = endpoints.create_subscription(
            self, msg_class(spec), topic, on_message, profile, raw=True, pooled=self.config.pooled)
        self._unmatched.add(topic)

    def _on_match_poll(self) -> None:
        """Log ``matched <topic>`` per topic; once all are matched, announce ``recorder/ready``.

        The announcement (latched, carrying the bag path) is what an excitation waits for:
        our readers see the publishers, and a short grace lets the publishers' side match
        us too (discovery is not symmetric), so the first sample is not lost. A pooled reader
        matched in an earlier job has had its grace already.
        """
        now = time.monotonic()
        since = {t: endpoints.matched_since(sub, sub.get_publisher_count() > 0, now)
                 for t, sub in self._subs.items()}
        for topic in sorted(self._unmatched):
            if since[topic] is not None:
                self._unmatched.discard(topic)
                self._offered_qos(topic)
                self.get_logger().info(f"matched {topic}")
        times = [t for t in since.values() if t is not None]
        if len(times) < len(since):
            return
        if now - max(times) >= self.config.ready_grace_s:
            self._ready_pub.publish(String(data=str(self.config.bag_path)))
            self.get_logger().info("ready")
            self._match_timer.cancel()

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self._written

    def _decide_log_time(self, stamp: int | None) -> str | None:
        """Resolve ``auto`` once, at the first stamped message (None: not yet).

        Sim time when use_sim_time is on or the stamp is :data:`SIM_TIME_GAP_NS`
        or more from the wall clock (a lock-step plant stamps k·dt from 0).
        Without a stamped topic among those recorded there is no sim time to
        read: arrival times, as rosbag2 (sim time already if use_sim_time is on).
        """
        if not self._expects_stamps:
            sim = False
        elif stamp is None:
            return None
        else:
            sim = (bool(self.get_parameter("use_sim_time").value)
                   or abs(stamp - time.time_ns()) >= SIM_TIME_GAP_NS)
        self._log_time = "stamp" if sim else "receive"
        self.get_logger().info(
            "log times: sim time from the stamps" if sim else "log times: node clock on arrival")
        return self._log_time

    def _record(self, topic: str, ros_type: str, data: bytes) -> None:
        if self._recorder is None:
            return
        if self._started is None:
            self._started = time.monotonic()
        now = self.get_clock().now().nanoseconds
        stamp = leading_stamp(ros_type, data)
        mode = self._log_time or self._decide_log_time(stamp)
        if mode == "receive":
            self._release_held(None)
            self._write(topic, ros_type, now, data)
        elif stamp is not None:
            self._sim_ns = stamp if self._sim_ns is None else max(self._sim_ns, stamp)
            self._release_held(self._sim_ns)
            self._write(topic, ros_type, stamp, data)
        elif mode is None or self._sim_ns is None:
            self._held.append((topic, ros_type, data, now))
        else:
            self._write(topic, ros_type, self._sim_ns, data)

    def _release_held(self, t_ns: int | None) -> None:
        """Write the messages that waited for a time: at ``t_ns``, or at their arrival if None."""
        held, self._held = self._held, []
        for topic, ros_type, data, arrival in held:
            self._write(topic, ros_type, arrival if t_ns is None else t_ns, data)

    def _write(self, topic: str, ros_type: str, t_ns: int, data: bytes) -> None:
        if self._recorder is None:
            return
        try:
            self._recorder.write(topic, ros_type, t_ns, data, self._offered_qos(topic))
        except BagError as exc:
            self._fail(exc)
            return
        self._written += 1
        self._check_limits()

    def _offered_qos(self, topic: str) -> list[Qos]:
        """The profiles the topic's publishers offer, read from the graph once per topic.

        Read when the topic matches (:meth:`_on_match_poll`), or here at its first
        message; a message written while closing after a signal (the context is
        gone, the graph cannot be asked) gets none rather than losing the bag.
        """
        if topic not in self._offered:
            try:
                infos = self.get_publishers_info_by_topic(topic)
            except (RCLError, InvalidHandle):
                return []
            self._offered[topic] = [bag_qos(i.qos_profile) for i in infos]
        return self._offered[topic]

    def _on_timer(self) -> None:
        if self._recorder is not None:
            try:
                self._recorder.flush_if_due()
            except BagError as exc:
                self._fail(exc)
                return
            self._check_limits()

    def _fail(self, exc: BagError) -> None:
        """Storage refused a write: the bag is already closed; say so once and end non-zero."""
        self._recorder = None
        self.get_logger().error(str(exc))
        if not self.done.done():
            self.done.set_result(EXIT_WRITE_ERROR)

    def _check_limits(self) -> None:
        cfg = self.config
        over_count = cfg.max_messages and self.message_count >= cfg.max_messages
        over_time = (
            cfg.max_duration_s
            and self._started is not None
            and time.monotonic() - self._started >= cfg.max_duration_s
        )
        if over_count or over_time:
            self.close()

    def close(self) -> None:
        """Finish the bag (summary + metadata.yaml) and complete ``done``; idempotent."""
        if self._held and self._recorder is not None:  # no time ever came: keep them, at arrival
            self._release_held(None)
        recorder, self._recorder = self._recorder, None
        if recorder is None:
            return
        try:
            recorder.close()
        except BagError as exc:
            self._recorder = None
            print(f"[{self.get_fully_qualified_name()}] error: {exc}", flush=True)
            if not self.done.done():
                self.done.set_result(EXIT_WRITE_ERROR)
            return
        if self.context.ok():  # after SIGTERM the context is gone and rosout would complain
            self.get_logger().info(f"closed {recorder.path} with {recorder.message_count} messages")
        if not self.done.done():
            self.done.set_result(0)

    def destroy_node(self) -> None:
        """Never leave an open bag behind."""
        self.close()
        super().destroy_node()


def bag_qos(profile: QoSProfile) -> Qos:
    """An rclpy profile in rosbags' terms (the enums share rmw's numbering; others become UNKNOWN)."""

    def enum(cls: Any, value: Any) -> Any:
        try:
            return cls(int(value))
        except ValueError:
            return cls.UNKNOWN

    def span(d: Duration) -> QosTime:
        return QosTime(d.nanoseconds // 1_000_000_000, d.nanoseconds % 1_000_000_000)

    return Qos(enum(QosHistory, profile.history), int(profile.depth),
               enum(QosReliability, profile.reliability), enum(QosDurability, profile.durability),
               span(profile.deadline), span(profile.lifespan), enum(QosLiveliness, profile.liveliness),
               span(profile.liveliness_lease_duration), bool(profile.avoid_ros_namespace_conventions))
