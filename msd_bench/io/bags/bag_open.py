"""Opening a bag for reading: every check before rosbags, every library failure one BagError line.

Why a module of its own: the readers of :mod:`.bags` and :mod:`.bag_interface`
all open bags here. Before rosbags sees a bag, its path must be a bag (not a
dangling symlink, not a directory named ``x.mcap``, not a FIFO), its
``metadata.yaml`` must pass :func:`.bag_meta.read_metadata`, and the files it
names must be regular files. rosbags then reads every MCAP file through
:class:`.mcap_guard.BoundedFile` after :func:`.mcap_guard.check_chunks`, so no
length or size in the file can allocate beyond its bound; what rosbags and its
decoders still raise on a damaged file (:data:`READ_ERRORS`) becomes one line.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from types import MappingProxyType
from typing import Any, BinaryIO, cast

from rosbags.rosbag2 import Reader, ReaderError
from rosbags.rosbag2.reader import DirectoryReader
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader
from rosbags.serde import SerdeError
from rosbags.typesys.base import TypesysError

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_meta import BagMetadata, read_metadata
from msd_bench.io.bags.mcap_guard import BoundedFile, check_chunks

READ_ERRORS = (ReaderError, SerdeError, TypesysError, OSError, EOFError, struct.error, KeyError, IndexError,
               ValueError, TypeError)
"""What rosbags raises on a damaged bag (besides ``ReaderError``: ``struct.error`` and ``TypeError``
from ``ord()`` of a short read in its MCAP parser, ``KeyError`` for an unknown schema encoding,
``SerdeError`` for a message cut short, ``TypesysError`` for a malformed message definition,
``ValueError`` for bad UTF-8 and for :class:`~.mcap_guard.McapBoundError`): each becomes the one-line
BagError naming the bag."""

BAG_SUFFIXES = (".mcap", ".db3")
"""Single-file bags rosbags reads without a directory."""


def missing_metadata(path: Path) -> BagError:
    """The one line for a bag directory without ``metadata.yaml`` (a killed recording)."""
    return BagError(
        f"bag {path} has no metadata.yaml: an interrupted recording? "
        f"try `msd-bench bag recover {path}`"
    )


class _BoundedMcapReader(McapReader):
    """rosbags' MCAP storage reading through :class:`BoundedFile`, after :func:`check_chunks`."""

    def open(self) -> None:
        bio = BoundedFile(Path(str(self.path)))
        self.bio = cast(BinaryIO, bio)
        opened = False
        try:
            check_chunks(bio)
            self._open()
            opened = True
        finally:
            if not opened:
                self.close()


_PLUGINS: Mapping[str, Any] = MappingProxyType({"mcap": _BoundedMcapReader, "sqlite3": Sqlite3Reader})


class _DirectoryReader(DirectoryReader):
    STORAGE_PLUGINS = _PLUGINS


class _Reader(Reader):
    STORAGE_PLUGINS = MappingProxyType({"dir": _DirectoryReader, ".mcap": _BoundedMcapReader,
                                        ".db3": Sqlite3Reader})


def check_path(path: Path) -> BagMetadata | None:
    """The bag's checked metadata (None for a single-file bag), or one BagError line on what is wrong."""
    if path.is_symlink() and not path.exists():
        raise BagError(f"bag {path} is a dangling symlink")
    if not path.exists():
        raise BagError(f"bag {path} does not exist")
    if path.is_dir():
        if not (path / "metadata.yaml").exists():
            raise missing_metadata(path)
        meta = read_metadata(path)
        for name in meta.files:
            data_file(path / name)
        mode = meta.compression_mode.lower()
        if mode in ("file", "message"):  # rosbags inflates those with no bound: a bomb fills the disk
            raise BagError(f"bag {path} is compressed by {mode}: convert it to an uncompressed bag first "
                           f"(`ros2 bag convert`); chunk-compressed MCAP bags are read as they are")
        return meta
    data_file(path)
    if path.suffix not in BAG_SUFFIXES:
        raise BagError(f"bag {path}: not a bag directory nor a {' or '.join(BAG_SUFFIXES)} file")
    return None


def data_file(path: Path) -> Path:
    """``path`` if it is a regular file; one BagError line if it is a dangling link, a directory, a FIFO."""
    if path.is_symlink() and not path.exists():
        raise BagError(f"bag file {path} is a dangling symlink")
    if not path.exists():
        raise BagError(f"bag file {path} does not exist")
    if path.is_dir():
        raise BagError(f"bag file {path} is a directory, not a bag file")
    if not path.is_file():
        raise BagError(f"bag file {path} is not a regular file")
    return path


@contextmanager
def open_bag(path: str | Path) -> Iterator[Reader]:
    """A rosbags reader whose every failure becomes one :class:`BagError` line naming the bag."""
    path = Path(path)
    check_path(path)
    try:
        with _Reader(path) as reader:
            yield reader
    except MsdBenchError:
        raise
    except READ_ERRORS as exc:
        text = " ".join(str(exc).split())[:300] or type(exc).__name__
        raise BagError(f"bag {path} is truncated or corrupt: {text}") from None
