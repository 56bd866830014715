"""A bounded reader for ``.npz`` archives that a user hands the tools (Q-table artifacts).

Why not ``np.load``: it trusts the archive. A member's ``.npy`` header states a
shape and numpy allocates ``prod(shape)`` elements before reading a byte (a
389 KB archive can expand to hundreds of MB, a lying header to terabytes);
the deflate stream is decompressed as far as it goes; and a damaged archive
leaks ``BadZipFile``, ``zlib.error``, ``EOFError`` or ``NotImplementedError``
as a traceback. Here every size is checked against a bound *before* anything
is allocated or decompressed beyond it, only stored or deflated members of
plain (numeric or string) dtypes are accepted, and each failure is the
caller's one-line error naming the file.
"""

from __future__ import annotations

import tokenize
import warnings
import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path
from typing import IO

import numpy as np
from numpy.lib import format as npy_format

from msd_bench.core.errors import MsdBenchError

MAX_NPZ_BYTES = 64 << 20
"""Largest total uncompressed size of an archive's members (64 MiB): a run's Q-tables
(3 seeds x 3 tables x 100 states x 5 actions of float64) are about 36 KB."""

MAX_NPZ_MEMBERS = 64
"""Most members an archive may have (a Q-table artifact has four)."""

DTYPE_KINDS = "fU"
"""Accepted dtype kinds: floating point (the tables) and unicode strings (the metadata)."""

_READ_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, tokenize.TokenError)
"""What zipfile (damaged archive, bad CRC, truncated or corrupt deflate stream) and numpy's
header parser (bad magic, unparsable or mis-typed header dictionary; ``TokenError`` from the
tokenizer its Python-2 header fallback runs on a header that is not a literal) raise."""

_UNREAD = 0x1 | 0x20 | 0x40
"""ZIP flag bits of members never read: encrypted, compressed patched data, strong encryption
(zipfile raises RuntimeError or NotImplementedError on them)."""


def read_npz_bounded(path: Path, error: type[MsdBenchError] = MsdBenchError,
                     max_bytes: int = MAX_NPZ_BYTES,
                     only: Collection[str] | None = None) -> dict[str, np.ndarray]:
    """Every member of the archive at ``path`` (or only those named in ``only``: a lab file may
    hold members of types not read here, e.g. overload flags) as an array, under the size bounds.

    Members are native-endian copies (a big-endian ``>f8`` member becomes
    ``float64``), so compiled code can read them as they are.
    """
    path = Path(path)
    try:
        if path.stat().st_size > max_bytes:
            raise error(f"{path}: archive of {path.stat().st_size} bytes exceeds the {max_bytes}-byte limit")
        with zipfile.ZipFile(path) as zf:
            infos = _checked_members(zf, path, error, max_bytes)
            return {info.filename[: -len(".npy")]: _member(zf, info, path, error) for info in infos
                    if only is None or info.filename[: -len(".npy")] in only}
    except MsdBenchError:  # a ValueError too: already the one line, naming the file
        raise
    except _READ_ERRORS as exc:
        raise error(f"{path}: unreadable .npz archive ({type(exc).__name__}: {_first_line(exc)})") from None


def _checked_members(zf: zipfile.ZipFile, path: Path, error: type[MsdBenchError],
                     max_bytes: int) -> list[zipfile.ZipInfo]:
    """The archive's members, refused unless few, uniquely named, plain and small in total."""
    infos = zf.infolist()
    if len(infos) > MAX_NPZ_MEMBERS:
        raise error(f"{path}: {len(infos)} archive members, more than {MAX_NPZ_MEMBERS}")
    names = [i.filename for i in infos]
    if len(set(names)) != len(names) or not all(n.endswith(".npy") and len(n) > 4 for n in names):
        raise error(f"{path}: archive members must be uniquely named .npy arrays, got {names[:8]}")
    for info in infos:
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED) or info.flag_bits & _UNREAD:
            raise error(f"{path}: member {info.filename!r} is encrypted or uses compression method "
                        f"{info.compress_type} (only stored or deflated members are read)")
    total = sum(i.file_size for i in infos)
    if total > max_bytes:
        raise error(f"{path}: members expand to {total} bytes, more than the {max_bytes}-byte limit")
    return infos


def _member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path,
            error: type[MsdBenchError]) -> np.ndarray:
    """One ``.npy`` member: its header checked against its stated size before its data is read."""
    with zf.open(info) as fh:
        shape, fortran, dtype = _header(fh)
        what = f"{path}: member {info.filename!r}"
        if dtype.kind not in DTYPE_KINDS or dtype.fields is not None or dtype.subdtype is not None:
            raise error(f"{what} has dtype {dtype.str}; only float and string arrays are read")
        if any(n < 0 for n in shape):
            raise error(f"{what} has a negative dimension in shape {shape}")
        count = 1
        for n in shape:
            count *= n
        nbytes = count * dtype.itemsize
        if nbytes > info.file_size:
            raise error(f"{what} declares shape {shape} of {dtype.str} ({nbytes} bytes), more than "
                        f"the member's {info.file_size} bytes")
        data = fh.read(nbytes + 1)  # one more: a member longer than its header says is refused
    if len(data) != nbytes:
        raise error(f"{what} holds {len(data)} data bytes, its header says {nbytes}")
    flat = np.frombuffer(data, dtype=dtype, count=count)
    array = flat.reshape(shape[::-1]).T if fortran else flat.reshape(shape)
    return array.astype(dtype.newbyteorder("="), order="C")  # a copy: the bytes are freed


def _header(fh: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype]:
    """A ``.npy`` header (versions 1.0 and 2.0); numpy raises ValueError on anything malformed."""
    version = npy_format.read_magic(fh)
    with warnings.catch_warnings():  # a header written by Python 2 warns and still parses
        warnings.simplefilter("ignore", UserWarning)
        if version == (1, 0):
            return npy_format.read_array_header_1_0(fh)
        if version == (2, 0):
            return npy_format.read_array_header_2_0(fh)
    raise ValueError(f".npy format version {version} is not read (1.0 and 2.0 are)")


def _first_line(exc: BaseException) -> str:
    """An exception's message cut to one short line (numpy's header errors span several)."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return text if len(text) <= 200 else text[:200] + "..."
