"""``msd-bench bag check``: verify a bag's MCAP checksums and index, as ``mcap doctor`` does.

Why: rosbags' reader trusts the summary and does not look at chunk CRCs, so
a bag with flipped bytes in its data can pass ``bag info`` and feed wrong
samples to a fit. The check reads the file twice — front to back (every
chunk against its CRC, the data section against the DataEnd CRC) and through
the summary (every chunk index must point at a chunk of the stated length,
every message index at a message-index record, the statistics must match the
messages found) — and compares the message count with ``metadata.yaml``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Chunk, Footer, Message
from mcap.stream_reader import CRCValidationError, StreamReader, breakup_chunk
from mcap.summary import Summary

from msd_bench.io.bag_recover import mcap_file

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

    @property
    def ok(self) -> bool:
        """True when no fault was found."""
        return not self.problems


def _scan(report: CheckReport) -> None:
    """Front-to-back read with every CRC validated; stops at the first fault."""
    with report.mcap_file.open("rb") as fh:
        reader = StreamReader(fh, emit_chunks=True, validate_crcs=True)
        try:
            for record in reader.records:
                if isinstance(record, Chunk):
                    inner = breakup_chunk(record, validate_crc=True)
                    report.messages += sum(isinstance(r, Message) for r in inner)
                    report.chunks += 1
                elif isinstance(record, Message):
                    report.messages += 1
                elif isinstance(record, Footer):
                    break
        except CRCValidationError as exc:
            report.problems.append(f"CRC mismatch after chunk {report.chunks}: {exc}")
        except (McapError, struct.error, EOFError, ValueError, UnicodeDecodeError) as exc:
            report.problems.append(f"truncated or corrupt record after chunk {report.chunks}: {exc!r}")


def _read_header(fh: IO[bytes], offset: int) -> tuple[int, int] | None:
    """(opcode, length) of the record at ``offset``, or None past the end."""
    fh.seek(offset)
    raw = fh.read(9)
    if len(raw) < 9:
        return None
    opcode, length = struct.unpack("<BQ", raw)
    return opcode, length


def _summary(fh: IO[bytes], report: CheckReport) -> Summary | None:
    try:
        summary = make_reader(fh).get_summary()
    except (McapError, struct.error, EOFError, ValueError) as exc:
        report.problems.append(f"summary unreadable (no footer? try `msd-bench bag recover`): {exc!r}")
        return None
    if summary is None:
        report.problems.append("no summary section: the file has no index (killed recording?)")
    return summary


def _check_index(report: CheckReport) -> None:
    """Every index entry must point at the record it names; statistics must match the data."""
    with report.mcap_file.open("rb") as fh:
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
    meta = bag_dir / "metadata.yaml"
    if not meta.exists():
        report.problems.append(f"no metadata.yaml: try `msd-bench bag recover {bag_dir}`")
        return
    try:
        info = yaml.safe_load(meta.read_text())["rosbag2_bagfile_information"]
        count = int(info["message_count"])
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
        report.problems.append(f"metadata.yaml unreadable: {exc!r}")
        return
    if not report.problems and count != report.messages:
        report.problems.append(f"metadata.yaml says {count} messages, the data holds {report.messages}")


def check_bag(path: str | Path) -> CheckReport:
    """Verify CRCs, index and counts of a bag directory (or one ``.mcap`` file)."""
    path = Path(path)
    report = CheckReport(mcap_file(path))
    _scan(report)
    _check_index(report)
    if path.is_dir():
        _check_metadata(path, report)
    return report


def crc_problem(path: str | Path) -> str | None:
    """The first CRC fault of a bag (front-to-back scan only), or None; for ``bag info``'s warning."""
    report = CheckReport(mcap_file(Path(path)))
    _scan(report)
    return report.problems[0] if report.problems else None
