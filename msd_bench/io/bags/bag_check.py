"""``msd-bench bag check``: verify a bag's MCAP checksums and index, as ``mcap doctor`` does.

Why: rosbags' reader trusts the summary and does not look at chunk CRCs, so
a bag with flipped bytes in its data can pass ``bag info`` and feed wrong
samples to a fit. The check reads the file twice — front to back (every
chunk against its CRC, the data section against the DataEnd CRC) and through
the summary (every chunk index must point at a chunk of the stated length,
every message index at a message-index record, the statistics must match the
messages found) — and compares ``metadata.yaml`` with the data: the total, every
topic's count, the starting time and the duration. Every read goes through
:mod:`.mcap_guard`, so a lying length or chunk size is a fault found, not an
allocation.
"""

from __future__ import annotations

import io
import struct
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, cast

from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Footer, McapRecord, Message
from mcap.stream_reader import CRCValidationError, StreamReader
from mcap.summary import Summary

from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_meta import BagMetadata, read_metadata, shown
from msd_bench.io.bags.bag_recover import mcap_file
from msd_bench.io.bags.mcap_guard import MCAP_ERRORS, BoundedFile, chunk_records

_OP_CHUNK = 0x06
_OP_MESSAGE_INDEX = 0x07



@dataclass
class CheckReport:
    """What :func:`check_bag` found; ``problems`` empty means the bag is sound."""

    mcap_file: Path
    """The MCAP file checked."""
    messages: int = 0
    """Messages read front to back."""
    chunks: int = 0
    """Chunks read front to back (each CRC-checked)."""
    problems: list[str] = field(default_factory=list)
    """One line per fault found."""
    warnings: list[str] = field(default_factory=list)
    """One line per disagreement that leaves the data usable (``metadata.yaml``'s times)."""
    topics: Counter[str] = field(default_factory=Counter)
    """Messages read front to back, per topic (by the channel records met on the way)."""
    first_ns: int | None = None
    """Earliest message log time met."""
    last_ns: int | None = None
    """Latest message log time met."""

    @property
    def ok(self) -> bool:
        """True when no fault was found."""
        return not self.problems


@dataclass
class _Tally:
    """Channels and per-channel message counts met front to back."""

    topic_of: dict[int, str] = field(default_factory=dict)
    per_channel: Counter[int] = field(default_factory=Counter)


def _count(report: CheckReport, tally: _Tally, record: McapRecord) -> None:
    if isinstance(record, Channel):
        tally.topic_of[record.id] = record.topic
    elif isinstance(record, Message):
        report.messages += 1
        tally.per_channel[record.channel_id] += 1
        t = record.log_time
        report.first_ns = t if report.first_ns is None else min(report.first_ns, t)
        report.last_ns = t if report.last_ns is None else max(report.last_ns, t)


def _scan(report: CheckReport) -> None:
    """Front-to-back read with every CRC validated; stops at the first fault."""
    tally = _Tally()
    with BoundedFile(report.mcap_file) as fh:
        reader = StreamReader(cast(IO[bytes], fh), emit_chunks=True, validate_crcs=True,
                              record_size_limit=fh.size)
        try:
            for record in reader.records:
                if isinstance(record, Chunk):
                    for inner in chunk_records(record):
                        _count(report, tally, inner)
                    report.chunks += 1
                elif isinstance(record, Footer):
                    break
                else:
                    _count(report, tally, record)
        except CRCValidationError as exc:
            report.problems.append(f"CRC mismatch after chunk {report.chunks}: {exc}")
        except MCAP_ERRORS as exc:
            report.problems.append(f"truncated or corrupt record after chunk {report.chunks}: {exc!r:.300}")
    for channel, n in tally.per_channel.items():
        report.topics[tally.topic_of.get(channel, f"(channel {channel} without a channel record)")] += n


def _read_header(fh: IO[bytes], offset: int) -> tuple[int, int] | None:
    """(opcode, length) of the record at ``offset``, or None past the end (an index may name any offset)."""
    if not 0 <= offset <= fh.seek(0, io.SEEK_END) - 9:
        return None
    fh.seek(offset)
    raw = fh.read(9)
    if len(raw) < 9:
        return None
    opcode, length = struct.unpack("<BQ", raw)
    return opcode, length


def _summary(fh: IO[bytes], report: CheckReport) -> Summary | None:
    try:
        summary = make_reader(fh).get_summary()
    except MCAP_ERRORS as exc:
        report.problems.append(f"summary unreadable (no footer? try `msd-bench bag recover`): {exc!r:.300}")
        return None
    if summary is None:
        report.problems.append("no summary section: the file has no index (killed recording?)")
    return summary


def _check_index(report: CheckReport) -> None:
    """Every index entry must point at the record it names; statistics must match the data."""
    with BoundedFile(report.mcap_file) as bounded:
        fh = cast(IO[bytes], bounded)
        summary = _summary(fh, report)
        if summary is None:
            return
        for i, idx in enumerate(summary.chunk_indexes):
            head = _read_header(fh, idx.chunk_start_offset)
            if head is None or head[0] != _OP_CHUNK or head[1] + 9 != idx.chunk_length:
                report.problems.append(f"chunk index {i} points at offset {idx.chunk_start_offset}, "
                                       f"where there is no chunk of {idx.chunk_length} bytes")
                continue
            for channel, offset in idx.message_index_offsets.items():
                head = _read_header(fh, offset)
                if head is None or head[0] != _OP_MESSAGE_INDEX:
                    report.problems.append(f"message index of channel {channel} in chunk {i} "
                                           f"points at offset {offset}, where there is none")
        stats = summary.statistics
        if stats is not None and not report.problems:
            if stats.message_count != report.messages:
                report.problems.append(f"statistics say {stats.message_count} messages, "
                                       f"the data holds {report.messages}")
            if stats.chunk_count != report.chunks or len(summary.chunk_indexes) != report.chunks:
                report.problems.append(f"index lists {len(summary.chunk_indexes)} chunks "
                                       f"(statistics {stats.chunk_count}), the data holds {report.chunks}")


def _check_metadata(bag_dir: Path, report: CheckReport) -> None:
    """``metadata.yaml`` against the data: the total, every topic's count, the first and last log time."""
    if not (bag_dir / "metadata.yaml").exists():
        report.problems.append(f"no metadata.yaml: try `msd-bench bag recover {bag_dir}`")
        return
    try:
        meta = read_metadata(bag_dir)
    except BagError as exc:
        report.problems.append(f"metadata.yaml unreadable: {exc}")
        return
    if report.problems:
        return  # counts of a damaged file say nothing more
    if meta.message_count != report.messages:
        report.problems.append(f"metadata.yaml says {meta.message_count} messages, "
                               f"the data holds {report.messages}")
    claimed: Counter[str] = Counter()
    for topic in meta.topics:
        claimed[topic.name] += topic.count
    for name in sorted(set(claimed) | set(report.topics)):
        if claimed[name] != report.topics[name]:
            report.problems.append(f"metadata.yaml says {claimed[name]} messages on {shown(name)}, "
                                   f"the data holds {report.topics[name]}")
    _check_times(meta, report)


def _check_times(meta: BagMetadata, report: CheckReport) -> None:
    """``starting_time`` and ``duration`` should be the first log time and the span of the data.

    A warning, not a fault: the readers take times from the messages, never from these fields
    (and a bag closed on a full disk keeps the duration of what it was sent).
    """
    if report.first_ns is None or report.last_ns is None or meta.message_count == 0:
        return
    if meta.start_ns != report.first_ns:
        report.warnings.append(f"metadata.yaml starting_time is {meta.start_ns} ns, "
                               f"the first message is logged at {report.first_ns} ns")
    span = report.last_ns - report.first_ns
    if meta.duration_ns != span:
        report.warnings.append(f"metadata.yaml duration is {meta.duration_ns} ns, the data spans {span} ns")


def _refuse_other_storage(path: Path) -> None:
    """A BagError for a bag whose metadata.yaml names another storage; an unreadable one is a fault found."""
    if not (path.is_dir() and (path / "metadata.yaml").exists()):
        return
    try:
        storage = read_metadata(path).storage
    except BagError:
        return  # reported by _check_metadata with the rest
    if storage != "mcap":
        raise BagError(f"bag {path} is stored as {shown(storage)}: bag check reads MCAP bags only")


def check_bag(path: str | Path) -> CheckReport:
    """Verify CRCs, index and counts of a bag directory (or one ``.mcap`` file).

    A bag that is not MCAP (a sqlite3 bag) is a BagError: it has none of this to check.
    """
    path = Path(path)
    _refuse_other_storage(path)
    report = CheckReport(mcap_file(path))
    _scan(report)
    _check_index(report)
    if path.is_dir():
        _check_metadata(path, report)
    return report


def crc_problem(path: str | Path) -> str | None:
    """The first CRC fault of a bag (front-to-back scan only), or None; for ``bag info``'s warning."""
    report = scan_bag(path)
    return report.problems[0] if report.problems else None


def scan_bag(path: str | Path) -> CheckReport:
    """The front-to-back scan alone (CRCs, and per-topic counts of the messages found): what
    ``bag info`` reads anyway, so it can print counts it verified instead of metadata.yaml's claims."""
    report = CheckReport(mcap_file(Path(path)))
    _scan(report)
    return report
