"""Recover a killed recording: salvage the complete chunks of a footerless MCAP.

A SIGKILLed :class:`~msd_bench.io.bags.reader.BagRecorder` leaves an MCAP file with
no summary, no footer, maybe a half-written last chunk, and no
``metadata.yaml``. ``mcap``'s ``StreamReader`` reads records front to back
without needing the footer; every chunk is checked against its CRC and taken
whole or not at all, and the scan stops at the first truncated or corrupt
record. The salvage is written as a new bag *beside* the original
(``<bag>.recovered``); the original is never modified.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, cast

from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader
from rosbags.interfaces import Qos
from rosbags.rosbag2 import ReaderError
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import get_types_from_msg
from rosbags.typesys.base import TypesysError
from rosbags.typesys.store import Typestore

from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_open import data_file
from msd_bench.io.bags.bag_writer import PARAMS_RECORD, BagRecorder, _prepare_target, check_target, typestore
from msd_bench.io.bags.mcap_guard import MCAP_ERRORS, BoundedFile, chunk_records
from msd_bench.io.storage.paths import writable_dir
from msd_bench.io.storage.safe_read import loads_bounded

RECOVERED_SUFFIX = ".recovered"
"""Suffix of the directory the recovered bag is written to, next to the original."""


@dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover` salvaged."""

    source: Path
    """The damaged MCAP file (left untouched)."""
    output: Path
    """The new, complete bag directory."""
    messages: int
    """Messages copied into the new bag."""
    chunks: int
    """Complete chunks read (a partial trailing chunk is dropped)."""
    stopped: str
    """Why the scan ended: ``"end of data"`` or the truncation/corruption met."""
    counts: dict[str, int] = field(default_factory=dict)
    """Messages per topic in the new bag."""

    def summary(self) -> str:
        """One line for the CLI."""
        return (
            f"recovered {self.messages} messages ({self.chunks} chunks) from {self.source} "
            f"into {self.output}; original left untouched; scan ended: {self.stopped}"
        )


@dataclass
class _Salvage:
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[Message] = field(default_factory=list)
    params: str | None = None
    chunks: int = 0
    stopped: str = "end of data"


def mcap_file(path: Path) -> Path:
    """The one MCAP file of a bag directory (or the file itself), a regular file.

    A dangling symlink, a directory named ``x.mcap`` or a FIFO is one BagError
    line (opening them was a traceback, or a read that never returns).
    """
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if len(files) != 1:
            raise BagError(f"bag {path}: expected one .mcap file, found {len(files)}")
        return data_file(files[0])
    if not path.exists() and not path.is_symlink():
        raise BagError(f"bag {path} does not exist")
    return data_file(path)


def _take(salvage: _Salvage, record: object) -> None:
    """Keep one record's contribution."""
    if isinstance(record, Schema):
        salvage.schemas[record.id] = record
    elif isinstance(record, Channel):
        salvage.channels[record.id] = record
    elif isinstance(record, Message):
        salvage.messages.append(record)
    elif isinstance(record, Metadata) and record.name == PARAMS_RECORD:
        salvage.params = record.metadata.get("params")


def _scan(mcap_file: Path) -> _Salvage:
    """Read records until the data section ends or a record is truncated or corrupt.

    Through :mod:`.mcap_guard`: no record length or chunk size read from the
    file can make the scan allocate more than the file (or one bounded chunk).
    """
    salvage = _Salvage()
    try:
        fh = BoundedFile(mcap_file)
    except OSError as exc:
        raise BagError(f"bag file {mcap_file}: cannot read ({exc.strerror or exc})") from None
    with fh:
        reader = StreamReader(cast(IO[bytes], fh), emit_chunks=True, validate_crcs=True,
                              record_size_limit=fh.size)
        try:
            for record in reader.records:
                if isinstance(record, DataEnd | Footer):
                    break
                if isinstance(record, Chunk):
                    inner = chunk_records(record, salvage=True)  # all or nothing
                    for rec in inner:
                        _take(salvage, rec)
                    salvage.chunks += 1
                else:
                    _take(salvage, record)
        except CRCValidationError as exc:
            salvage.stopped = f"corrupt chunk ({exc})"
        except MCAP_ERRORS as exc:
            salvage.stopped = f"truncated or corrupt record after chunk {salvage.chunks} ({exc!r:.300})"
    _check_params(mcap_file, salvage)
    return salvage


def _check_params(mcap_file: Path, salvage: _Salvage) -> None:
    """Keep the parameters record only if it is a bounded JSON object; say so when it is dropped."""
    if salvage.params is None:
        return
    try:
        value = loads_bounded(salvage.params, f"bag file {mcap_file}: parameters record", BagError)
    except BagError as exc:
        value, why = None, str(exc)
    else:
        why = "" if isinstance(value, dict) else "parameters record is not a JSON object"
    if why:
        salvage.params = None
        salvage.stopped += f"; parameters not copied ({why})"


def _store_for(schemas: dict[int, Schema]) -> Typestore:
    """Kilted's typestore plus any message type the bag defines that it lacks."""
    store = typestore()
    for schema in schemas.values():
        if schema.name not in store.types and schema.encoding == "ros2msg":
            store.register(get_types_from_msg(schema.data.decode(), schema.name))
    return store


def _write(salvage: _Salvage, out: Path) -> dict[str, int]:
    """Copy the salvaged messages into a complete bag; returns messages per topic."""
    params = json.loads(salvage.params) if salvage.params else {}
    counts: dict[str, int] = {}
    with BagRecorder(out, params=params, store=_store_for(salvage.schemas)) as rec:
        for msg in salvage.messages:
            channel = salvage.channels.get(msg.channel_id)
            schema = salvage.schemas.get(channel.schema_id) if channel else None
            if channel is None or schema is None:
                continue  # a message whose channel was lost cannot be typed
            rec.write(channel.topic, schema.name, msg.log_time, msg.data, _offered_qos(channel))
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return counts


def _offered_qos(channel: Channel) -> list[Qos]:
    """The channel's recorded QoS profiles, carried into the recovered bag (none if unreadable)."""
    try:
        return parse_qos(channel.metadata.get("offered_qos_profiles", ""))
    except (ReaderError, KeyError, TypeError, ValueError):
        return []


def _check_output(out: Path, source: Path, bag_dir: Path | None) -> None:
    """Refuse an output that is the damaged recording, holds it, or lies inside its bag directory.

    Why: ``--overwrite`` removes the output first, so ``recover victim --output
    victim --overwrite`` would delete the only copy of the data to recover.
    """
    o = out.resolve()
    for kept in (source, *([bag_dir] if bag_dir is not None else [])):
        k = kept.resolve()
        if o == k or o in k.parents:
            raise BagError(f"output {out} is the recording being recovered or holds it ({kept}): choose "
                           f"another output; the original is never replaced")
    if bag_dir is not None and bag_dir.resolve() in o.parents:
        raise BagError(f"output {out} is inside the bag being recovered ({bag_dir}): choose a directory "
                       f"outside it")


def recover(path: str | Path, *, output: str | Path | None = None, overwrite: bool = False) -> RecoveryReport:
    """Write the readable part of a killed recording as a new bag next to it.

    ``path`` is the bag directory (or its ``.mcap``); the new bag goes to
    ``output`` or ``<bag>.recovered``. Raises :class:`BagError` when nothing
    at all can be salvaged.
    """
    path = Path(path)
    source = mcap_file(path)
    whole = path.absolute()  # `bag recover x.mcap` inside the bag: its directory has a name
    bag_dir = whole if path.is_dir() else whole.parent
    out = Path(output) if output is not None else bag_dir.with_name(bag_dir.name + RECOVERED_SUFFIX)
    _check_output(out, source, bag_dir if path.is_dir() else None)
    check_target(out, overwrite)  # before the scan: a refusal costs nothing
    writable_dir(out.parent, "output directory")  # and a read-only disk is one line at once
    salvage = _scan(source)
    if not salvage.messages:
        raise BagError(f"bag {path}: no complete chunk to recover ({salvage.stopped})")
    _prepare_target(out, overwrite)  # an old recovered bag is removed only once there is a new one to write
    try:
        counts = _write(salvage, out)
    except BagError:
        raise
    except (ValueError, KeyError, TypesysError) as exc:  # TypesysError: a malformed message definition
        text = " ".join(str(exc).split())[:300]
        raise BagError(f"bag {path}: cannot rewrite salvaged messages ({text})") from None
    return RecoveryReport(source, out, sum(counts.values()), salvage.chunks, salvage.stopped, counts)


__all__ = ["RECOVERED_SUFFIX", "RecoveryReport", "recover"]
