"""Task functions for the executor tests: module-level, so spawned and Ray workers import them by name."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

from msd_bench.core.errors import ConfigError


def square(x: int) -> dict[str, object]:
    """A result and the thread setting the worker ran with."""
    return {"x": x, "square": x * x, "omp": os.environ.get("OMP_NUM_THREADS")}


def die_first(marker: str, x: int) -> int:
    """Kill its own worker on the first attempt (the marker file says whether it was tried)."""
    p = Path(marker)
    if not p.exists():
        p.write_text("tried")
        os.kill(os.getpid(), signal.SIGKILL)
    return x


def die_always(x: int) -> int:
    """Kill its own worker every time."""
    os.kill(os.getpid(), signal.SIGKILL)
    return x


def refuse(x: int) -> int:
    """Fail with the project's error, as a task given a bad input does."""
    raise ConfigError(f"task input {x} is not allowed")


def wait_for(release: str, x: int) -> int:
    """Block until the release file exists (a sweep is killed while tasks are held here)."""
    while not Path(release).exists():
        time.sleep(0.05)
    return x * 10
