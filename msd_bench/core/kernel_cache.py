"""The project's compiled kernels: numba's ``njit`` with its on-disk cache, compiled once across processes.

Why a decorator of our own rather than ``numba.njit(cache=True)`` at each kernel: numba compiles a
kernel in every process that calls it before any of them has written the cache. Where several
processes start together on cold caches (a fresh clone's parallel test run, whose workers each
start node processes; a sweep's first tasks on two workers) each kernel was compiled several times
over on the same cores. Here a file lock beside the kernel's cache index makes a second process
wait for the first one's compile, after which numba's own compile finds the overload in the cache
and loads it instead of compiling (``Dispatcher.compile`` looks in the cache first). What it saves is
measured by benchmarks/cold_compile.py (docs/testing.md §Workers).

The lock is taken per kernel, only in ``Dispatcher.compile`` (called once per new signature and
process), and only for kernels of this package. Nested compiles (a kernel's callees, compiled while
it is typed) take their locks in call order, so two processes cannot wait on each other. A lock
that cannot be created (a read-only cache directory) leaves the compile unlocked, as numba's is.
The kernel has its lock only while the process lives: a killed process releases it.
``MSD_KERNEL_LOCK=0`` in the environment leaves numba's compile as it is (a file system without
``flock``; benchmarks/cold_compile.py's baseline).
"""

from __future__ import annotations

import fcntl
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar, overload

import numba
from numba.core.dispatcher import Dispatcher

ENV_SWITCH = "MSD_KERNEL_LOCK"
"""``MSD_KERNEL_LOCK=0`` turns the lock off for the processes that inherit it."""
PACKAGE = "msd_bench."
"""Prefix of the modules whose kernels compile under the lock."""

_held_lock = threading.RLock()
"""Held by a thread while it compiles (numba compiles one kernel at a time per process anyway)."""
_held: dict[str, tuple[int, int]] = {}
"""Lock path -> (open descriptor, nesting depth) of the locks this process holds."""
_numba_compile: list[Callable[..., Any]] = []
"""numba's own ``Dispatcher.compile`` once the lock is installed."""


F = TypeVar("F", bound=Callable[..., Any])


@overload
def kernel(func: F, /) -> F: ...


@overload
def kernel(**options: Any) -> Callable[[F], F]: ...


def kernel(func: Callable[..., Any] | None = None, /, **options: Any) -> Any:
    """``@kernel`` or ``@kernel(nogil=True, ...)``: ``numba.njit(cache=True, **options)`` whose
    compile runs in one process at a time (module docstring). Typed as the function it compiles,
    as the checkers read a ``numba.njit`` kernel (numba itself is untyped)."""
    install()
    jit = numba.njit(cache=True, **options)
    return jit if func is None else jit(func)


def lock_path(dispatcher: Any) -> str | None:
    """The lock file beside ``dispatcher``'s cache index; None for a kernel outside this package or
    one numba does not cache (the cache's layout is numba's: read defensively)."""
    if not getattr(dispatcher.py_func, "__module__", "").startswith(PACKAGE):
        return None
    index = getattr(getattr(getattr(dispatcher, "_cache", None), "_cache_file", None), "_index_path", None)
    return None if index is None else f"{index}.lock"


@contextmanager
def compiling(path: str) -> Iterator[None]:
    """Hold the lock at ``path`` across processes while the block runs; re-entered by a nested compile
    of the same kernel (another signature) without waiting on itself."""
    with _held_lock:
        fd, depth = _held.get(path, (-1, 0))
        if depth == 0:
            try:
                fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError:  # an unwritable cache directory: compile as numba would, unlocked
                yield
                return
            fcntl.flock(fd, fcntl.LOCK_EX)
        _held[path] = (fd, depth + 1)
        try:
            yield
        finally:
            if depth == 0:
                del _held[path]
                os.close(fd)  # releases the lock
            else:
                _held[path] = (fd, depth)


def _locked_compile(self: Any, sig: Any) -> Any:
    path = lock_path(self)
    if path is None:
        return _numba_compile[0](self, sig)
    with compiling(path):
        return _numba_compile[0](self, sig)


def install() -> None:
    """Put the lock around numba's ``Dispatcher.compile`` (once per process; idempotent). Why the class:
    numba rebuilds dispatchers (unpickled in a worker process) without any decorator of ours."""
    if os.environ.get(ENV_SWITCH, "1") == "0":
        return
    with _held_lock:
        if not _numba_compile:
            _numba_compile.append(Dispatcher.compile)
            Dispatcher.compile = _locked_compile  # type: ignore[method-assign]
