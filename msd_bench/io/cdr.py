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
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

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


def _strings(raw: bytes | memoryview, p: int) -> tuple[list[str], int]:
    p = _aligned(p, 4)
    count = _U32.unpack_from(raw, p)[0]
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
        out.append(bytes(raw[p:p + n - 1]).decode())
        p += n
    return out, p


def _doubles(raw: bytes | memoryview, p: int) -> tuple[tuple[float, ...], int]:
    p = _aligned(p, 4)
    count = _U32.unpack_from(raw, p)[0]
    p += 4
    if count == 0:
        return (), p
    p = _aligned(p, 8)
    if p + 8 * count > len(raw):
        raise struct.error("array beyond the message")
    return struct.unpack_from(f"<{count}d", raw, p), p + 8 * count
