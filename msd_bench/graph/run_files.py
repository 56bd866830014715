"""Readers of the files a run directory holds, for the report stage: trust nothing in them.

Why: ``bench.py --stages report --out <run>`` rebuilds a report from files
that may have been edited, truncated by a full disk, copied from another
version or crafted. Each reader here bounds the document's size and depth
(:mod:`msd_bench.io.storage.safe_read`), checks every field the report uses for type
and range, and turns anything else into one :class:`RunFileError` line naming
the file and the field — before the report's science sees a value.
"""

from __future__ import annotations

import math
import typing
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench.app.agents import learner_from_meta
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.learning.qconfig import QConfig, encoding
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.run_fields import is_int, is_number, seed_row
from msd_bench.io.storage.run_output import FAILED_KEY
from msd_bench.io.storage.safe_read import read_json_bounded


class RunFileError(MsdBenchError):
    """A file of a run directory is corrupt, truncated, oversized or holds a wrong-typed field."""


@dataclass(frozen=True)
class AgentDoc:
    """What the report takes from an agent's ``result.json``."""

    training: str
    """How the agent trained (``in-process``, ``ros``, ``dyna-q over the plant``)."""
    per_seed: list[dict[str, Any]]
    """One row per validated seed: ``seed``, ``id_seed``, the metrics (None = N/A) and ``success``."""
    real_interactions: int
    """Steps taken on the true plant during training."""
    on_node_scenarios: dict[str, dict[str, Any]]
    """Robustness cells measured on a foreign node, by scenario id (empty otherwise)."""


@dataclass(frozen=True)
class QTables:
    """An agent's Q-table artifact, checked against the learner config stored beside it."""

    arrays: dict[str, np.ndarray]
    """``q`` (seeds x states x actions) and the ``first``/``last`` episode snapshots."""
    learner: QConfig
    """The learner config the tables were trained with."""
    seeds: list[int]
    """Validation seeds, one per table of ``q``."""


def read_json_object(path: Path) -> dict[str, Any]:
    """A JSON object from ``path`` under the size and depth bounds."""
    doc = read_json_bounded(path, RunFileError)
    if not isinstance(doc, dict):
        raise RunFileError(f"{path}: expected a JSON object, got {type(doc).__name__}")
    return doc


def read_run_facts(path: Path) -> dict[str, Any]:
    """``run.json`` from an earlier stage of the run: an object whose ``timings`` are numbers."""
    doc = read_json_object(path)
    timings = doc.get("timings", {})
    if not isinstance(timings, dict) or not all(is_number(v) for v in timings.values()):
        raise RunFileError(f"{path}: timings must be an object of stage seconds")
    return doc


def read_result(path: Path) -> AgentDoc:
    """An agent's ``result.json`` with every field the report reads checked."""
    doc = read_json_object(path)
    rows = _field(doc, "per_seed", list, path)
    if not rows:
        raise RunFileError(f"{path}: per_seed is empty (no seed was validated)")
    scenarios = doc.get("on_node_scenarios", {})
    if not isinstance(scenarios, dict):
        raise RunFileError(f"{path}: on_node_scenarios must be an object")
    return AgentDoc(
        training=_field(doc, "training", str, path),
        per_seed=[_seed_row(row, f"per_seed[{i}]", path) for i, row in enumerate(rows)],
        real_interactions=_count(doc.get("real_interactions"), "real_interactions", path),
        on_node_scenarios={str(k): _cell(c, f"on_node_scenarios[{k!r}]", path) for k, c in scenarios.items()},
    )


def read_fits(path: Path) -> dict[str, FitReport]:
    """``fits.json``: a :class:`FitReport` per model name (None, JSON's NaN, read back as NaN)."""
    doc = read_json_object(path)  # the kinds that failed (FAILED_KEY) have no fit
    return {str(name): _fit(value, f"{name!r}", path) for name, value in doc.items() if name != FAILED_KEY}


def read_failed_fits(path: Path) -> dict[str, str]:
    """``fits.json``'s kinds that could not be fitted, with their one-line reasons (none if absent)."""
    failed = read_json_object(path).get(FAILED_KEY, {}) if path.is_file() else {}
    if not isinstance(failed, dict) or not all(isinstance(v, str) for v in failed.values()):
        raise RunFileError(f"{path}: {FAILED_KEY!r} must map model kinds to reasons")
    return {str(k): v for k, v in failed.items()}


def read_qtables(path: Path) -> QTables:
    """An agent's ``qtables.npz``: shapes agree with the stored learner config and seeds."""
    arrays, meta = artifacts.load_qtables(path)
    seeds = meta.get("seeds")
    if not isinstance(seeds, list) or not seeds or not all(is_int(s) and 0 <= s < 2**63 for s in seeds):
        raise RunFileError(f"{path}: meta seeds must be a non-empty list of integers in [0, 2**63)")
    learner = _learner(meta, path)
    missing = [k for k in ("q", "first", "last") if k not in arrays]
    if missing:
        raise RunFileError(f"{path}: Q-table artifact lacks member(s) {', '.join(missing)}")
    table = (encoding(learner).n_states, learner.actions().size)
    if arrays["q"].shape != (len(seeds), *table):
        raise RunFileError(f"{path}: q has shape {arrays['q'].shape}, but {len(seeds)} seed(s) and the "
                           f"learner's {table[0]} states x {table[1]} actions need {(len(seeds), *table)}")
    for k in ("first", "last"):
        if arrays[k].shape[0] < 1 or arrays[k].shape[1:] != table:
            raise RunFileError(f"{path}: {k} has shape {arrays[k].shape}, not (n, {table[0]}, {table[1]})")
    return QTables(arrays, learner, [int(s) for s in seeds])


def _learner(meta: dict[str, Any], path: Path) -> QConfig:
    """The stored learner config, each field typed like :class:`QConfig`'s before it is built."""
    doc = meta.get("learner")
    if not isinstance(doc, dict):
        raise RunFileError(f"{path}: Q-table artifact carries no learner config")
    hints = typing.get_type_hints(QConfig)
    for key, value in doc.items():
        hint = hints.get(key)
        if hint is not None and not _fits_hint(value, hint):
            raise RunFileError(f"{path}: learner field {key!r} has the wrong type ({type(value).__name__})")
    try:
        return learner_from_meta(meta)
    except MsdBenchError as exc:
        raise RunFileError(f"{path}: {exc}") from None


def _fits_hint(value: Any, hint: Any) -> bool:
    """Whether a JSON value can stand for a QConfig field of type ``hint`` (int, float, str, bool,
    or a tuple of floats/ints written as a list)."""
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return is_int(value)
    if hint is float:
        return is_number(value)
    if hint is str:
        return isinstance(value, str)
    item = typing.get_args(hint)[0] if typing.get_origin(hint) is tuple else None
    return isinstance(value, list) and item is not None and all(_fits_hint(v, item) for v in value)


def _fit(value: Any, what: str, path: Path) -> FitReport:
    """One model's fit entry: exactly FitReport's fields, numbers where it has numbers."""
    if not isinstance(value, dict):
        raise RunFileError(f"{path}: fit {what} must be an object")
    hints = typing.get_type_hints(FitReport)
    known = {f.name for f in fields(FitReport)}
    if unknown := sorted(set(value) - known):
        raise RunFileError(f"{path}: fit {what} has unknown field(s) {', '.join(map(repr, unknown[:5]))}")
    out: dict[str, Any] = {}
    for name, v in value.items():
        hint = hints[name]
        if hint is str:
            ok = isinstance(v, str)
        elif hint is int:
            ok = is_int(v)
        else:  # float or float | None: None is how NaN was written
            ok = v is None or is_number(v)
        if not ok:
            raise RunFileError(f"{path}: fit {what} field {name} has the wrong type ({type(v).__name__})")
        if hint not in (str, int):
            v = (math.nan if hint is float else None) if v is None else float(v)
        out[name] = v
    try:
        return FitReport(**out)
    except TypeError:  # a required field is missing
        missing = sorted(f.name for f in fields(FitReport) if f.name not in out)
        raise RunFileError(f"{path}: fit {what} lacks field(s) {', '.join(missing)}") from None


def _seed_row(row: Any, what: str, path: Path) -> dict[str, Any]:
    """A per-seed row (:func:`msd_bench.io.storage.run_fields.seed_row`)."""
    return seed_row(row, what, path, RunFileError)


def _cell(cell: Any, what: str, path: Path) -> dict[str, Any]:
    """A robustness cell: counts 0 <= n_success <= n, a median SSE (None: NaN), SSE and MAE lists."""
    if not isinstance(cell, dict):
        raise RunFileError(f"{path}: {what} must be an object")
    n = _count(cell.get("n"), f"{what}.n", path)
    wins = _count(cell.get("n_success"), f"{what}.n_success", path)
    if wins > n:
        raise RunFileError(f"{path}: {what}: n_success {wins} exceeds n {n}")
    for key in ("median_sse", "median_mae"):
        if not (cell.get(key) is None or is_number(cell.get(key))):
            raise RunFileError(f"{path}: {what}.{key} must be a number or null")
    for key in ("sse", "mae"):
        values = cell.get(key, [])
        if not isinstance(values, list) or not all(v is None or is_number(v) for v in values):
            raise RunFileError(f"{path}: {what}.{key} must be a list of numbers")
    return {**cell, "median_sse": math.nan if cell.get("median_sse") is None else cell["median_sse"]}


def _field(doc: dict[str, Any], key: str, kind: type, path: Path) -> Any:
    value = doc.get(key)
    if not isinstance(value, kind):
        raise RunFileError(f"{path}: {key} must be a {kind.__name__}, got {type(value).__name__}")
    return value


def _count(value: Any, what: str, path: Path) -> int:
    if not is_int(value) or value < 0:
        raise RunFileError(f"{path}: {what} must be a non-negative integer")
    return int(value)
