"""A direct reader of serialized ``sensor_msgs/msg/JointState`` (little-endian CDR).

Why: every bag the bench reads is mostly JointState rows, and rosbags'
general deserializer builds a message object per row — reading a run's 40-odd
bags cost its report and its identifier more than the work they do with the
rows. This reads the few fields the bench needs straight from the bytes, and
answers None for anything it does not recognise (another encapsulation, a
layout that does not end where the bytes end), so the caller falls back to
rosbags and its errors. Tests compare it with rosbags field by field.

Layout (XCDR1, as rmw_fastrtps writes it; alignment counts from the byte after
the 4-byte encapsulation header): header.stamp (int32 sec, uint32 nanosec),
header.frame_id (string: uint32 length with the NUL, bytes), name
(uint32 count, strings), then position, velocity and effort (uint32 count,
float64 values aligned to 8 when there are any).

:func:`joint_state_columns` reads a whole topic at once when every message has
the same layout (the plant's one-joint rows): such messages differ only in
their stamp, value and padding bytes, so numpy reads stamps and values at fixed offsets from the
concatenated bytes instead of a Python loop per row.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

_LITTLE_ENDIAN_CDR = b"\x00\x01"
_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_BASE = 4
"""Alignment origin: the payload starts after the encapsulation header."""


@dataclass(frozen=True)
class JointStateRow:
    """The fields of one JointState the bench reads."""

    stamp_ns: int
    name: list[str]
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]


def joint_state(raw: bytes | memoryview) -> JointStateRow | None:
    """Decode one serialized JointState; None if it is not plain little-endian CDR of that layout."""
    if len(raw) < 16 or bytes(raw[:2]) != _LITTLE_ENDIAN_CDR:
        return None
    try:
        sec, nanosec = _STAMP.unpack_from(raw, 4)
        frame_len = _U32.unpack_from(raw, 12)[0]
        p = 16 + frame_len
        names, p = _strings(raw, p)
        arrays = []
        for _ in range(3):
            values, p = _doubles(raw, p)
            arrays.append(values)
    except (struct.error, UnicodeDecodeError):
        return None
    if p > len(raw) or len(raw) - p > 7:  # trailing bytes beyond padding: not this layout
        return None
    return JointStateRow(sec * 1_000_000_000 + nanosec, names, arrays[0], arrays[1], arrays[2])


def _aligned(p: int, size: int) -> int:
    return p + (-(p - _BASE)) % size


def _strings(raw: bytes | memoryview, p: int, spans: list[slice] | None = None) -> tuple[list[str], int]:
    """A sequence of strings at ``p``; ``spans`` (if given) collects the bytes that encode it."""
    p = _aligned(p, 4)
    count = _U32.unpack_from(raw, p)[0]
    _span(spans, p, 4)
    p += 4
    if count > len(raw):
        raise struct.error("string count beyond the message")
    out = []
    for _ in range(count):
        p = _aligned(p, 4)
        n = _U32.unpack_from(raw, p)[0]
        p += 4
        if n == 0 or p + n > len(raw):
            raise struct.error("string beyond the message")
        _span(spans, p - 4, 3 + n)  # its length and text; the reader never looks at the NUL
        out.append(bytes(raw[p:p + n - 1]).decode())
        p += n
    return out, p


def _doubles(
    raw: bytes | memoryview, p: int, spans: list[slice] | None = None
) -> tuple[tuple[float, ...], int]:
    """A float64 sequence at ``p``; ``spans`` (if given) collects its count's bytes, not the values'."""
    p = _aligned(p, 4)
    count = _U32.unpack_from(raw, p)[0]
    _span(spans, p, 4)
    p += 4
    if count == 0:
        return (), p
    p = _aligned(p, 8)
    if p + 8 * count > len(raw):
        raise struct.error("array beyond the message")
    return struct.unpack_from(f"<{count}d", raw, p), p + 8 * count


def _span(spans: list[slice] | None, start: int, size: int) -> None:
    if spans is not None:
        spans.append(slice(start, start + size))


@dataclass(frozen=True)
class JointStateColumns:
    """The fields of a run of one-joint JointStates, one row per message, in the order given."""

    stamp_ns: np.ndarray
    """Header stamps, ns (int64)."""
    name: list[str]
    """The one joint's name (the same in every message)."""
    position: np.ndarray
    """(n, 0) or (n, 1) float64: a JointState may leave an array empty, the same way in every message."""
    velocity: np.ndarray
    """As ``position``."""
    effort: np.ndarray
    """As ``position``."""


def joint_state_columns(raws: Sequence[bytes | memoryview]) -> JointStateColumns | None:
    """All messages decoded at once, or None unless they share one one-joint layout.

    Shared layout means: the first message is one :func:`joint_state` reads, with
    one name and at most one value per array, and every message has its length
    and its layout bytes (:func:`_layout`). :func:`joint_state` walks such
    messages exactly like the first, so reading the stamp and the values at the
    first's offsets gives what it gives row by row, bit for bit;
    anything else (several joints, a changing frame id, a truncated message) is
    None and left to the per-message reader and its errors.
    """
    if not raws:
        return None
    first = joint_state(raws[0])
    if first is None or len(first.name) != 1:
        return None
    spans, slots = _layout(raws[0])
    if any(count > 1 for _, count in slots):
        return None
    size = len(raws[0])
    if any(len(raw) != size for raw in raws):
        return None
    rows = np.frombuffer(b"".join(raws), dtype=np.uint8).reshape(len(raws), size)
    layout = np.zeros(size, dtype=bool)
    for span in spans:
        layout[span] = True
    if not (rows[:, layout] == rows[0, layout]).all():
        return None
    position, velocity, effort = (_doubles_at(rows, offset, count) for offset, count in slots)
    sec = _column(rows, 4, "<i4").astype(np.int64)
    nanosec = _column(rows, 8, "<u4").astype(np.int64)
    return JointStateColumns(sec * 1_000_000_000 + nanosec, first.name, position, velocity, effort)


def _layout(raw: bytes | memoryview) -> tuple[list[slice], list[tuple[int, int]]]:
    """Where a message :func:`joint_state` reads encodes its layout, and (offset, count) of its arrays.

    The layout bytes are what that reader's walk depends on or returns: the
    encapsulation, the frame id's length, the names and the array counts. Not
    the frame id's text (skipped) nor the padding: rmw leaves padding bytes
    uninitialised, so they differ between messages of one layout.
    """
    spans = [slice(0, 2), slice(12, 16)]
    frame_len = _U32.unpack_from(raw, 12)[0]
    _, p = _strings(raw, 16 + frame_len, spans)
    slots = []
    for _ in range(3):
        values, p = _doubles(raw, p, spans)
        slots.append((p - 8 * len(values), len(values)))
    return spans, slots


def _column(rows: np.ndarray, offset: int, dtype: str) -> np.ndarray:
    """One little-endian field at ``offset`` of every row, as a native array."""
    width = np.dtype(dtype).itemsize
    return np.ascontiguousarray(rows[:, offset:offset + width]).view(dtype)[:, 0]


def _doubles_at(rows: np.ndarray, offset: int, count: int) -> np.ndarray:
    """(n, count) float64 values at ``offset`` of every row (count 0: an empty array in every message)."""
    if count == 0:
        return np.empty((rows.shape[0], 0), dtype=np.float64)
    return _column(rows, offset, "<f8").astype(np.float64).reshape(-1, 1)
