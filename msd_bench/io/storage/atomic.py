"""Atomic, symlink-safe writes: a crash leaves the old file or the new one, never half of one.

Every result, model, table, report and run file goes through :func:`write_with`:
the bytes go to a temporary file created with ``O_CREAT | O_EXCL | O_NOFOLLOW``
in the target's own directory, are flushed and fsynced, and the temporary file
is renamed over the target (``os.replace``; ``os.link`` when the target must
not exist yet, which fails instead of clobbering). A reader therefore sees the
old file or the complete new one, and a file a rerun finds is never truncated.

Why the directory walk: a run directory may come from elsewhere (a received
run whose ``report/table1.md`` is a symlink to a file outside). The root a
caller names is resolved once; every component below it is opened relative to
its parent with ``O_NOFOLLOW``, so a symlink at the target or in any directory
under the root is refused with one line instead of being written through.

A process killed between the write and the rename leaves a temporary file named
``.msd-tmp-<name>.<random>``: never the target's name, so it blocks nothing, and
:func:`remove_stale_temps` (called when a run directory is opened) sweeps it.
"""

from __future__ import annotations

import errno
import io
import os
import secrets
import stat
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.storage.paths import OutputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

TEMP_PREFIX = ".msd-tmp-"
"""Start of every temporary file name; nothing else the tools write starts so."""

Writer = Callable[[IO[bytes]], None]
"""Writes a file's content into the open binary temporary file."""


def _why(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _split(path: Path, root: Path | None) -> tuple[Path, tuple[str, ...]]:
    """The resolved root and the components below it (the last one is the file name)."""
    path = Path(os.path.abspath(path))
    if root is None:
        root = path.parent
    given = Path(os.path.abspath(root))
    try:
        rel = path.relative_to(given)
    except ValueError:
        raise OutputError(f"{path}: outside the output directory {given}; refusing to write") from None
    if not rel.parts:
        raise OutputError(f"{path}: is the output directory itself, not a file in it")
    try:
        given.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{given}: cannot create the output directory ({_why(exc)})") from None
    return Path(os.path.realpath(given)), rel.parts


def _kind(name: str, dir_fd: int) -> int | None:
    """``st_mode`` of ``name`` in ``dir_fd`` without following a symlink (None if absent)."""
    try:
        return os.stat(name, dir_fd=dir_fd, follow_symlinks=False).st_mode
    except FileNotFoundError:
        return None


@contextmanager
def _open_dir(root: Path, parts: tuple[str, ...], shown: Path) -> Iterator[int]:
    """A descriptor of the directory ``root/parts`` (created as needed), no symlink followed."""
    fd = os.open(root, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        for part in parts:
            mode = _kind(part, fd)
            if mode is None:
                with suppress(FileExistsError):  # a concurrent writer made it: checked below like any other
                    os.mkdir(part, 0o777, dir_fd=fd)
                mode = _kind(part, fd)
            if mode is not None and stat.S_ISLNK(mode):
                raise OutputError(f"{shown}: {part} is a symlink inside the output directory; refusing "
                                  f"to write through it")
            try:
                child = os.open(part, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC, dir_fd=fd)
            except OSError as exc:
                why = "not a directory" if exc.errno in (errno.ENOTDIR, errno.ELOOP) else _why(exc)
                raise OutputError(f"{shown}: cannot use {part} as a directory ({why})") from None
            os.close(fd)
            fd = child
        yield fd
    finally:
        os.close(fd)


def write_with(path: Path, writer: Writer, *, root: Path | None = None, exclusive: bool = False,
               error: type[MsdBenchError] = OutputError) -> Path:
    """Write ``path`` atomically with ``writer``; returns ``path``.

    ``root`` is the output directory the write must stay in (default: the
    file's own directory); ``exclusive`` refuses an existing target (raised as
    ``error``) instead of replacing it. Raises :class:`OutputError` on a
    symlink, a directory at the target, or an OS error.
    """
    path = Path(path)
    real_root, parts = _split(path, root)
    name = parts[-1]
    try:
        with _open_dir(real_root, parts[:-1], path) as dir_fd:
            _check_target(path, name, dir_fd, exclusive, error)
            _write_and_rename(name, writer, dir_fd, exclusive)
    except FileExistsError:
        raise error(f"{path}: already exists; refusing to overwrite") from None
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({_why(exc)})") from None
    return path


def _check_target(path: Path, name: str, dir_fd: int, exclusive: bool, error: type[MsdBenchError]) -> None:
    mode = _kind(name, dir_fd)
    if mode is None:
        return
    if stat.S_ISLNK(mode):
        raise OutputError(f"{path}: is a symlink; refusing to write through it")
    if not stat.S_ISREG(mode):
        raise OutputError(f"{path}: exists and is not a regular file")
    if exclusive:
        raise error(f"{path}: already exists; refusing to overwrite")


def _write_and_rename(name: str, writer: Writer, dir_fd: int, exclusive: bool) -> None:
    """Temporary file, fsync, rename; the temporary file never outlives a failure in this process."""
    tmp = f"{TEMP_PREFIX}{name}.{secrets.token_hex(4)}"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644,
                 dir_fd=dir_fd)
    try:
        with os.fdopen(fd, "wb") as fh:
            writer(fh)
            fh.flush()
            os.fsync(fh.fileno())
        if exclusive:
            _link_new(tmp, name, dir_fd)
        else:
            os.replace(tmp, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
    except BaseException:
        with suppress(FileNotFoundError):
            os.unlink(tmp, dir_fd=dir_fd)
        raise
    os.fsync(dir_fd)


def _link_new(tmp: str, name: str, dir_fd: int) -> None:
    """Give the finished temporary file the target's name only if that name is free.

    ``os.link`` fails on an existing name, so no concurrent writer is clobbered;
    a file system without hard links gets a checked rename instead.
    """
    try:
        os.link(tmp, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd, follow_symlinks=False)
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK):
            raise
        if _kind(name, dir_fd) is not None:
            raise FileExistsError(errno.EEXIST, "File exists") from None
        os.replace(tmp, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
        return
    os.unlink(tmp, dir_fd=dir_fd)


def write_bytes_atomic(path: Path, data: bytes, **kw: Any) -> Path:
    """Write ``data`` to ``path`` atomically (keywords as :func:`write_with`)."""
    def write(fh: IO[bytes]) -> None:
        fh.write(data)

    return write_with(path, write, **kw)


def write_text_atomic(path: Path, text: str, **kw: Any) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (keywords as :func:`write_with`)."""
    return write_bytes_atomic(path, text.encode("utf-8"), **kw)


def save_figure_atomic(fig: Figure, path: Path, dpi: int = 90, **kw: Any) -> Path:
    """``fig.savefig`` as a PNG, atomically (keywords as :func:`write_with`)."""
    return write_with(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi), **kw)


def savez_atomic(path: Path, arrays: Mapping[str, Any], **kw: Any) -> Path:
    """``np.savez_compressed`` of ``arrays`` into ``path``, atomically (keywords as :func:`write_with`)."""
    import numpy as np

    def write(fh: IO[bytes]) -> None:
        buf = io.BytesIO()  # zipfile seeks back to write its directory: build it whole, then write once
        np.savez_compressed(buf, **arrays)
        fh.write(buf.getbuffer())

    return write_with(path, write, **kw)


def remove_stale_temps(root: Path) -> int:
    """Delete the temporary files a killed writer left under ``root`` (only names of ours); their count."""
    count = 0
    for dirpath, _dirs, files in os.walk(root, followlinks=False):
        for f in files:
            if f.startswith(TEMP_PREFIX):
                try:
                    Path(dirpath, f).unlink(missing_ok=True)
                except OSError as exc:
                    raise OutputError(f"{Path(dirpath, f)}: cannot remove this stale temporary file "
                                      f"({_why(exc)})") from None
                count += 1
    return count


__all__ = ["TEMP_PREFIX", "remove_stale_temps", "save_figure_atomic", "savez_atomic", "write_bytes_atomic",
           "write_text_atomic", "write_with"]
