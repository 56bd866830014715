"""The supervisor's files: its parameter file (one JSON object of :class:`SupervisorOptions`
fields) and the record bench.py keeps of what it reported.

Both are read bounded (:mod:`msd_bench.io.storage.safe_read`), so a huge or deeply nested file is
one line like any other mistake in it.
"""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.io.storage.artifacts import ArtifactError
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.safe_read import read_json_bounded


def read_options(path: Path) -> SupervisorOptions:
    """The options in ``path``; a file that is not an object of known, numeric fields is one line."""
    value = read_json_bounded(Path(path), ConfigError)
    if not isinstance(value, dict):
        raise ConfigError(f"{path}: supervisor options must be a JSON object, got {type(value).__name__}")
    return SupervisorOptions.from_mapping(value, what=str(path))


def options_json(options: SupervisorOptions, plant: PlantParams) -> str:
    """``options`` as a parameter file with every limit derived from ``plant`` written out.

    Why spelled out: the file is also the run's record of what the supervisor held it to, and a
    reader should not have to re-derive a default from the stroke to know the envelope.
    """
    lim = options.limits(plant)
    full = replace(options, envelope=lim.envelope, margin=lim.margin, v_max=lim.v_max)
    return json.dumps(asdict(full), indent=1) + "\n"


def write_record(path: Path, doc: dict[str, Any], root: Path) -> Path:
    """Write a supervisor record (JSON object) atomically under ``root``."""
    return write_text_atomic(path, json.dumps(doc, indent=1) + "\n", root=root)


def read_record(path: Path) -> dict[str, Any]:
    """A supervisor record written by :func:`write_record`, with every field the report reads checked:
    anything else is one line naming the file and the field (a record is a file like any other)."""
    value = read_json_bounded(Path(path), ArtifactError)
    if not isinstance(value, dict):
        raise ArtifactError(f"{path}: not a supervisor record (expected a JSON object)")
    _each(value, "runs", path, _run)
    totals = value.get("totals")
    if totals is not None:
        _object(totals, "totals", path)
        _counts(totals.get("outside_overrides", {}), "totals.outside_overrides", path)
        for key in ("outside_steps", "estop_latches", "steps", "runs"):
            _count(totals.get(key, 0), f"totals.{key}", path)
    _text(value.get("limits", ""), "limits", path)
    _each(value, "stages", path, _text)
    _by_kind(value.get("by_kind", {}), path)
    return value


def _object(value: Any, what: str, path: Path) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ArtifactError(f"{path}: {what} must be an object")
    return value


def _count(value: Any, what: str, path: Path) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ArtifactError(f"{path}: {what} must be a count (an integer >= 0)")


def _counts(value: Any, what: str, path: Path) -> None:
    for reason, n in _object(value, what, path).items():
        _count(n, f"{what}.{reason}", path)


def _text(value: Any, what: str, path: Path) -> None:
    if not isinstance(value, str):
        raise ArtifactError(f"{path}: {what} must be a string")


def _each(doc: dict[str, Any], key: str, path: Path, check: Any) -> None:
    items = doc.get(key, [])
    if not isinstance(items, list):
        raise ArtifactError(f"{path}: {key} must be a list")
    for i, item in enumerate(items):
        check(item, f"{key}[{i}]", path)


def _run(value: Any, what: str, path: Path) -> None:
    run = _object(value, what, path)
    _counts(run.get("overrides", {}), f"{what}.overrides", path)
    for key in ("overridden", "steps", "samples"):
        _count(run.get(key, 0), f"{what}.{key}", path)
    if run.get("aborted") is not None:
        _text(run["aborted"], f"{what}.aborted", path)


def _by_kind(value: Any, path: Path) -> None:
    by_kind = _object(value, "by_kind", path)
    if not isinstance(by_kind.get("attributed", True), bool):
        raise ArtifactError(f"{path}: by_kind.attributed must be true or false")
    _text(by_kind.get("note", ""), "by_kind.note", path)
    for kind, doc in _object(by_kind.get("kinds", {}), "by_kind.kinds", path).items():
        _each(_object(doc, f"by_kind.kinds.{kind}", path), "aborted", path, _abort)


def _abort(value: Any, what: str, path: Path) -> None:
    abort = _object(value, what, path)
    for key in ("scenario", "reason"):
        _text(abort.get(key), f"{what}.{key}", path)
    if isinstance(abort.get("seed"), bool) or not isinstance(abort.get("seed"), int):
        raise ArtifactError(f"{path}: {what}.seed must be an integer")
