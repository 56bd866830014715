"""Reading rosbag2 bags (MCAP): experiments, topics and summaries, with one-line errors.

Works on our bags (written by :mod:`msd_bench.io.bag_writer`, parameters
included) and on any rosbag2 MCAP bag with the contract's topics, e.g. one
recorded with ``ros2 bag record`` on a rig. Every failure — a missing bag or
topic, a wrong type, a truncated or corrupt file — is one :class:`BagError`
line naming the bag and, where relevant, the topic. Writers are re-exported
here so callers have one module to import.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.typesys.store import Typestore

from msd_bench.core.data import Experiment
from msd_bench.core.errors import MsdBenchError
from msd_bench.io import cdr
from msd_bench.io.bag_timing import READ, TimingPolicy, check_timing
from msd_bench.io.bag_writer import (  # noqa: F401  (re-exported: one module for callers)
    PARAMS_KEY,
    PARAMS_RECORD,
    BagRecorder,
    typestore,
    write_experiment,
)
from msd_bench.io.cdr import JointStateRow
from msd_bench.io.errors import BagError
from msd_msgs_py.contract import JOINT_NAME, JOINT_STATES, PLANT_NAMESPACE, TRUTH_JOINT_STATES, TopicSpec

UNCHECKED = TimingPolicy(min_samples=0, rate_tolerance=float("inf"), gap_factor=float("inf"))
"""Timing policy that only refuses stamps going backwards or repeating (closed-loop runs, tests)."""

_READ_ERRORS = (ReaderError, OSError, EOFError, struct.error, KeyError, IndexError, ValueError)


def missing_metadata(path: Path) -> BagError:
    """The one line for a bag directory without ``metadata.yaml`` (a killed recording)."""
    return BagError(
        f"bag {path} has no metadata.yaml: an interrupted recording? "
        f"try `msd-bench bag recover {path}`"
    )


@contextmanager
def _open_bag(path: str | Path) -> Iterator[Reader]:
    """A rosbags reader whose every failure becomes one :class:`BagError` line naming the bag."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"bag {path} does not exist")
    if path.is_dir() and not (path / "metadata.yaml").exists():
        raise missing_metadata(path)
    try:
        with Reader(path) as reader:
            yield reader
    except MsdBenchError:
        raise
    except _READ_ERRORS as exc:
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise BagError(f"bag {path} is truncated or corrupt: {text}") from None


def _deserializer(store: Typestore, conn: Connection) -> Any:
    """Decode function for the connection's type, registering it from the bag if unknown."""
    if conn.msgtype not in store.types:
        from rosbags.typesys import get_types_from_msg

        store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
    return lambda raw: store.deserialize_cdr(raw, conn.msgtype)


def read_topic(path: str | Path, topic: str) -> tuple[np.ndarray, list[Any]]:
    """Log times (ns, int64) and decoded messages of one topic, in bag order."""
    store = typestore()
    stamps: list[int] = []
    msgs: list[Any] = []
    with _open_bag(path) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            raise BagError(f"bag {path} has no topic {topic} (has: {_topic_list(reader)})")
        decode = {c.id: _deserializer(store, c) for c in conns}
        for conn, t_ns, raw in reader.messages(connections=conns):
            stamps.append(t_ns)
            msgs.append(decode[conn.id](raw))
    return np.asarray(stamps, dtype=np.int64), msgs


def _topic_list(reader: Reader) -> str:
    return ", ".join(sorted({c.topic for c in reader.connections})) or "none"


def _custom(reader: Reader) -> dict[str, str]:
    return dict(getattr(reader.storage, "metadata").custom or {})  # noqa: B009 (rosbags attr)


def _params(path: Path, reader: Reader) -> dict[str, Any]:
    text = _custom(reader).get(PARAMS_KEY)
    if text is None:
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        raise BagError(f"bag {path}: custom_data {PARAMS_KEY} is not valid JSON") from None
    return dict(value) if isinstance(value, dict) else {}


def read_experiment(
    path: str | Path, namespace: str = PLANT_NAMESPACE, *, timing: TimingPolicy | None = None
) -> tuple[Experiment, dict[str, Any]]:
    """Force and position from ``<namespace>/joint_states``, in stamp order.

    Works on any rosbag2 MCAP bag with that topic (e.g. ``ros2 bag record`` on a
    rig); the parameters dict is empty when the bag carries none. The header
    stamps, in the order the bag stores them, must pass ``timing`` (default:
    the run's 10 ms, in order, no gaps; see :mod:`.bag_timing`).

    A bag that also holds ``<namespace>/truth/joint_states`` (an emulator with
    a sensor model) gives the experiment its noise-free ``truth``, matched row
    by row on the header stamp; see :func:`_with_truth`.
    """
    path = Path(path)
    topic = JOINT_STATES.resolve(namespace)
    truth_topic = TRUTH_JOINT_STATES.resolve(namespace)
    with _open_bag(path) as reader:
        rows = _rows(path, reader, JOINT_STATES, topic)
        if not rows:
            raise BagError(f"bag {path}: topic {topic} has no messages")
        truth_rows = _rows(path, reader, TRUTH_JOINT_STATES, truth_topic, required=False)
        params = _params(path, reader)
    stamps = np.array([r[0] for r in rows], dtype=np.int64)
    check_timing(path, stamps, READ if timing is None else timing)
    data = np.array([r[1:] for r in rows], dtype=np.float64)
    order = np.argsort(stamps, kind="stable")
    try:
        exp = Experiment(u=data[order, 1], y=data[order, 0], name=str(path))
    except MsdBenchError as exc:
        raise BagError(f"bag {path}: topic {topic}: {exc}") from None
    if truth_rows:
        exp = _with_truth(path, truth_topic, exp, stamps[order], truth_rows)
    return exp, params


def _rows(
    path: Path, reader: Reader, spec: TopicSpec, topic: str, *, required: bool = True
) -> list[tuple[int, float, float]]:
    """(stamp, position, effort) rows of a JointState topic; [] for an absent optional topic."""
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        if not required:
            return []
        raise BagError(f"bag {path} has no topic {topic} (has: {_topic_list(reader)})")
    wrong = [c.msgtype for c in conns if c.msgtype != spec.ros_type]
    if wrong:
        raise BagError(f"bag {path}: topic {topic} has type {wrong[0]}, expected {spec.ros_type}")
    store = typestore()
    return [_sample(path, topic, store, raw) for _, _, raw in reader.messages(connections=conns)]


def _with_truth(
    path: Path, topic: str, exp: Experiment, stamps: np.ndarray, truth_rows: list[tuple[int, float, float]]
) -> Experiment:
    """``exp`` with the truth row of the same header stamp attached to every sample.

    A lock-step bag holds both topics for every sample. A real-time recorder may
    catch one topic a sample before or after the other, so samples without a
    truth row are cut *at the ends only*; a missing truth row inside the record,
    or a truth row whose force differs from the measured row's, is a BagError
    (the two topics would not describe the same run).
    """
    truth = {stamp: (x, effort) for stamp, x, effort in truth_rows}
    has = np.array([int(s) in truth for s in stamps], dtype=bool)
    if not has.any():
        raise BagError(f"bag {path}: topic {topic} shares no header stamp with joint_states")
    first, last = int(np.argmax(has)), int(has.size - np.argmax(has[::-1]))
    if not has[first:last].all():
        k = first + int(np.argmin(has[first:last]))
        raise BagError(f"bag {path}: topic {topic} lacks sample {k} inside the record")
    rows = [truth[int(s)] for s in stamps[first:last]]
    x = np.array([r[0] for r in rows], dtype=np.float64)
    if not np.array_equal([r[1] for r in rows], exp.u[first:last]):
        raise BagError(f"bag {path}: topic {topic} has another force than joint_states")
    try:
        return Experiment(exp.u[first:last], exp.y[first:last], exp.name, truth=x)
    except MsdBenchError as exc:
        raise BagError(f"bag {path}: topic {topic}: {exc}") from None


def decode_joint_state(store: Typestore, raw: bytes) -> JointStateRow:
    """One serialized JointState's stamp, names and arrays: read directly (:mod:`.cdr`), or by rosbags
    for anything that reader declines (rosbags' error then says what is wrong)."""
    row = cdr.joint_state(raw)
    if row is not None:
        return row
    msg: Any = store.deserialize_cdr(raw, JOINT_STATES.ros_type)
    return JointStateRow(int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec), list(msg.name),
                         tuple(msg.position), tuple(msg.velocity), tuple(msg.effort))


def _sample(path: Path, topic: str, store: Typestore, raw: bytes) -> tuple[int, float, float]:
    """(stamp ns, position, effort) of the slider joint in one JointState."""
    msg = decode_joint_state(store, raw)
    idx = msg.name.index(JOINT_NAME) if JOINT_NAME in msg.name else 0
    if len(msg.position) <= idx or len(msg.effort) <= idx:
        raise BagError(f"bag {path}: topic {topic}: a message lacks position or effort")
    return msg.stamp_ns, float(msg.position[idx]), float(msg.effort[idx])


@dataclass(frozen=True)
class BagInfo:
    """What ``msd-bench bag info`` shows."""

    path: Path
    """The bag directory."""
    topics: dict[str, tuple[str, int]]
    """Topic -> (ROS type, message count)."""
    duration_s: float
    """Time between first and last message log time."""
    params: dict[str, Any]
    """Stored experiment parameters (empty when none)."""


def bag_info(path: str | Path) -> BagInfo:
    """Topics, counts, duration and stored parameters of a bag."""
    path = Path(path)
    with _open_bag(path) as reader:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        duration = max(reader.duration - 1, 0) / 1e9 if reader.message_count else 0.0
        return BagInfo(path, topics, duration, _params(path, reader))
