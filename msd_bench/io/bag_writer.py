"""Writing rosbag2 bags in MCAP storage: whole experiments and streamed recordings.

Why this shape: rosbags' ``Writer`` owns the rosbag2 side (connections,
``metadata.yaml``, counts), and its storage plugin is swapped for
:class:`_FlushingMcapStorage`, which writes the MCAP file with the ``mcap``
library: every chunk carries a CRC (so corruption is detected, rosbags' own
MCAP writer writes CRC 0), and the open chunk is flushed to disk at least
once per ``flush_period_s`` (rosbags keeps up to 1 MiB in memory, minutes of
100 Hz telemetry). A SIGKILLed recording therefore loses at most about one
flush period; :mod:`msd_bench.io.bag_recover` turns it back into a bag.

Experiment parameters are stored twice from the same JSON string: as an MCAP
metadata record ``msd_bench`` (``params`` key) written when the bag opens, so
it survives a kill and ``mcap``'s ``iter_metadata()`` sees it; and as
rosbag2 ``custom_data`` key ``msd_bench.params`` in ``metadata.yaml``, which
rosbags readers see.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Mapping
from pathlib import Path
from types import MappingProxyType, TracebackType
from typing import Any

import numpy as np
from mcap.writer import CompressionType
from mcap.writer import Writer as _McapLibWriter
from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.rosbag2.enums import CompressionMode
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from msd_bench.io.errors import BagError
from msd_msgs_py.contract import FORCE, JOINT_NAME, JOINT_STATES, PLANT_NAMESPACE, POSITION, REFERENCE

PARAMS_KEY = "msd_bench.params"
"""rosbag2 ``custom_data`` key holding the experiment parameters as JSON."""
PARAMS_RECORD = "msd_bench"
"""Name of the MCAP metadata record holding the parameters (``params`` key)."""


def typestore() -> Typestore:
    """Message definitions of the newest ROS 2 distribution rosbags knows (Kilted here)."""
    return get_typestore(Stores.ROS2_KILTED)


class _FlushingMcapStorage:
    """rosbags ``StorageWriter`` on the ``mcap`` library: CRC'd chunks, flushed on a timer."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        if compression != CompressionMode.NONE:
            raise WriterError("compression is not supported by the msd_bench bag writer")
        self.path = path / f"{path.name}.mcap"
        self.flush_period_s = 1.0
        self._file = self.path.open("xb")
        self._mcap = _McapLibWriter(self._file, compression=CompressionType.NONE)
        self._mcap.start(profile="ros2", library="msd_bench (mcap + rosbags)")
        self._schemas: dict[str, int] = {}
        self._channels: dict[int, int] = {}
        self._last_flush = time.monotonic()

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
            {"offered_qos_profiles": offered_qos_profiles},
        )

    def add_params(self, params_json: str) -> None:
        """Write the parameters record now, so a killed recording keeps it."""
        self._mcap.add_metadata(PARAMS_RECORD, {"params": params_json})
        self._file.flush()

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        self._mcap.add_message(self._channels[connection.id], timestamp, bytes(data), timestamp)
        self.flush_if_due()

    def flush_if_due(self) -> None:
        """Push the open chunk to the file once per flush period (bounds what a kill loses)."""
        if time.monotonic() - self._last_flush >= self.flush_period_s:
            self.flush()

    def flush(self) -> None:
        """End the open chunk and hand it to the OS (survives SIGKILL, not a power cut)."""
        self._mcap.flush()
        self._last_flush = time.monotonic()

    def close(self, version: int, metadata: str) -> None:
        _ = version
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": metadata})
        self._mcap.finish()
        self._file.close()

    def abort(self) -> None:
        self._file.close()


class _BagWriter(Writer):
    """rosbags' rosbag2 writer with the MCAP storage replaced by :class:`_FlushingMcapStorage`."""

    STORAGE_PLUGINS = MappingProxyType({StoragePlugin.MCAP: _FlushingMcapStorage})


def _prepare_target(path: Path, overwrite: bool) -> None:
    """Refuse an existing bag unless ``overwrite``; never delete something that is not a bag."""
    if not path.exists():
        return
    if not overwrite:
        raise BagError(f"bag {path} exists already, not overwriting (pass overwrite=True)")
    looks_like_bag = path.is_dir() and (
        (path / "metadata.yaml").exists() or any(path.glob("*.mcap"))
    )
    if not looks_like_bag:
        raise BagError(f"{path} exists and is not a bag: refusing to delete it")
    shutil.rmtree(path)


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
        except WriterError as exc:
            raise BagError(f"bag {self.path}: cannot create ({exc})") from None
        storage = writer.storage
        assert isinstance(storage, _FlushingMcapStorage)
        storage.flush_period_s = self._flush_period_s
        storage.add_params(self._params)
        writer.set_custom_data(PARAMS_KEY, self._params)
        self._writer = writer
        return self

    def write(self, topic: str, ros_type: str, t_ns: int, data: bytes | memoryview) -> None:
        """Append one CDR-serialized message logged at ``t_ns``."""
        if self._writer is None:
            raise BagError(f"bag {self.path}: write on a recorder that is not open")
        conn = self._connections.get((topic, ros_type))
        if conn is None:
            conn = self._writer.add_connection(topic, ros_type, typestore=self._store)
            self._connections[(topic, ros_type)] = conn
        self._writer.write(conn, int(t_ns), data)
        self.message_count += 1

    def flush_if_due(self) -> None:
        """Flush the open chunk if the flush period elapsed (call from a timer when idle)."""
        if self._writer is not None and isinstance(self._writer.storage, _FlushingMcapStorage):
            self._writer.storage.flush_if_due()

    def flush(self) -> None:
        """End the open chunk now (a chunk boundary, e.g. between experiment phases)."""
        if self._writer is not None and isinstance(self._writer.storage, _FlushingMcapStorage):
            self._writer.storage.flush()

    def close(self) -> None:
        """Finish the MCAP summary and write ``metadata.yaml``; idempotent."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()

    def __enter__(self) -> BagRecorder:
        return self.open()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


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
    with BagRecorder(path, params=params, overwrite=overwrite) as rec:
        if reference is not None and t_ns.size:
            ref = store.serialize_cdr(types[f64_t](data=float(reference)), f64_t)
            rec.write(REFERENCE.resolve(namespace), REFERENCE.ros_type, int(t_ns[0]), ref)
        for k in range(t_ns.size):
            ns = int(t_ns[k])
            stamp = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            state = types[state_t](
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
                name=[JOINT_NAME],
                position=np.array([x[k]], dtype=np.float64),
                velocity=np.array([v[k]], dtype=np.float64),
                effort=np.array([u[k]], dtype=np.float64),
            )
            rec.write(topics[0], state_t, ns, store.serialize_cdr(state, state_t))
            rec.write(topics[1], f64_t, ns, store.serialize_cdr(types[f64_t](data=float(x[k])), f64_t))
            rec.write(topics[2], f64_t, ns, store.serialize_cdr(types[f64_t](data=float(u[k])), f64_t))
    return Path(path)
