"""Model and Q-table artifacts with a schema version and provenance.

A model artifact is one JSON file (exact: Python writes floats with ``repr``,
so parameters round-trip bit-for-bit); a Q-table artifact is an ``.npz`` with
its metadata as a JSON string inside. Both record where they came from: the
bags and their content hashes, the parameters and the seed, so any result can
be traced back to the data that produced it.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import io
import json
import logging
import math
import platform
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from msd_bench._version import __version__
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.layouts import KERNEL_LAYOUTS
from msd_bench.core.physics.model import StepModel
from msd_bench.core.physics.plant import DT
from msd_bench.io.storage.atomic import write_bytes_atomic
from msd_bench.io.storage.safe_npz import read_npz_bounded
from msd_bench.io.storage.safe_read import loads_bounded, read_json_bounded

_log = logging.getLogger(__name__)

MODEL_SCHEMA = "msd-bench/model"
DEFAULT_UNITS = {"input": "N", "output": "m"}
"""Units a model file states when its maker did not say (the emulated plant's)."""
QTABLE_SCHEMA = "msd-bench/qtable"
POLICY_SCHEMA = "msd-bench/policy"
SCHEMA_VERSION = 1


class ArtifactError(MsdBenchError):
    """An artifact is missing, unreadable, of another schema or another version."""


@dataclass(frozen=True)
class Provenance:
    """Where an artifact came from."""

    sources: tuple[dict[str, str], ...] = ()
    """Input files (bags, models) as ``{"path": ..., "sha256": ...}``."""
    parameters: dict[str, Any] = field(default_factory=dict)
    """Every configuration value that shaped the artifact."""
    seed: int | None = None
    """Random seed, if any."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, stamped with the tool version, Python and the time of writing."""
        return {
            "sources": list(self.sources),
            "parameters": jsonable(self.parameters),
            "seed": self.seed,
            "msd_bench_version": __version__,
            "python": platform.python_version(),
            "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        }


def sha256_path(path: Path) -> str:
    """Content hash of a file, or of every file under a directory (a rosbag2 bag)."""
    path = Path(path)
    if not path.exists():
        raise ArtifactError(f"{path}: no such file or directory to hash")
    digest = hashlib.sha256()
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    for f in files:
        digest.update(f.relative_to(path).as_posix().encode() if path.is_dir() else b"")
        with f.open("rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()


def source(path: Path) -> dict[str, str]:
    """A provenance entry for an input file or bag."""
    return {"path": str(path), "sha256": sha256_path(path)}


def save_model(model: StepModel, path: Path, provenance: Provenance, *, root: Path | None = None,
               overwrite: bool = False) -> Path:
    """Write ``model`` as a JSON artifact, atomically; refuses to overwrite unless ``overwrite``.

    ``root`` is the output directory the write must stay inside (no symlink
    below it is followed); ``overwrite`` is for a run directory that vouches
    the file is its own (a resumed task).
    """
    path = Path(path)
    doc = {
        "schema": MODEL_SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "name": model.name,
        "kind": kernels.KIND_NAMES[model.kind],
        "params": [float(v) for v in model.params],
        "dt": float(model.dt),
        "force_limit": float(model.force_limit),
        "stroke": 2 * model.x_max,
        "units": jsonable(model.info.get("units", DEFAULT_UNITS)),
        "info": jsonable(model.info),
        "provenance": provenance.as_dict(),
    }
    return _fresh(path, (json.dumps(doc, indent=1) + "\n").encode(), root, overwrite)


def load_model(path: Path) -> StepModel:
    """Read a model artifact written by :func:`save_model`, trusting nothing in it.

    Every field is type-checked and the parameter vector is checked against
    its kind's layout (:data:`msd_bench.core.physics.layouts.KERNEL_LAYOUTS`) before
    a kernel sees it: a crafted file is a one-line ArtifactError, never a
    crash of the compiled step.
    """
    path = Path(path)
    doc = _read_json(path, MODEL_SCHEMA)
    kinds = {v: k for k, v in kernels.KIND_NAMES.items()}
    kind = doc.get("kind")
    if not isinstance(kind, str) or kind not in kinds:
        raise ArtifactError(f"{path}: unknown model kind {_short(kind)}; known: {', '.join(kinds)}")
    params = _model_params(doc.get("params"), kind, path)
    name, info = doc.get("name"), doc.get("info", {})
    if not isinstance(name, str) or not isinstance(info, dict):
        raise ArtifactError(f"{path}: malformed model artifact (name must be a string, info an object)")
    limits = {k: _number(doc[k], k, path) for k in ("dt", "force_limit") if k in doc}  # older: defaults
    try:
        model = StepModel(kinds[kind], params, name, info, **limits)
    except MsdBenchError as exc:
        raise ArtifactError(f"{path}: {exc}") from None
    if "dt" not in limits:  # only for a model that loads: a refused file is its one error line
        _log.warning("%s: no sample time recorded (an older model file); loading it at dt %g s", path, DT)
    return model


def _model_params(value: Any, kind: str, path: Path) -> np.ndarray:
    """The ``params`` list as float64, refused before conversion if longer than its layout allows."""
    most = KERNEL_LAYOUTS[kind].max_size
    if not isinstance(value, list) or len(value) > most:
        got = f"{len(value)} values" if isinstance(value, list) else _short(value)
        raise ArtifactError(f"{path}: params must be a list of at most {most} numbers for kind {kind}, "
                            f"got {got}")
    return np.array([_number(v, f"params[{i}]", path) for i, v in enumerate(value)], dtype=np.float64)


def _number(value: Any, what: str, path: Path) -> float:
    """A JSON number as a float (a bool, a string or an int beyond float range is refused)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArtifactError(f"{path}: {what} must be a number, got {_short(value)}")
    try:
        return float(value)
    except OverflowError:
        raise ArtifactError(f"{path}: {what} is beyond the float range") from None


def _short(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut short, so a crafted value cannot make the error line megabytes long."""
    text = repr(value) if not isinstance(value, list | dict) or len(value) < 50 else type(value).__name__
    return text if len(text) <= limit else text[:limit] + "..."


def save_qtables(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any], *,
                 root: Path | None = None, overwrite: bool = False) -> Path:
    """Write Q-tables (and snapshots) as ``.npz`` with JSON metadata, atomically (keywords as
    :func:`save_model`); refuses to overwrite unless ``overwrite``."""
    doc = {"schema": QTABLE_SCHEMA, "schema_version": SCHEMA_VERSION, **jsonable(meta)}
    payload: dict[str, Any] = {"meta": np.array(json.dumps(doc)), **arrays}
    buf = io.BytesIO()
    np.savez_compressed(buf, **payload)
    return _fresh(Path(path), buf.getvalue(), root, overwrite)


def load_qtables(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a Q-table artifact: its arrays and its metadata, every size bounded.

    The archive is read by :func:`msd_bench.io.storage.safe_npz.read_npz_bounded`
    (uncompressed sizes checked before anything is decompressed or allocated),
    its metadata by :func:`msd_bench.io.storage.safe_read.loads_bounded`; every other
    member must be a 3-D table stack (tables x states x actions) of finite
    float64 values.
    """
    path = Path(path)
    if not path.is_file():
        raise ArtifactError(f"{path}: no such Q-table artifact")
    members = read_npz_bounded(path, ArtifactError)
    text = members.pop("meta", None)
    if text is None or text.dtype.kind != "U" or text.shape != ():
        raise ArtifactError(f"{path}: Q-table artifact has no metadata string (member meta)")
    meta = loads_bounded(str(text), str(path), ArtifactError)
    _check_schema(meta, QTABLE_SCHEMA, path)
    for name, array in members.items():
        if array.dtype != np.float64 or array.ndim != 3 or not np.all(np.isfinite(array)):
            raise ArtifactError(f"{path}: member {name!r} must be a 3-D array of finite float64 "
                                f"(tables x states x actions), got {array.dtype} of shape {array.shape}")
    return members, meta


def policy_doc(kind: str, facts: Any, members: Any, provenance: dict[str, Any], files: dict[str, str],
               body: dict[str, Any] | None = None) -> dict[str, Any]:
    """``policy.json``: which kind and design, its facts and members, the design's own files beside it
    (by role) and its body (what a design without files needs to be checked on loading)."""
    return {"schema": POLICY_SCHEMA, "schema_version": SCHEMA_VERSION, "kind": kind,
            "design": facts.design, "facts": jsonable(dataclasses.asdict(facts)),
            "members": [int(m) for m in members], "files": dict(files), "body": jsonable(body or {}),
            "provenance": jsonable(provenance)}


def save_policy(path: Path, doc: dict[str, Any], *, root: Path | None = None,
                overwrite: bool = False) -> Path:
    """Write a ``policy.json`` atomically (keywords as :func:`save_model`)."""
    return _fresh(Path(path), (json.dumps(jsonable(doc), indent=1) + "\n").encode(), root, overwrite)


def load_policy(path: Path) -> dict[str, Any]:
    """Read a ``policy.json``: schema, version, kind, design, facts, members and files, every one
    type-checked (a one-line ArtifactError naming the field otherwise); the design reads the rest."""
    path = Path(path)
    doc = _read_json(path, POLICY_SCHEMA)
    for key, kind in (("kind", str), ("design", str), ("facts", dict), ("files", dict), ("body", dict)):
        if not isinstance(doc.get(key), kind):
            raise ArtifactError(f"{path}: policy field {key!r} must be a {kind.__name__}")
    policy_members(doc, path)
    policy_real(doc, path)
    for role, name in doc["files"].items():
        if not isinstance(name, str) or not name or "/" in name or "\\" in name or name.startswith("."):
            raise ArtifactError(f"{path}: policy file {_short(role)} must be a plain file name, "
                                f"got {_short(name)}")
    return doc


def policy_members(doc: dict[str, Any], where: Path) -> tuple[int, ...]:
    """The members' seeds of a policy document (a non-empty list of integers)."""
    members = doc.get("members")
    if not isinstance(members, list) or not members or not all(
            isinstance(m, int) and not isinstance(m, bool) and 0 <= m < 2**63 for m in members):
        raise ArtifactError(f"{where}: policy members must be a non-empty list of integers in [0, 2**63)")
    return tuple(members)


def policy_real(doc: dict[str, Any], where: Path) -> int:
    """Real interactions a policy's facts charge (a non-negative integer)."""
    real = doc.get("facts", {}).get("real_interactions")
    if not isinstance(real, int) or isinstance(real, bool) or real < 0:
        raise ArtifactError(f"{where}: policy facts real_interactions must be an integer >= 0")
    return real


def policy_file(doc: dict[str, Any], role: str, where: Path) -> str:
    """The design file of ``role`` (e.g. ``tables``) named by a policy document."""
    name = doc.get("files", {}).get(role)
    if not isinstance(name, str):
        raise ArtifactError(f"{where}: policy names no {role!r} file")
    return name


def policy_body(doc: dict[str, Any], where: Path, keys: tuple[str, ...]) -> dict[str, Any]:
    """A policy's body, with every key in ``keys`` present."""
    body = doc.get("body")
    missing = [k for k in keys if not isinstance(body, dict) or k not in body]
    if missing:
        raise ArtifactError(f"{where}: policy body lacks {', '.join(missing)}")
    return body  # type: ignore[return-value]


def _read_json(path: Path, schema: str) -> dict[str, Any]:
    if not path.is_file():
        raise ArtifactError(f"{path}: no such artifact")
    doc = read_json_bounded(path, ArtifactError)
    _check_schema(doc, schema, path)
    return doc  # type: ignore[no-any-return]


def _check_schema(doc: Any, schema: str, path: Path) -> None:
    if not isinstance(doc, dict) or doc.get("schema") != schema:
        raise ArtifactError(f"{path}: not a {schema} artifact")
    version = doc.get("schema_version")
    if version != SCHEMA_VERSION or isinstance(version, bool | float):
        raise ArtifactError(f"{path}: schema version {_short(version)} is not {SCHEMA_VERSION}")


def _fresh(path: Path, data: bytes, root: Path | None, overwrite: bool) -> Path:
    """Write ``data`` atomically: a new file only (``os.link``, no clobbering) unless ``overwrite``."""
    if root is None:
        root = path.parent
    return write_bytes_atomic(path, data, root=root, exclusive=not overwrite, error=ArtifactError)


def jsonable(value: Any) -> Any:
    """Plain JSON types: numpy scalars/arrays to Python, NaN/inf to None, tuples to lists."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Path):
        return str(value)
    return value
