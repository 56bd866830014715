"""One ROS domain per concurrent bench run, claimed with a lock file.

Why: two runs drawing the same random ``ROS_DOMAIN_ID`` see each other's
plants and recorders. A run holds an exclusive ``flock`` on
``<tmp>/msd-bench-domains/<id>.lock`` for its whole life; the kernel drops
the lock when the process dies, however it dies, so a stale file never
blocks a domain.
"""

from __future__ import annotations

import fcntl
import os
import random
import tempfile
from pathlib import Path
from typing import IO

from msd_bench.core.errors import ConfigError

MAX_DOMAIN_ID = 232
"""Largest ROS_DOMAIN_ID whose DDS ports fit below the Linux ephemeral range."""
AUTO_DOMAINS = range(1, 201)
"""Domains a run picks from when none is given."""


def lock_dir() -> Path:
    """Where the domain locks live (shared by every user of this machine's temp dir)."""
    return Path(tempfile.gettempdir()) / "msd-bench-domains"


_FIX = "set TMPDIR to a directory you can write (the locks live in $TMPDIR/msd-bench-domains)"


def _lock_dir_ready() -> Path:
    """The lock directory, created if needed; one ConfigError line naming it if it cannot be."""
    where = lock_dir()
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"domain-lock directory {where}: cannot create it ({exc.strerror}); "
                          f"{_FIX}") from None
    return where


def _try_lock(domain: int, *, skip_foreign: bool = False) -> IO[str] | None:
    """The locked file of ``domain``, or None if another run holds it.

    A lock file this user cannot open (another user's, or a symlink, which is
    never followed) means the domain is not ours: skipped when ``skip_foreign``
    (a random pick), else one line. A directory where no file can be created is
    one line naming it and what to set.
    """
    path = _lock_dir_ready() / f"{domain}.lock"
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    except OSError as exc:
        if not path.is_symlink() and not path.exists():
            raise ConfigError(f"domain-lock directory {path.parent} is not writable ({exc.strerror}); "
                              f"{_FIX}") from None
        if skip_foreign:
            return None
        raise ConfigError(f"ROS domain {domain}: cannot open its lock file {path} ({exc.strerror}); "
                          f"pick another --domain-id or {_FIX}") from None
    fh = os.fdopen(fd, "a+")
    try:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        fh.close()
        return None
    return fh


def claim_domain(requested: int | None, rng: random.Random | None = None) -> tuple[int, IO[str]]:
    """A domain id no other bench run holds, and the open lock file (keep it open for the run)."""
    if requested is not None and not 0 <= requested <= MAX_DOMAIN_ID:
        raise ConfigError(f"--domain-id must be between 0 and {MAX_DOMAIN_ID}, got {requested}")
    if requested is not None:
        fh = _try_lock(requested)
        if fh is None:
            raise ConfigError(f"ROS domain {requested} is in use by another bench run; "
                              f"pick another --domain-id")
        return requested, fh
    candidates = list(AUTO_DOMAINS)
    (rng or random.SystemRandom()).shuffle(candidates)
    for domain in candidates:
        fh = _try_lock(domain, skip_foreign=True)
        if fh is not None:
            return domain, fh
    raise ConfigError(f"every ROS domain in {AUTO_DOMAINS.start}..{AUTO_DOMAINS.stop - 1} "
                      f"is in use by a bench run")
