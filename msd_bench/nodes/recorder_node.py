"""Recorder node: chosen contract topics into one rosbag2 (MCAP) bag per experiment.

A thin adapter: subscriptions take the serialized CDR bytes (``raw=True``) and
hand them to :class:`~msd_bench.io.bags.BagRecorder` unchanged, stamped with
the node clock (sim time in lock-step mode). The bag is closed when the node
closes (Ctrl-C, SIGTERM through :mod:`.spin`) or when a limit is reached, which
also completes ``done`` so the process exits. A timer flushes the open chunk
while topics are idle, so a SIGKILL loses at most about ``flush_period_s``.

A write error (full or read-only storage) stops the recording: the bag is
closed with what reached the disk whole (:class:`~msd_bench.io.bag_writer.BagWriteError`
says how much), one error line is logged, and the process exits with
:data:`EXIT_WRITE_ERROR`.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any, ClassVar

from rclpy.node import Node
from rclpy.subscription import Subscription
from rclpy.task import Future
from std_msgs.msg import String

from msd_bench.core.errors import ConfigError
from msd_bench.io.bag_writer import BagRecorder
from msd_bench.io.errors import BagError
from msd_bench.nodes.params import declare_from_dataclass
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
from msd_msgs_py.ros import msg_class, qos

_SPECS = {spec.name: spec for spec in ALL_TOPICS}

EXIT_WRITE_ERROR = 1
"""Exit status of a recorder whose storage refused a write (the bag is closed, shorter)."""


@dataclass(frozen=True)
class RecorderConfig:
    """What to record and where; one ROS parameter per field."""

    bag_path: str = ""
    """Bag directory to create (must not exist); required."""
    topics: tuple[str, ...] = (JOINT_STATES.name, POSITION.name, FORCE.name)
    """Contract topic names to record, relative to ``namespace`` (``/clock`` is absolute)."""
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

    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "max_duration_s": (0.0, 1e6),
        "max_messages": (0, 2**31 - 1),
        "flush_period_s": (0.05, 60.0),
        "ready_grace_s": (0.0, 30.0),
    }

    def __post_init__(self) -> None:
        if not self.bag_path:
            raise ConfigError("bag_path is required (the bag directory to create)")
        unknown = [t for t in self.topics if t not in _SPECS]
        if not self.topics or unknown:
            raise ConfigError(f"topics must be among {sorted(_SPECS)}, got {list(self.topics)}")
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

    def specs(self) -> tuple[TopicSpec, ...]:
        """The contract entries of the recorded topics."""
        return tuple(_SPECS[t] for t in self.topics)


class RecorderNode(Node):
    """Records the configured topics until closed or a limit is reached."""

    def __init__(self, **node_kwargs: Any) -> None:
        self._recorder: BagRecorder | None = None  # set first: destroy_node() may run on a failed init
        super().__init__("recorder", **node_kwargs)
        self.config = declare_from_dataclass(self, RecorderConfig)
        self.done: Future[int] = Future()
        self._recorder = BagRecorder(
            self.config.bag_path,
            params=self.config.params(),
            flush_period_s=self.config.flush_period_s,
        ).open()
        self._started: float | None = None
        self._written = 0
        self._unmatched: dict[str, Subscription[Any]] = {}
        for spec in self.config.specs():
            self._subscribe(spec)
        self._timer = self.create_timer(self.config.flush_period_s / 2, self._on_timer)
        self._ready_pub = self.create_publisher(
            String, RECORDER_READY.resolve(self.config.namespace), qos(RECORDER_READY))
        self._all_matched_at: float | None = None
        self._match_timer = self.create_timer(0.02, self._on_match_poll)
        self.get_logger().info(f"recording {list(self.config.topics)} to {self.config.bag_path}")

    def _subscribe(self, spec: TopicSpec) -> None:
        topic = spec.resolve(self.config.namespace)

        def on_message(data: bytes) -> None:
            self._record(topic, spec.ros_type, data)

        profile = qos(spec)  # commands are keep-last 1: a lagging recorder would drop them
        profile.depth = max(profile.depth, RECORD_DEPTH)
        self._unmatched[topic] = self.create_subscription(
            msg_class(spec), topic, on_message, profile, raw=True
        )

    def _on_match_poll(self) -> None:
        """Log ``matched <topic>`` per topic; once all are matched, announce ``recorder/ready``.

        The announcement (latched, carrying the bag path) is what an excitation waits for:
        our readers see the publishers, and a short grace lets the publishers' side match
        us too (discovery is not symmetric), so the first sample is not lost.
        """
        for topic, sub in list(self._unmatched.items()):
            if sub.get_publisher_count() > 0:
                del self._unmatched[topic]
                self.get_logger().info(f"matched {topic}")
        if self._unmatched:
            return
        now = time.monotonic()
        if self._all_matched_at is None:
            self._all_matched_at = now
        elif now - self._all_matched_at >= self.config.ready_grace_s:
            self._ready_pub.publish(String(data=str(self.config.bag_path)))
            self.get_logger().info("ready")
            self._match_timer.cancel()

    @property
    def message_count(self) -> int:
        """Messages written so far."""
        return self._written

    def _record(self, topic: str, ros_type: str, data: bytes) -> None:
        if self._recorder is None:
            return
        if self._started is None:
            self._started = time.monotonic()
        try:
            self._recorder.write(topic, ros_type, self.get_clock().now().nanoseconds, data)
        except BagError as exc:
            self._fail(exc)
            return
        self._written += 1
        self._check_limits()

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
