"""Reading one rig's task result back (``<out>/rigs/rig-<seed>.json``) before it is pooled.

Why a checked reader: a resumed sweep pools files an earlier process wrote,
and a run directory may have been received or edited. The run directory
proves a file is the size it was written at, not that it holds what the report
indexes; so every field :func:`msd_bench.app.rigs.document`, ``rigs.md`` and
the figure read is checked here, and anything else is one line naming the
file and the field (:class:`~msd_bench.io.storage.run_dir.RunDirError`), never a
``KeyError`` from deep inside the report.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from msd_bench.io.rigs.rigs_report import OWN_PLANT, PARAMETERS
from msd_bench.io.storage.run_dir import RunDirError
from msd_bench.io.storage.safe_read import read_json_bounded


def _fail(path: Path, where: str, what: str) -> RunDirError:
    return RunDirError(f"{path}: {where} {what}")


def _number(path: Path, where: str, value: Any, nullable: bool = False) -> None:
    if value is None and nullable:
        return
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(path, where, f"must be a finite number, got {type(value).__name__}")


def _mapping(path: Path, where: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise _fail(path, where, f"must be an object, got {type(value).__name__}")
    return value


def _flag(path: Path, where: str, value: Any) -> None:
    if not isinstance(value, bool):
        raise _fail(path, where, f"must be true or false, got {type(value).__name__}")


def check_outcome(path: Path, i: int, row: Any, kinds: Sequence[str], scenarios: Sequence[str]) -> None:
    """One (kind, seed) outcome: what the pooled statistics and the tables read."""
    where = f"outcomes[{i}]"
    row = _mapping(path, where, row)
    if row.get("kind") not in kinds:
        raise _fail(path, f"{where}.kind", f"must be one of the run's kinds ({', '.join(kinds)})")
    if isinstance(row.get("seed"), bool) or not isinstance(row.get("seed"), int):
        raise _fail(path, f"{where}.seed", "must be a whole number")
    _flag(path, f"{where}.success", row.get("success"))
    _flag(path, f"{where}.identified", row.get("identified"))
    if not row["identified"] or isinstance(row.get("design_failed"), str):
        return  # no surrogate, or its design could not be made on it: a failure with no run
    _flag(path, f"{where}.success_measured", row.get("success_measured"))
    _number(path, f"{where}.start_x", row.get("start_x"))
    cells = _mapping(path, f"{where}.scenarios", row.get("scenarios"))
    if sorted(cells) != sorted(scenarios):
        raise _fail(path, f"{where}.scenarios", "must hold exactly the run's rig scenarios")
    for sid in scenarios:
        _flag(path, f"{where}.scenarios[{sid!r}].success", _mapping(path, where, cells[sid]).get("success"))


def check_part(path: Path, doc: Any, seed: int, kinds: Sequence[str],
               scenarios: Sequence[str]) -> dict[str, Any]:
    """``doc`` if it is rig ``seed``'s result as :func:`msd_bench.app.rigs.rig_task` writes it."""
    part: dict[str, Any] = dict(_mapping(path, "the document", doc))
    if part.get("rig") != seed or isinstance(part.get("rig"), bool):
        raise _fail(path, "rig", f"must be {seed}, the rig of this task")
    params = _mapping(path, "parameters", part.get("parameters"))
    for name in (*PARAMETERS, *(OWN_PLANT if "stroke" in params else ())):
        _number(path, f"parameters.{name}", params.get(name))
    failed = _mapping(path, "identification_failed", part.get("identification_failed"))
    if not all(isinstance(v, str) for v in failed.values()):
        raise _fail(path, "identification_failed", "must map model kinds to reasons")
    _number(path, "seconds.total", _mapping(path, "seconds", part.get("seconds")).get("total"))
    rows = part.get("outcomes")
    if not isinstance(rows, list) or not rows:
        raise _fail(path, "outcomes", "must be a non-empty list")
    for i, row in enumerate(rows):
        check_outcome(path, i, row, kinds, scenarios)
    missing = [k for k in kinds if k not in {row["kind"] for row in rows}]
    if missing:
        raise _fail(path, "outcomes", f"hold no run of {', '.join(missing)}")
    return part


def read_part(path: Path, seed: int, kinds: Sequence[str], scenarios: Sequence[str]) -> dict[str, Any]:
    """Rig ``seed``'s task result from ``path``: bounded JSON, every field the report reads checked."""
    return check_part(path, read_json_bounded(path, RunDirError), seed, kinds, scenarios)
