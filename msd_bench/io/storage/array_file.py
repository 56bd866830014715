"""An input and an output column read from a CSV, NPZ or MAT file, for ``msd-bench identify``.

Why its own reader: most lab records (the Silverbox among them) live in such files, not in
bags; a user names the two signals and the sample time, as MATLAB's ``iddata(y, u, Ts)``
takes them. Every mistake (no such file, an unreadable file, a missing column, a signal that
is not a finite 1-D number series) is one line naming the file and what was wrong.
"""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.storage.safe_npz import read_npz_bounded

FloatArray = NDArray[np.float64]

FORMATS = ("csv", "npz", "mat")
"""The array file formats ``msd-bench identify`` reads."""


class ArrayFileError(MsdBenchError):
    """An array file cannot give the named input and output signals."""


def read_signals(path: Path, fmt: str, u: str, y: str) -> tuple[FloatArray, FloatArray]:
    """The columns ``u`` and ``y`` of the ``fmt`` file at ``path`` as finite float arrays of one length."""
    path = Path(path)
    if not path.is_file():
        raise ArrayFileError(f"{path}: no such file")
    columns = _npz(path, (u, y)) if fmt == "npz" else {"csv": _csv, "mat": _mat}[fmt](path)
    got = tuple(_signal(columns, name, path) for name in (u, y))
    if got[0].size != got[1].size:
        raise ArrayFileError(f"{path}: {u} has {got[0].size} samples but {y} has {got[1].size}")
    return got[0], got[1]


def _signal(columns: dict[str, np.ndarray], name: str, path: Path) -> FloatArray:
    if name not in columns:
        raise ArrayFileError(f"{path}: no column {name!r}; it has {', '.join(sorted(columns)) or 'none'}")
    try:
        x = np.asarray(columns[name], dtype=np.float64)
    except (TypeError, ValueError):
        raise ArrayFileError(f"{path}: column {name!r} is not numbers") from None
    x = x.reshape(-1) if x.ndim == 2 and 1 in x.shape else x  # MATLAB stores vectors as 1 x n or n x 1
    if x.ndim != 1:
        raise ArrayFileError(f"{path}: column {name!r} must be one series, got shape {x.shape}")
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise ArrayFileError(f"{path}: column {name!r} has {bad.size} non-finite sample(s), the first at "
                             f"index {bad[0]}")
    return x


def _csv(path: Path) -> dict[str, np.ndarray]:
    """A CSV file with a header row naming its columns."""
    try:
        with path.open(newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ArrayFileError(f"{path}: not a readable CSV file ({exc})") from None
    if len(rows) < 2:
        raise ArrayFileError(f"{path}: a CSV file needs a header row and samples")
    header = [h.strip() for h in rows[0]]
    out: dict[str, list[float]] = {h: [] for h in header}
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ArrayFileError(f"{path}: line {i} has {len(row)} fields, the header {len(header)}")
        for h, cell in zip(header, row, strict=True):
            try:
                out[h].append(float(cell))
            except ValueError:
                raise ArrayFileError(f"{path}: line {i}, column {h!r}: {cell!r} is not a number") from None
    return {h: np.array(v) for h, v in out.items()}


def _npz(path: Path, names: tuple[str, str]) -> dict[str, np.ndarray]:
    """The two named members only (bounded; an unreadable archive is one line)."""
    got = read_npz_bounded(path, ArrayFileError, only=names)
    if len(got) < len(set(names)):
        with zipfile.ZipFile(path) as zf:  # readable: read_npz_bounded has opened it
            have = sorted(n[: -len(".npy")] for n in zf.namelist())
        missing = next(n for n in names if n not in got)
        raise ArrayFileError(f"{path}: no column {missing!r}; it has {', '.join(have)}")
    return got


def _mat(path: Path) -> dict[str, np.ndarray]:
    from scipy.io import loadmat  # only a MAT input needs it

    try:
        doc = loadmat(path)
    except (OSError, ValueError, NotImplementedError, TypeError) as exc:
        raise ArrayFileError(f"{path}: not a readable MAT file ({' '.join(str(exc).split())})") from None
    return {k: v for k, v in doc.items() if not k.startswith("__")}
