"""Progress display for long runs: one tqdm bar over stages, on stderr.

tqdm is used because it degrades sensibly when stderr is not a terminal (CI
logs get a line per update instead of carriage-return noise).
"""

from __future__ import annotations

import sys
import time
from types import TracebackType

from tqdm import tqdm


class StageProgress:
    """A bar whose total is learned from the first update; the description is the stage."""

    def __init__(self, name: str, total: int | None = None) -> None:
        self._name = name
        self._bar: tqdm | None = None
        self._total = total
        self._t0 = time.perf_counter()

    def __enter__(self) -> StageProgress:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._bar is not None:
            self._bar.close()

    def update(self, stage: str, done: int, total: int) -> None:
        """Show ``stage`` with ``done`` of ``total`` steps complete."""
        if self._bar is None:
            self._bar = tqdm(total=total, desc=self._name, file=sys.stderr, unit="stage",
                             dynamic_ncols=True, mininterval=0.5)
        self._bar.set_postfix_str(stage, refresh=False)
        self._bar.update(done - self._bar.n)

    def say(self, line: str) -> None:
        """Print a line above the bar (a resumed sweep's count, a retried task)."""
        tqdm.write(line, file=sys.stderr)

    def elapsed(self) -> float:
        """Seconds since the bar was created."""
        return time.perf_counter() - self._t0
