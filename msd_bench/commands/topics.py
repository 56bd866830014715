"""``echo TOPIC`` and ``hz TOPIC``: ``ros2 topic echo/hz`` for machines without the ROS 2 CLI.

The PyPI wheels ship rclpy but no ``ros2`` command, so these two look at the
bench from a terminal. The message type of a contract topic (``*/position``,
``*/joint_states``, ``/clock`` ...) comes from :mod:`msd_msgs_py.contract`
with its QoS; any other topic's type is looked up in the graph and read
best-effort (which matches reliable and best-effort publishers alike).

    msd-bench echo /msd/position --count 5
    msd-bench hz /msd/joint_states --window 200
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import itertools
import math
import re
import sys
import time
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data

from msd_bench.core.errors import MsdBenchError
from msd_bench.dds import confine_process
from msd_bench.nodes.spin import ros_session
from msd_msgs_py.contract import ALL_TOPICS
from msd_msgs_py.ros import qos


class TopicError(MsdBenchError):
    """The topic is unknown, has no publisher, or its type cannot be imported."""


def register(subparsers: Any) -> None:
    """Add ``echo`` and ``hz`` to an argparse subparsers object."""
    echo = subparsers.add_parser("echo", help="print messages of a topic (like ros2 topic echo)")
    _common(echo)
    echo.set_defaults(func=run_echo)
    hz = subparsers.add_parser("hz", help="print the rate of a topic (like ros2 topic hz)")
    _common(hz)
    hz.add_argument("--window", type=int, default=100, help="messages the statistics cover")
    hz.set_defaults(func=run_hz)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("topic", help="absolute topic name, e.g. /msd/position")
    p.add_argument("--count", type=int, default=0, help="stop after N messages (0: until Ctrl-C)")
    p.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for a publisher")


def resolve_type(node: Node, topic: str, timeout: float) -> tuple[type, QoSProfile]:
    """Message class and QoS of ``topic``: the contract first, then the graph."""
    for spec in ALL_TOPICS:
        if topic == spec.name or topic.endswith("/" + spec.name.lstrip("/")):
            return import_type(spec.ros_type), qos(spec)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for name, types in node.get_topic_names_and_types():
            if name == topic and types:
                return import_type(types[0]), qos_profile_sensor_data
        time.sleep(0.1)
    raise TopicError(f"topic {topic} has no publisher (waited {timeout} s)")


_PACKAGE = re.compile(r"[a-z][a-z0-9_]*\Z")
_TYPE = re.compile(r"[A-Z][A-Za-z0-9]*\Z")
"""ROS 2 naming rules for interface packages and message types (REP 144, rosidl)."""


def import_type(ros_type: str) -> type:
    """``pkg/msg/Name`` -> the generated class; only ROS message types, never another module.

    Why so strict: the name may come from any participant on the domain (the
    graph reports the type another node advertises), and importing a module
    runs its code. So the name must be ``<package>/msg/<Type>`` with ROS
    identifiers, the package must be found (not imported) with rosidl's
    generated type support beside it, and only then is ``<package>.msg``
    imported and the class checked for rosidl's attributes.
    """
    parts = ros_type.split("/")
    if len(parts) != 3 or parts[1] != "msg" or not _PACKAGE.match(parts[0]) or not _TYPE.match(parts[2]):
        raise TopicError(f"unsupported type {ros_type!r}: only message types <package>/msg/<Type> are read")
    pkg, _, name = parts
    if not _is_interface_package(pkg):
        raise TopicError(f"unsupported type {ros_type!r}: {pkg} is not an installed ROS message package")
    try:
        cls = getattr(importlib.import_module(f"{pkg}.msg"), name)
    except (ImportError, AttributeError):
        raise TopicError(f"unsupported type {ros_type!r}: {pkg}.msg has no message {name}") from None
    if not (isinstance(cls, type) and hasattr(type(cls), "__import_type_support__")
            and hasattr(cls, "get_fields_and_field_types")):
        raise TopicError(f"unsupported type {ros_type!r}: {pkg}.msg.{name} is not a ROS message class")
    return cls


def _is_interface_package(pkg: str) -> bool:
    """Whether ``pkg`` is a top-level package with rosidl type support and a ``msg`` subpackage.

    Looked up with ``find_spec`` on the top-level name, which imports nothing.
    """
    try:
        spec = importlib.util.find_spec(pkg)
    except (ImportError, ValueError):
        return False
    if spec is None or not spec.submodule_search_locations:
        return False
    for location in spec.submodule_search_locations:
        root = Path(location)
        if (root / "msg" / "__init__.py").is_file() and any(root.glob(f"{pkg}_s__rosidl_typesupport_c*")):
            return True
    return False


def to_plain(msg: Any) -> Any:
    """A message as dicts/lists/floats, for YAML output."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {f: to_plain(getattr(msg, f)) for f in msg.get_fields_and_field_types()}
    if isinstance(msg, bytes | str | int | float | bool) or msg is None:
        return msg
    return [to_plain(v) for v in msg]


class _Probe:
    """One subscription counting and handing messages to a sink."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.node = rclpy.create_node("msd_bench_topic_probe")
        cls, profile = resolve_type(self.node, args.topic, args.timeout)
        self.received = 0
        self.node.create_subscription(cls, args.topic, self._on_msg, profile)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)

    def _on_msg(self, msg: Any) -> None:
        self.received += 1
        self.handle(msg)

    def handle(self, msg: Any) -> None:
        raise NotImplementedError

    def spin(self) -> None:
        """Spin until --count messages (or forever); TopicError if none comes in --timeout."""
        deadline = time.monotonic() + self.args.timeout
        while self.args.count <= 0 or self.received < self.args.count:
            self.executor.spin_once(timeout_sec=0.1)
            if self.received == 0 and time.monotonic() > deadline:
                raise TopicError(f"no message on {self.args.topic} within {self.args.timeout} s")


class _Echo(_Probe):
    def handle(self, msg: Any) -> None:
        sys.stdout.write(yaml.safe_dump(to_plain(msg), sort_keys=False) + "---\n")
        sys.stdout.flush()


class _Hz(_Probe):
    def __init__(self, args: argparse.Namespace) -> None:
        super().__init__(args)
        self.times: deque[float] = deque(maxlen=max(2, args.window + 1))
        self.last_report = time.monotonic()

    def handle(self, _msg: Any) -> None:
        now = time.monotonic()
        self.times.append(now)
        done = self.args.count > 0 and self.received >= self.args.count
        if done or now - self.last_report >= 1.0:
            self.last_report = now
            print(rate_report(list(self.times)), flush=True)


def rate_report(times: Sequence[float]) -> str:
    """``ros2 topic hz``-style line: average rate, min/max/std of the gaps, window."""
    if len(times) < 2:
        return "average rate: n/a (fewer than 2 messages)"
    gaps = [b - a for a, b in itertools.pairwise(times)]
    mean = sum(gaps) / len(gaps)
    std = math.sqrt(sum((g - mean) ** 2 for g in gaps) / len(gaps))
    return (
        f"average rate: {1.0 / mean:.3f}\n\tmin: {min(gaps):.4f}s max: {max(gaps):.4f}s "
        f"std dev: {std:.5f}s window: {len(gaps)}"
    )


def _run(probe_cls: type[_Probe], args: argparse.Namespace) -> int:
    try:
        with ros_session([]):
            probe = probe_cls(args)
            try:
                probe.spin()
            finally:
                probe.node.destroy_node()
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    return 0


def run_echo(args: argparse.Namespace) -> int:
    """Print each message as YAML followed by ``---``."""
    return _run(_Echo, args)


def run_hz(args: argparse.Namespace) -> int:
    """Print the receive rate once a second (and once more at --count)."""
    return _run(_Hz, args)


def main(argv: Sequence[str] | None = None) -> int:
    """Standalone entry point: ``python -m msd_bench.commands.topics echo /msd/position``.

    As :func:`msd_bench.cli.main`: without ``argv`` it is the process's entry
    point and confines the process's DDS first (:func:`msd_bench.dds.confine_process`).
    """
    if argv is None:
        confine_process()
    parser = argparse.ArgumentParser(prog="msd-bench-topics", description=__doc__.splitlines()[0])
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except MsdBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
