"""Writing rosbag2 bags in MCAP storage: whole experiments and streamed recordings.

Why this shape: rosbags' ``Writer`` owns the rosbag2 side (connections,
``metadata.yaml``, counts), and its storage plugin is swapped for
:class:`_FlushingMcapStorage`, which writes the MCAP file with the ``mcap``
library: every chunk carries a CRC (so corruption is detected, rosbags' own
MCAP writer writes CRC 0), and the open chunk is flushed to disk at least
once per ``flush_period_s`` (rosbags keeps up to 1 MiB in memory, minutes of
100 Hz telemetry). A SIGKILLed recording therefore loses at most about one
flush period; :mod:`msd_bench.io.bags.bag_recover` turns it back into a bag.

What a rosbag2 user expects of the metadata is filled in as rosbag2 writes it:
each topic's ``offered_qos_profiles`` (the publishers' real profiles when a
recorder saw them in the graph, the contract's profile for bags written
offline, :func:`contract_qos`) in ``metadata.yaml`` and in the MCAP channel;
the channel's ``topic_type_hash`` (RIHS01, the same hash the running rclpy
reports for the type, computed by rosbags from the type description); and
``ros_distro``, the distribution actually installed (:func:`ros_distro`)
instead of rosbags' placeholder ``rosbags``.

Experiment parameters are stored twice from the same JSON string: as an MCAP
metadata record ``msd_bench`` (``params`` key) written when the bag opens, so
it survives a kill and ``mcap``'s ``iter_metadata()`` sees it; and as
rosbag2 ``custom_data`` key ``msd_bench.params`` in ``metadata.yaml``, which
rosbags readers see.

A write error (disk full, storage gone read-only) never leaves a half bag:
the file is cut back to the end of the last chunk that reached the disk whole
(:class:`_Sink` knows that offset), the summary and ``metadata.yaml`` are
written for exactly those messages, and :class:`BagWriteError` says how much
was kept. A reserve file (:data:`RESERVE_BYTES`) allocated when the bag
opens is deleted first, so the summary and ``metadata.yaml`` find space on a
full disk.
"""

from __future__ import annotations

import copy
import importlib.metadata
import json
import os
import re
import shutil
import stat
import struct
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType, TracebackType
from typing import IO, Any, cast

import numpy as np
from mcap.writer import CompressionType
from mcap.writer import Writer as _McapLibWriter
from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.rosbag2.enums import CompressionMode
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from msd_bench.io.bags.bag_error import BagError
from msd_msgs_py.contract import (
    CLOCK,
    FORCE,
    HEADER_TYPE,
    JOINT_NAME,
    JOINT_STATES,
    MULTI_ARRAY_LAYOUT_TYPE,
    PLANT_NAMESPACE,
    POSITION,
    REFERENCE,
    TIME_TYPE,
    TopicSpec,
)
from msd_msgs_py.interface import COMMANDS_TYPE, PlantInterface

PARAMS_KEY = "msd_bench.params"
"""rosbag2 ``custom_data`` key holding the experiment parameters as JSON."""
RESERVE_BYTES = 256 * 1024
"""Space held back while recording so a full disk can still take the bag's summary (about
100 bytes per chunk: 40 minutes of one-second chunks) and ``metadata.yaml``."""
RESERVE_NAME = ".msd_bench_reserve"
"""The reserve file inside the bag directory (gone once the bag is closed)."""
PARAMS_RECORD = "msd_bench"
"""Name of the MCAP metadata record holding the parameters (``params`` key)."""


INFINITE = QosTime(9_223_372_036, 854_775_807)
"""``RMW_DURATION_INFINITE`` as rosbag2 writes it (sec, nsec): no deadline, lifespan or lease."""

RCLPY_DISTROS = {3: "humble", 4: "iron", 7: "jazzy", 9: "kilted"}
"""ROS 2 distribution of each rclpy major version (the PyPI wheels carry no ROS_DISTRO)."""


def ros_distro() -> str:
    """The ROS 2 distribution actually running: ``ROS_DISTRO`` if set, else the installed rclpy's.

    A sourced ROS install sets ``ROS_DISTRO``; the pip-installed rclpy wheels
    do not, so its major version names the distribution. ``unknown`` when
    neither says (bag tooling also runs without ROS).
    """
    env = os.environ.get("ROS_DISTRO", "").strip()
    if env:
        return env
    try:
        major = int(importlib.metadata.version("ros-rclpy").split(".")[0])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return "unknown"
    return RCLPY_DISTROS.get(major, "unknown")


def contract_qos(spec: TopicSpec) -> Qos:
    """The profile a plant-like node offers on ``spec`` (``msd_msgs_py.ros.qos``), in rosbags' terms."""
    return Qos(QosHistory.KEEP_LAST, spec.depth, QosReliability.RELIABLE,
               QosDurability.TRANSIENT_LOCAL if spec.latched else QosDurability.VOLATILE,
               INFINITE, INFINITE, QosLiveliness.AUTOMATIC, INFINITE, False)


def _with_distro(metadata_text: str) -> str:
    """rosbags writes ``ros_distro: rosbags``; put the real distribution in its place."""
    return re.sub(r"^(\s*ros_distro:) rosbags$", lambda m: f"{m.group(1)} {ros_distro()}",
                  metadata_text, count=1, flags=re.MULTILINE)


STAMPED_TYPES = frozenset({JOINT_STATES.ros_type, CLOCK.ros_type})
"""Types whose CDR body starts with a ``builtin_interfaces/Time`` (a header stamp, or /clock's time)."""


def leading_stamp(ros_type: str, data: bytes | memoryview) -> int | None:
    """The time (ns) a stamped message carries, read from its CDR bytes; None for other types.

    Why not deserialize: the recorder writes raw bytes at 100 Hz and only needs
    8 of them. The time is the first field after the 4-byte encapsulation
    header (``int32 sec, uint32 nanosec``), little- or big-endian as it says.
    """
    if ros_type not in STAMPED_TYPES or len(data) < 12:
        return None
    raw = bytes(data[:12])
    sec, nanosec = struct.unpack_from("<iI" if raw[1] & 1 else ">iI", raw, 4)
    return int(sec) * 1_000_000_000 + int(nanosec)


def typestore() -> Typestore:
    """Message definitions of the newest ROS 2 distribution rosbags knows (Kilted here)."""
    return get_typestore(Stores.ROS2_KILTED)


class BagWriteError(BagError):
    """The storage refused a write; the bag was closed with what reached the disk whole."""

    def __init__(self, message: str, kept: int, dropped: int) -> None:
        super().__init__(message)
        self.kept = kept
        """Messages in the closed bag."""
        self.dropped = dropped
        """Messages received but not stored (the partial chunk and everything after)."""


class _Sink:
    """Unbuffered append-only file: a short write raises, and the offset written so far is exact.

    Why not a buffered file: after ENOSPC a ``BufferedWriter`` holds bytes it
    will retry on close, and its ``tell()`` counts bytes that never reached the
    disk, so the end of the last whole chunk would be unknown.
    """

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        self._pos = 0

    def write(self, data: bytes | memoryview) -> int:
        view = memoryview(data)
        while view.nbytes:
            n = os.write(self._fd, view)
            self._pos += n
            view = view[n:]
        return len(data)

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here (mcap calls it)."""

    def cut(self, offset: int) -> None:
        """Drop everything after ``offset`` (frees the space of a partial chunk)."""
        os.ftruncate(self._fd, offset)
        os.lseek(self._fd, offset, os.SEEK_SET)
        self._pos = offset

    def close(self) -> None:
        if self._fd >= 0:
            fd, self._fd = self._fd, -1
            os.close(fd)


class _Checkpoint:
    """The state of the file after the last chunk that reached the disk whole."""

    def __init__(self, offset: int, lengths: dict[str, int], stats: object, counts: dict[int, int]) -> None:
        self.offset, self.lengths, self.stats, self.counts = offset, lengths, stats, counts


_INDEX_LISTS = ("chunk_indices", "metadata_indexes", "summary_offsets")
"""mcap Writer lists that grow as records are written; cut back to their checkpoint lengths."""


class _FlushingMcapStorage:
    """rosbags ``StorageWriter`` on the ``mcap`` library: CRC'd chunks, flushed on a timer."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        if compression != CompressionMode.NONE:
            raise WriterError("compression is not supported by the msd_bench bag writer")
        self.path = path / f"{path.name}.mcap"
        self.flush_period_s = 1.0
        self._reserve = path / RESERVE_NAME
        with self._reserve.open("xb") as fh:
            os.posix_fallocate(fh.fileno(), 0, RESERVE_BYTES)
        self._file = _Sink(self.path)
        self._mcap = _McapLibWriter(cast(IO[bytes], self._file), compression=CompressionType.NONE)
        self._mcap.start(profile="ros2", library="msd_bench (mcap + rosbags)")
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, int] = {}
        self._counts: dict[int, int] = {}
        self._last_flush = time.monotonic()
        self.checkpoint = self._snapshot()

    def add_msgtype(self, connection: Connection) -> None:
        encoding = "ros2idl" if connection.msgdef.data.startswith("=" * 80) else "ros2msg"
        data = connection.msgdef.data.encode()
        self._schemas[connection.msgtype] = self._mcap.register_schema(
            connection.msgtype, encoding, data
        )

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        self._channels[connection.id] = self._mcap.register_channel(
            connection.topic,
            "cdr",
            self._schemas[connection.msgtype],
            # rosbag2's MCAP plugin stores both; its reader takes the type hash from here.
            {"offered_qos_profiles": offered_qos_profiles, "topic_type_hash": connection.digest},
        )
        self._counts[connection.id] = 0

    def add_params(self, params_json: str) -> None:
        """Write the parameters record now, so a killed recording keeps it."""
        self._mcap.add_metadata(PARAMS_RECORD, {"params": params_json})
        self._file.flush()

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        self._mcap.add_message(self._channels[connection.id], timestamp, bytes(data), timestamp)
        self._counts[connection.id] += 1
        self.flush_if_due()

    def flush_if_due(self) -> None:
        """Push the open chunk to the file once per flush period (bounds what a kill loses)."""
        if time.monotonic() - self._last_flush >= self.flush_period_s:
            self.flush()

    def flush(self) -> None:
        """End the open chunk and hand it to the OS (survives SIGKILL, not a power cut)."""
        self._mcap.flush()
        self._last_flush = time.monotonic()
        self.checkpoint = self._snapshot()

    def _mcap_private(self, name: str) -> Any:
        """A private field of ``mcap.writer.Writer`` (pinned by the write-error tests)."""
        return getattr(self._mcap, f"_Writer__{name}")

    def _snapshot(self) -> _Checkpoint:
        lengths = {name: len(self._mcap_private(name)) for name in _INDEX_LISTS}
        return _Checkpoint(self._file.tell(), lengths,
                           copy.deepcopy(self._mcap_private("statistics")), dict(self._counts))

    def rollback(self) -> dict[int, int]:
        """Forget everything after the checkpoint; returns the messages per connection kept."""
        cp = self.checkpoint
        self.release_reserve()
        self._file.cut(cp.offset)
        for name, length in cp.lengths.items():
            del self._mcap_private(name)[length:]
        setattr(self._mcap, "_Writer__statistics", copy.deepcopy(cp.stats))  # noqa: B010
        builder = self._mcap_private("chunk_builder")
        if builder is not None:
            builder.reset()
        self._counts = dict(cp.counts)
        return dict(cp.counts)

    def release_reserve(self) -> None:
        """Give the reserved space back (before the summary, or on a write error)."""
        self._reserve.unlink(missing_ok=True)

    def close(self, version: int, metadata: str) -> None:
        _ = version
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": _with_distro(metadata)})
        self._mcap.finish()
        self._file.close()
        self.release_reserve()

    def abort(self) -> None:
        self._file.close()
        self.release_reserve()


class _BagWriter(Writer):
    """rosbags' rosbag2 writer with the MCAP storage replaced by :class:`_FlushingMcapStorage`."""

    STORAGE_PLUGINS = MappingProxyType({StoragePlugin.MCAP: _FlushingMcapStorage})

    def close(self) -> None:
        """rosbags' close, then ``ros_distro`` corrected in ``metadata.yaml`` (atomically, like rosbags)."""
        super().close()
        text = self.metapath.read_text("utf8")
        fixed = _with_distro(text)
        if fixed != text:
            tmp = self.metapath.with_suffix(".yaml.tmp")
            tmp.write_text(fixed, "utf8")
            tmp.replace(self.metapath)


def _why(exc: OSError | WriterError) -> str:
    """The reason of an OS error without its path (the message names the bag already)."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return " ".join(str(exc).split()) or type(exc).__name__


def _prepare_target(path: Path, overwrite: bool) -> None:
    """Refuse an existing bag unless ``overwrite``; then remove only a bag wholly of our making.

    Why so strict: ``--overwrite`` names a bag, not a directory. A directory is
    removed only if it holds exactly what a rosbag2 bag holds — ``metadata.yaml``
    and the MCAP files it lists — so a ``thesis.tex`` beside them (or a symlink,
    a subdirectory, an unlisted file) refuses the overwrite and names the file.
    """
    names = check_target(path, overwrite)
    for name in names:
        (path / name).unlink()
    if names:
        path.rmdir()


def check_target(path: Path, overwrite: bool) -> list[str]:
    """What :func:`_prepare_target` would remove (nothing for a new path), or its one-line refusal."""
    if not os.path.lexists(path):
        return []
    if not overwrite:
        raise BagError(f"bag {path} exists already, not overwriting (pass overwrite=True)")
    return own_bag_files(path)


def own_bag_files(path: Path) -> list[str]:
    """The files of the bag at ``path`` if it holds nothing else; a one-line :class:`BagError` otherwise."""
    if path.is_symlink() or not path.is_dir():
        raise BagError(f"{path} exists and is not a bag directory: refusing to delete it")
    meta = path / "metadata.yaml"
    if meta.is_symlink() or not meta.is_file():
        raise BagError(f"{path} exists and is not a bag (no metadata.yaml): refusing to delete it")
    listed = _listed_files(meta)
    files = ["metadata.yaml", *listed]
    for entry in sorted(os.listdir(path)):
        if entry not in files or not stat.S_ISREG(os.lstat(path / entry).st_mode):
            raise BagError(f"{path} holds {entry!r}, which is not part of the bag: refusing to delete it")
    return [f for f in files if (path / f).exists()]


def _listed_files(meta: Path) -> list[str]:
    """The plain file names ``metadata.yaml`` lists as the bag's storage files."""
    import yaml

    try:
        info = yaml.safe_load(meta.read_bytes()[:1 << 20])["rosbag2_bagfile_information"]
        names = [str(n) for n in info["relative_file_paths"]]
    except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
        raise BagError(f"{meta}: unreadable ({type(exc).__name__}): not deleting the directory") from None
    for n in names:
        if n in ("", ".", "..", "metadata.yaml") or "/" in n or not n.endswith(".mcap"):
            raise BagError(f"{meta} lists {n!r}, not a file of an MCAP bag: not deleting the directory")
    return names


class BagRecorder:
    """Streams serialized (CDR) messages into one bag; always leaves a complete bag on close.

    Use as a context manager (the bag is closed in ``finally``, also on
    KeyboardInterrupt). Between closes, at most ``flush_period_s`` of data is
    only in memory; call :meth:`flush_if_due` from a timer when messages may stop.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        params: Mapping[str, Any] | None = None,
        flush_period_s: float = 1.0,
        overwrite: bool = False,
        store: Typestore | None = None,
    ) -> None:
        self.path = Path(path)
        self._params = json.dumps(dict(params or {}), sort_keys=True)
        self._flush_period_s = float(flush_period_s)
        self._overwrite = overwrite
        self._writer: _BagWriter | None = None
        self._connections: dict[tuple[str, str], Connection] = {}
        self._store = store or typestore()
        """Message definitions written into the bag (pass one with extra types registered)."""
        self.message_count = 0

    def open(self) -> BagRecorder:
        """Create the bag directory and the MCAP file (fails if the bag exists)."""
        _prepare_target(self.path, self._overwrite)
        writer = _BagWriter(self.path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
        try:
            writer.open()
            storage = writer.storage
            assert isinstance(storage, _FlushingMcapStorage)
            storage.flush_period_s = self._flush_period_s
            storage.add_params(self._params)
        except (WriterError, OSError) as exc:
            if writer.storage is not None:
                writer.storage.abort()
            shutil.rmtree(self.path, ignore_errors=True)  # did not exist before (_prepare_target)
            raise BagError(f"bag {self.path}: cannot create ({_why(exc)})") from None
        writer.set_custom_data(PARAMS_KEY, self._params)
        self._writer = writer
        return self

    def write(self, topic: str, ros_type: str, t_ns: int, data: bytes | memoryview,
              offered_qos: Sequence[Qos] = ()) -> None:
        """Append one CDR-serialized message logged at ``t_ns``.

        ``offered_qos`` (the publishers' profiles) is stored with the topic when
        its first message is written, and ignored after that.
        """
        if self._writer is None:
            raise BagError(f"bag {self.path}: write on a recorder that is not open")
        try:
            conn = self._connections.get((topic, ros_type))
            if conn is None:
                conn = self._writer.add_connection(topic, ros_type, typestore=self._store,
                                                   offered_qos_profiles=list(offered_qos))
                self._connections[(topic, ros_type)] = conn
            self._writer.write(conn, int(t_ns), data)
        except OSError as exc:
            raise self._close_after(exc, received=self.message_count + 1) from None
        self.message_count += 1

    def flush_if_due(self) -> None:
        """Flush the open chunk if the flush period elapsed (call from a timer when idle)."""
        self._guarded(lambda s: s.flush_if_due())

    def flush(self) -> None:
        """End the open chunk now (a chunk boundary, e.g. between experiment phases)."""
        self._guarded(lambda s: s.flush())

    def _guarded(self, action: Any) -> None:
        if self._writer is not None and isinstance(self._writer.storage, _FlushingMcapStorage):
            try:
                action(self._writer.storage)
            except OSError as exc:
                raise self._close_after(exc, received=self.message_count) from None

    def _close_after(self, exc: OSError, received: int) -> BagWriteError:
        """Cut the bag back to its last whole chunk, close it, and describe what was kept."""
        writer, self._writer = self._writer, None
        assert writer is not None
        storage = writer.storage
        if not isinstance(storage, _FlushingMcapStorage):  # the MCAP is complete, metadata.yaml failed
            return BagWriteError(
                f"bag {self.path}: writing metadata.yaml failed ({_why(exc)}); the MCAP file is complete: "
                f"free space, then `msd-bench bag recover {self.path}`", received, 0)
        counts = storage.rollback()
        writer.counts.update(counts)
        kept = sum(counts.values())
        where = f"bag {self.path}: write failed ({_why(exc)})"
        try:
            writer.close()
        except OSError as exc2:
            storage.abort()
            return BagWriteError(
                f"{where}; could not close the bag either ({_why(exc2)}): {kept} of {received} messages "
                f"are on disk; free space, then `msd-bench bag recover {self.path}`", kept, received - kept)
        return BagWriteError(f"{where}; closed the bag with the {kept} of {received} messages "
                             f"that reached the disk whole", kept, received - kept)

    def close(self) -> None:
        """Finish the MCAP summary and write ``metadata.yaml``; idempotent."""
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.close()
            except OSError as exc:
                self._writer = writer
                raise self._close_after(exc, received=self.message_count) from None

    def __enter__(self) -> BagRecorder:
        return self.open()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _header(types: Mapping[str, Any], ns: int) -> Any:
    """A ``std_msgs/Header`` stamped ``ns`` in rosbags' classes (types named by the contract)."""
    return types[HEADER_TYPE](stamp=types[TIME_TYPE](sec=ns // 10**9, nanosec=ns % 10**9), frame_id="")


def write_experiment(
    path: str | Path,
    t_ns: np.ndarray,
    u: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    *,
    params: Mapping[str, Any],
    namespace: str = PLANT_NAMESPACE,
    overwrite: bool = False,
    reference: float | None = None,
) -> Path:
    """Write one experiment as the plant would publish it: joint_states, position, force.

    ``u[k]`` is the force applied over the sample after ``t_ns[k]`` (the
    ``effort`` of the same JointState), so identification gets exact alignment.
    A closed-loop run also gets its set-point: one ``reference`` message at ``t_ns[0]``.
    """
    t_ns, u, x, v = (np.asarray(a).ravel() for a in (t_ns, u, x, v))
    if not (t_ns.size == u.size == x.size == v.size):
        raise BagError(f"bag {path}: t, u, x, v lengths differ ({t_ns.size}, {u.size}, {x.size}, {v.size})")
    store = typestore()
    types = store.types
    state_t, f64_t = JOINT_STATES.ros_type, POSITION.ros_type
    topics = (JOINT_STATES.resolve(namespace), POSITION.resolve(namespace), FORCE.resolve(namespace))
    qos = {spec: [contract_qos(spec)] for spec in (JOINT_STATES, POSITION, FORCE, REFERENCE)}
    with BagRecorder(path, params=params, overwrite=overwrite) as rec:
        if reference is not None and t_ns.size:
            ref = store.serialize_cdr(types[f64_t](data=float(reference)), f64_t)
            rec.write(REFERENCE.resolve(namespace), REFERENCE.ros_type, int(t_ns[0]), ref, qos[REFERENCE])
        for k in range(t_ns.size):
            ns = int(t_ns[k])
            state = types[state_t](
                header=_header(types, ns),
                name=[JOINT_NAME],
                position=np.array([x[k]], dtype=np.float64),
                velocity=np.array([v[k]], dtype=np.float64),
                effort=np.array([u[k]], dtype=np.float64),
            )
            rec.write(topics[0], state_t, ns, store.serialize_cdr(state, state_t), qos[JOINT_STATES])
            rec.write(topics[1], f64_t, ns, store.serialize_cdr(types[f64_t](data=float(x[k])), f64_t),
                      qos[POSITION])
            rec.write(topics[2], f64_t, ns, store.serialize_cdr(types[f64_t](data=float(u[k])), f64_t),
                      qos[FORCE])
    return Path(path)


def write_interface_experiment(
    path: str | Path,
    t_ns: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    effort: np.ndarray,
    *,
    iface: PlantInterface,
    command_ns: np.ndarray,
    command_u: np.ndarray,
    params: Mapping[str, Any],
    namespace: str = PLANT_NAMESPACE,
    other_joints: Sequence[str] = (),
    state_log_ns: np.ndarray | None = None,
    overwrite: bool = False,
) -> Path:
    """Write a recording as a rig with interface ``iface`` shows it: joint_states plus its commands.

    ``joint_states`` row k (stamp ``t_ns[k]``, logged at ``state_log_ns[k]``,
    default the stamp) lists ``other_joints`` first (position 0, velocity 0,
    effort 0) and our joint last, with ``effort[k]`` as the rig reports it.
    Command j asks for ``command_u[j]`` on our joint and is logged at
    ``command_ns[j]``: a ``Float64MultiArray`` in the controller's joint order
    (other joints 0.0) on ros2_control, a ``Float64`` on ``force`` for msd.
    There is no ``position`` topic: that is what a ros2_control rig offers.
    """
    t_ns, x, v, effort = (np.asarray(a).ravel() for a in (t_ns, x, v, effort))
    logs = t_ns if state_log_ns is None else np.asarray(state_log_ns).ravel()
    command_ns, command_u = np.asarray(command_ns).ravel(), np.asarray(command_u).ravel()
    if not (t_ns.size == x.size == v.size == effort.size == logs.size) or command_ns.size != command_u.size:
        raise BagError(f"bag {path}: state arrays or command arrays differ in length")
    store = typestore()
    types = store.types
    state_t, cmd = JOINT_STATES.ros_type, iface.command
    names = [*other_joints, iface.joint]
    pad = [0.0] * len(other_joints)
    msgs: list[tuple[int, str, str, bytes | memoryview, TopicSpec]] = []
    for k in range(t_ns.size):
        ns = int(t_ns[k])
        state = types[state_t](
            header=_header(types, ns),
            name=names,
            position=np.array([*pad, x[k]], dtype=np.float64),
            velocity=np.array([*pad, v[k]], dtype=np.float64),
            effort=np.array([*pad, effort[k]], dtype=np.float64),
        )
        msgs.append((int(logs[k]), iface.state.resolve(namespace), state_t,
                     store.serialize_cdr(state, state_t), iface.state))
    for j in range(command_ns.size):
        values = iface.command_values(float(command_u[j]))
        if cmd.ros_type == COMMANDS_TYPE:
            layout = types[MULTI_ARRAY_LAYOUT_TYPE](dim=[], data_offset=0)
            body = types[COMMANDS_TYPE](layout=layout, data=np.array(values, dtype=np.float64))
        else:
            body = types[cmd.ros_type](data=values[0])
        msgs.append((int(command_ns[j]), cmd.resolve(namespace), cmd.ros_type,
                     store.serialize_cdr(body, cmd.ros_type), cmd))
    msgs.sort(key=lambda m: m[0])  # a bag is written in log-time order
    with BagRecorder(path, params=params, overwrite=overwrite) as rec:
        for log_ns, topic, ros_type, data, spec in msgs:
            rec.write(topic, ros_type, log_ns, data, [contract_qos(spec)])
    return Path(path)
