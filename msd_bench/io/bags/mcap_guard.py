"""Bounds on what reading an MCAP file may allocate, whatever its bytes claim.

Why: an MCAP record starts with its length (a uint64), and a chunk states its
uncompressed size; both rosbags and the ``mcap`` library trust them. A
truncated file, a flipped bit or a crafted length of 2^60 then asks for a
buffer of that size (``file.read(n)`` allocates ``n`` bytes before reading),
and a compressed chunk can inflate far beyond what it claims (``zstandard``
sizes its output by the frame header, not by the caller's limit). So:

* :class:`BoundedFile` is the file every reader gets: a read never asks for
  more than the bytes left in the file, so no record length can allocate more
  than the file's own size;
* :func:`check_chunks` walks the file's top-level records once before a library
  does, and refuses a chunk whose uncompressed size is over
  :data:`MAX_CHUNK_BYTES` or whose compressed data does not inflate to exactly
  that size (measured with a bounded decompressor);
* :func:`inflate` is that bounded decompressor, for the readers that unpack
  chunks themselves (``bag check``, ``bag recover``).

Every fault is a :class:`McapBoundError` (a ``ValueError``, like the libraries'
own parse errors), which the bag readers turn into their one-line BagError.
"""

from __future__ import annotations

import io
import struct
from dataclasses import replace
from pathlib import Path
from types import TracebackType

import lz4.frame
import zstandard
from mcap.exceptions import McapError
from mcap.records import Chunk, McapRecord
from mcap.stream_reader import breakup_chunk

MAX_CHUNK_BYTES = 64 << 20
"""Largest uncompressed chunk read (64 MiB): rosbag2's MCAP writer makes chunks of 768 KiB, ours of 1 MiB."""
_PIECE = 1 << 20
"""Bytes decompressed per step, so memory grows with the real output, not with a claimed size."""

_OP_CHUNK = 0x06
_OP_FOOTER = 0x02
_MAGIC = b"\x89MCAP0\r\n"
_RECORD = struct.Struct("<BQ")
_CHUNK_HEAD = struct.Struct("<QQQII")
"""Chunk: start time, end time, uncompressed size, uncompressed CRC, compression string length."""
COMPRESSIONS = ("", "zstd", "lz4")
"""Chunk compressions the readers understand."""


class McapBoundError(ValueError):
    """An MCAP file claims more than it holds, or more than a reader will allocate."""


MCAP_ERRORS = (McapError, struct.error, EOFError, ValueError, OSError)
"""What the ``mcap`` library raises on a damaged file: its own ``McapError`` family (``InvalidMagic``,
``EndOfFile``, ``RecordLengthLimitExceeded``), ``struct.error`` on a short field, ``ValueError``
(``CRCValidationError``, a bad UTF-8 string, an unknown opcode, :class:`McapBoundError`) and
``OSError`` (seeking to the footer of a file shorter than one)."""


class BoundedFile:
    """A read-only file whose reads never ask for more bytes than are left in it.

    Why a wrapper and not a check: the libraries read lengths straight from the
    file and call ``read(length)``; clamping here keeps their own short-read
    errors (``ReaderError``, ``EndOfFile``) while a lying length costs nothing.
    Deliberately not an ``io.RawIOBase``: ``mcap`` would wrap one in a
    ``BufferedReader``, whose ``read(n)`` allocates ``n`` bytes first.
    """

    def __init__(self, path: Path) -> None:
        self._fh = Path(path).open("rb")  # noqa: SIM115 (closed by close())
        self.size = self._fh.seek(0, io.SEEK_END)
        self._fh.seek(0)

    def readable(self) -> bool:
        """Always: the file is open for reading."""
        return True

    def seekable(self) -> bool:
        """Always: the file is a regular file (so ``mcap`` picks its seeking reader)."""
        return True

    def read(self, size: int | None = -1) -> bytes:
        """At most ``size`` bytes, and never more than are left."""
        left = max(0, self.size - self._fh.tell())
        return self._fh.read(left if size is None or size < 0 else min(size, left))

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        """As ``file.seek``."""
        return self._fh.seek(offset, whence)

    def tell(self) -> int:
        """As ``file.tell``."""
        return self._fh.tell()

    def close(self) -> None:
        """Close the file."""
        self._fh.close()

    def __enter__(self) -> BoundedFile:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def inflate(compression: str, data: bytes, size: int) -> bytes:
    """``data`` decompressed, if it inflates to exactly ``size`` bytes (at most :data:`MAX_CHUNK_BYTES`).

    Never produces more than ``size + 1`` bytes, whatever the compressed
    stream's own header says.
    """
    if compression not in COMPRESSIONS:
        raise McapBoundError(f"unsupported chunk compression {compression[:40]!r}")
    if size > MAX_CHUNK_BYTES:
        raise McapBoundError(f"a chunk claims {size} uncompressed bytes, "
                             f"over the {MAX_CHUNK_BYTES}-byte limit")
    if compression == "":
        out = data
    elif compression == "zstd":
        out = _zstd(data, size + 1)
    else:
        out = _lz4(data, size + 1)
    if len(out) != size:
        raise McapBoundError(f"a {compression or 'plain'} chunk holds {len(out)}"
                             f"{'+' if len(out) > size else ''} bytes, not the {size} it claims")
    return out


def _zstd(data: bytes, limit: int) -> bytes:
    parts: list[bytes] = []
    got = 0
    try:
        with zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data), read_across_frames=True) as rd:
            while got < limit and (part := rd.read(min(limit - got, _PIECE))):
                parts.append(part)
                got += len(part)
    except zstandard.ZstdError as exc:
        raise McapBoundError(f"zstd chunk does not decompress ({exc})") from None
    return b"".join(parts)


def _lz4(data: bytes, limit: int) -> bytes:
    """One LZ4 frame, as rosbags and mcap read it, at most ``limit`` bytes of it."""
    try:
        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=limit))
    except RuntimeError as exc:  # lz4.frame's error type for a bad frame
        raise McapBoundError(f"lz4 chunk does not decompress ({exc})") from None


def check_chunks(fh: BoundedFile) -> None:
    """Walk the top-level records from the start: each must fit the file, each chunk must inflate honestly.

    Stops at the footer or at the end of the file (a file cut short is left to
    the libraries' own errors, which say so); leaves ``fh`` at its start.
    """
    fh.seek(0)
    if fh.read(len(_MAGIC)) != _MAGIC:
        fh.seek(0)
        return  # not MCAP magic: the library's own error says so
    pos = len(_MAGIC)
    while pos + _RECORD.size <= fh.size:
        fh.seek(pos)
        opcode, length = _RECORD.unpack(fh.read(_RECORD.size))
        body = pos + _RECORD.size
        if length > fh.size - body:
            raise McapBoundError(f"record at offset {pos} claims {length} bytes, "
                                 f"{fh.size - body} are left in the file")
        if opcode == _OP_FOOTER:
            break
        if opcode == _OP_CHUNK:
            _check_chunk(fh, body, length)
        pos = body + length
    fh.seek(0)


def _check_chunk(fh: BoundedFile, body: int, length: int) -> None:
    head = fh.read(_CHUNK_HEAD.size)
    if len(head) < _CHUNK_HEAD.size:
        raise McapBoundError(f"chunk at offset {body - _RECORD.size} is shorter than its header")
    _, _, size, _, name_len = _CHUNK_HEAD.unpack(head)
    if _CHUNK_HEAD.size + name_len + 8 > length:
        raise McapBoundError(f"chunk at offset {body - _RECORD.size}: compression name runs past the record")
    try:
        compression = fh.read(name_len).decode()
    except UnicodeDecodeError:
        where = body - _RECORD.size
        raise McapBoundError(f"chunk at offset {where}: compression name is not UTF-8") from None
    (compressed,) = struct.unpack("<Q", fh.read(8))
    if size > MAX_CHUNK_BYTES:
        raise McapBoundError(f"chunk at offset {body - _RECORD.size} claims {size} uncompressed bytes, "
                             f"over the {MAX_CHUNK_BYTES}-byte limit")
    if compressed > length - (_CHUNK_HEAD.size + name_len + 8):
        raise McapBoundError(f"chunk at offset {body - _RECORD.size}: {compressed} compressed bytes "
                             f"claimed, the record holds fewer")
    if compression:
        inflate(compression, fh.read(compressed), size)


def chunk_records(chunk: Chunk, *, salvage: bool = False) -> list[McapRecord]:
    """The records of an ``mcap`` chunk, decompressed by :func:`inflate` (bounded), CRC checked.

    Why not ``breakup_chunk`` on the chunk itself: it sizes its output by what the chunk claims.
    ``salvage`` (``bag recover``) takes an uncompressed chunk's data as it is, whatever size it
    claims: the data is already in memory, and its CRC decides whether it is whole.
    """
    if salvage and chunk.compression == "":
        data = chunk.data
    else:
        data = inflate(chunk.compression, chunk.data, chunk.uncompressed_size)
    plain = replace(chunk, compression="", data=data)
    return breakup_chunk(plain, validate_crc=True)
