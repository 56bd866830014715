"""Type checks of the fields a run's report stage reads back, shared by every reader of run files.

Why one place: ``bench.py --stages report`` (:mod:`msd_bench.graph.run_files`) and a resumed
``paper`` run (:func:`msd_bench.app.paper_tasks.load_run`) both read per-seed rows that an
earlier process wrote and anyone may have edited; a string where a metric belongs must be one
line naming the file and the field, never a ``ValueError`` from ``float()`` deep in the science.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from msd_bench.core.evaluation.results import METRIC_KEYS


def is_int(value: Any) -> bool:
    """A JSON integer (a bool is not one)."""
    return isinstance(value, int) and not isinstance(value, bool)


def is_number(value: Any) -> bool:
    """A JSON number within float range (an int of 400 digits is not a float)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        float(value)
    except OverflowError:
        return False
    return True


def seed_row(row: Any, what: str, path: Path, error: type[Exception]) -> dict[str, Any]:
    """A per-seed row: integer seeds, metrics as numbers or None, a boolean success; else ``error``."""
    if not isinstance(row, dict):
        raise error(f"{path}: {what} must be an object")
    for key in ("seed", "id_seed"):
        if not is_int(row.get(key)):
            raise error(f"{path}: {what}.{key} must be an integer")
    for key in METRIC_KEYS:
        if key not in row or not (row[key] is None or is_number(row[key])):
            raise error(f"{path}: {what}.{key} must be a number or null")
    if not is_number(row["sse"]) or not is_number(row["mae"]):
        raise error(f"{path}: {what}: sse and mae must be numbers")
    if not isinstance(row.get("success"), bool):
        raise error(f"{path}: {what}.success must be true or false")
    return row
