"""Reading rosbag2 bags (MCAP): experiments, topics and summaries, with one-line errors.

Works on our bags (written by :mod:`msd_bench.io.bags.bag_writer`, parameters
included) and on any rosbag2 MCAP bag with the contract's topics, e.g. one
recorded with ``ros2 bag record`` on a rig. Every failure — a missing bag or
topic, a wrong type, a truncated or corrupt file — is one :class:`BagError`
line naming the bag and, where relevant, the topic. Bags are opened by
:func:`msd_bench.io.bags.bag_open.open_bag`, which checks the path and
``metadata.yaml`` and bounds what an MCAP file's lengths may allocate. Writers
are re-exported here so callers have one module to import.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader
from rosbags.typesys.store import Typestore

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.identification.data import Experiment
from msd_bench.io.bags import cdr
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_meta import params_from_custom, shown
from msd_bench.io.bags.bag_open import READ_ERRORS, open_bag
from msd_bench.io.bags.bag_open import missing_metadata as missing_metadata
from msd_bench.io.bags.bag_timing import READ, TimingPolicy, check_timing
from msd_bench.io.bags.bag_writer import (  # noqa: F401  (re-exported: one module for callers)
    PARAMS_KEY,
    PARAMS_RECORD,
    BagRecorder,
    typestore,
    write_experiment,
)
from msd_bench.io.bags.cdr import JointStateRow
from msd_msgs_py.contract import JOINT_NAME, JOINT_STATES, PLANT_NAMESPACE, TRUTH_JOINT_STATES, TopicSpec

UNCHECKED = TimingPolicy(min_samples=0, rate_tolerance=float("inf"), gap_factor=float("inf"))
"""Timing policy that only refuses stamps going backwards or repeating (closed-loop runs, tests)."""

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
    with open_bag(path) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            raise BagError(f"bag {path} has no topic {topic} (has: {_topic_list(reader)})")
        decode = {c.id: _deserializer(store, c) for c in conns}
        for conn, t_ns, raw in reader.messages(connections=conns):
            stamps.append(t_ns)
            msgs.append(decode[conn.id](raw))
    return np.asarray(stamps, dtype=np.int64), msgs


def _topic_list(reader: Reader) -> str:
    return ", ".join(sorted({shown(c.topic) for c in reader.connections})) or "none"


def _params(path: Path, reader: Reader) -> dict[str, Any]:
    """The experiment parameters in the bag's ``custom_data``, bounded and checked (:mod:`.bag_meta`)."""
    return params_from_custom(path, getattr(reader.storage, "metadata").custom)  # noqa: B009 (rosbags attr)


@dataclass(frozen=True)
class SliderRows:
    """The slider joint's header stamps (ns), positions and efforts in a JointState topic, in bag order."""

    stamps: np.ndarray
    x: np.ndarray
    effort: np.ndarray

    def __len__(self) -> int:
        return int(self.stamps.size)


_NO_ROWS = SliderRows(np.empty(0, dtype=np.int64), np.empty(0), np.empty(0))


@dataclass(frozen=True)
class BagSamples:
    """What :func:`read_experiment` reads from a bag, before any check of its stamps.

    Why kept: the identifier reads each bag for its parameters (which bags are
    there, and for what) and then identifies from it, each with its own timing
    policy; holding these rows lets the second use skip reading and decoding
    the bag again (:attr:`msd_bench.io.bags.bag_records.BagRole.samples`).
    """

    path: Path
    """The bag read."""
    namespace: str
    """The namespace whose ``joint_states`` (and truth) topic was read."""
    rows: SliderRows
    """``<namespace>/joint_states`` (never empty)."""
    truth: SliderRows
    """``<namespace>/truth/joint_states``; empty when the bag has no such topic."""
    params: dict[str, Any]
    """Stored experiment parameters (empty when none)."""

    def experiment(self, timing: TimingPolicy | None = None) -> tuple[Experiment, dict[str, Any]]:
        """The experiment and a copy of the parameters, as :func:`read_experiment` returns them."""
        check_timing(self.path, self.rows.stamps, READ if timing is None else timing)
        order = np.argsort(self.rows.stamps, kind="stable")
        try:
            exp = Experiment(u=self.rows.effort[order], y=self.rows.x[order], name=str(self.path))
        except MsdBenchError as exc:
            topic = JOINT_STATES.resolve(self.namespace)
            raise BagError(f"bag {self.path}: topic {topic}: {exc}") from None
        if len(self.truth):
            truth_topic = TRUTH_JOINT_STATES.resolve(self.namespace)
            exp = _with_truth(self.path, truth_topic, exp, self.rows.stamps[order], self.truth)
        return exp, copy.deepcopy(self.params)


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
    return read_samples(path, namespace).experiment(timing)


def read_samples(path: str | Path, namespace: str = PLANT_NAMESPACE) -> BagSamples:
    """The bag's rows and parameters, read once; :meth:`BagSamples.experiment` checks and orders them."""
    path = Path(path)
    topic = JOINT_STATES.resolve(namespace)
    truth_topic = TRUTH_JOINT_STATES.resolve(namespace)
    with open_bag(path) as reader:
        rows = _rows(path, reader, JOINT_STATES, topic)
        if not len(rows):
            raise BagError(f"bag {path}: topic {topic} has no messages")
        truth = _rows(path, reader, TRUTH_JOINT_STATES, truth_topic, required=False)
        params = _params(path, reader)
    return BagSamples(path, namespace, rows, truth, params)


def _rows(path: Path, reader: Reader, spec: TopicSpec, topic: str, *, required: bool = True) -> SliderRows:
    """The slider's rows of a JointState topic; empty for an absent optional topic."""
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        if not required:
            return _NO_ROWS
        raise BagError(f"bag {path} has no topic {topic} (has: {_topic_list(reader)})")
    wrong = [c.msgtype for c in conns if c.msgtype != spec.ros_type]
    if wrong:
        raise BagError(f"bag {path}: topic {topic} has type {shown(wrong[0])}, expected {spec.ros_type}")
    raws, failure = _raw_messages(reader, conns)
    rows = _columns_rows(raws) if failure is None else None
    if rows is None:
        rows = _message_rows(path, topic, typestore(), raws)
    if failure is not None:
        raise failure
    return rows


def _raw_messages(reader: Reader, conns: list[Connection]) -> tuple[list[bytes], Exception | None]:
    """Every message's bytes in bag order, and the read error that cut them short, if any.

    Why the error is returned, not raised: messages used to be decoded while
    the bag was read, so a bad message before a corrupt chunk was the error
    reported. The caller decodes what was read before raising the read error,
    which keeps that.
    """
    raws: list[bytes] = []
    try:
        for _, _, raw in reader.messages(connections=conns):
            raws.append(raw)
    except READ_ERRORS as exc:  # raised again by the caller, unchanged
        return raws, exc
    return raws, None


def _columns_rows(raws: list[bytes]) -> SliderRows | None:
    """All rows at once when the messages share one one-joint layout (:func:`cdr.joint_state_columns`).

    None when they do not, or when a message lacks position or effort: the
    per-message reader then gives the rows, or the error, as it always did.
    """
    cols = cdr.joint_state_columns(raws)
    if cols is None or cols.position.shape[1] != 1 or cols.effort.shape[1] != 1:
        return None
    return SliderRows(cols.stamp_ns, cols.position[:, 0], cols.effort[:, 0])


def _message_rows(path: Path, topic: str, store: Typestore, raws: list[bytes]) -> SliderRows:
    """The rows decoded one message at a time: any layout, several joints, rosbags for the rest."""
    samples = [_sample(path, topic, store, raw) for raw in raws]
    return SliderRows(np.array([s[0] for s in samples], dtype=np.int64),
                      np.array([s[1] for s in samples], dtype=np.float64),
                      np.array([s[2] for s in samples], dtype=np.float64))


def _with_truth(
    path: Path, topic: str, exp: Experiment, stamps: np.ndarray, truth_rows: SliderRows
) -> Experiment:
    """``exp`` with the truth row of the same header stamp attached to every sample.

    A lock-step bag holds both topics for every sample. A real-time recorder may
    catch one topic a sample before or after the other, so samples without a
    truth row are cut *at the ends only*; a missing truth row inside the record,
    or a truth row whose force differs from the measured row's, is a BagError
    (the two topics would not describe the same run).
    """
    truth = dict(zip(truth_rows.stamps.tolist(), zip(truth_rows.x.tolist(), truth_rows.effort.tolist(),
                                                     strict=True), strict=True))
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
    storage: str = "mcap"
    """``mcap`` or ``sqlite3``: only MCAP bags have chunk CRCs for ``bag info`` to check."""


def bag_info(path: str | Path) -> BagInfo:
    """Topics, counts, duration, stored parameters and storage of a bag."""
    path = Path(path)
    with open_bag(path) as reader:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        duration = max(reader.duration - 1, 0) / 1e9 if reader.message_count else 0.0
        storage = "sqlite3" if isinstance(reader.storage, Sqlite3Reader) or any(
            isinstance(s, Sqlite3Reader) for s in getattr(reader.storage, "storages", ())) else "mcap"
        return BagInfo(path, topics, duration, _params(path, reader), storage)
