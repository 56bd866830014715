"""Output directories proven writable before any work is done, with one-line errors.

Why: the identifier fits for tens of seconds and bench.py runs for minutes
before the first file is written; a read-only disk or an ``--out`` under a
file must be reported at once, as one line, not as a traceback at the end.
"""

from __future__ import annotations

from pathlib import Path

from msd_bench.core.errors import MsdBenchError


class OutputError(MsdBenchError):
    """An output directory cannot be created or written."""


def writable_dir(path: str | Path, label: str) -> Path:
    """Create ``path`` (and parents) and write-probe it; ``label`` names the option in the error."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-probe"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise OutputError(f"{label} {path}: cannot write there ({exc.strerror or exc})") from None
    return path
