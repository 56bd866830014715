"""Reading a rig description from a ROS 2 parameter file (docs/rig-description.md).

The file is the one a ROS 2 user already writes for ``--ros-args --params-file``:
a node section holding ``ros__parameters``. Which section is read: ``/**``
(every node) when present, else the one node section when there is exactly one;
two node sections without ``/**`` are refused, because which node's values
describe the rig would be a guess. Parsing the values is the core's
(:func:`msd_bench.core.rigs.description.parse_description`); this module only
reads the file, bounded, and names it in every error.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from msd_bench.core.errors import ConfigError
from msd_bench.core.rigs.description import RigDescription, parse_description
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.paths import writable_dir

MAX_BYTES = 256 * 1024
"""Largest rig file read: a description is a few hundred bytes."""

_Loader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_rig(path: str | Path) -> RigDescription:
    """The description in ``path``; a one-line ConfigError naming the file otherwise."""
    path = Path(path)
    return parse_description(rig_parameters(path), str(path))


def rig_parameters(path: Path) -> dict[str, Any]:
    """The ``ros__parameters`` mapping of the section that describes the rig."""
    try:
        with path.open("rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"rig file {path}: cannot read it ({exc.strerror or exc})") from None
    if len(raw) > MAX_BYTES:
        raise ConfigError(f"rig file {path}: larger than {MAX_BYTES} bytes, not a rig description")
    try:
        document = yaml.load(raw, Loader=_Loader)  # a safe loader (_Loader)
    except yaml.YAMLError as exc:
        line = getattr(getattr(exc, "problem_mark", None), "line", None)
        where = f" (line {line + 1})" if line is not None else ""
        raise ConfigError(f"rig file {path}: not valid YAML{where}") from None
    return _section(document, path)


def _section(document: object, path: Path) -> dict[str, Any]:
    """``/**`` if present, else the only node section; its ``ros__parameters``."""
    if not isinstance(document, dict) or not document:
        raise ConfigError(f"rig file {path}: expected '/**: ros__parameters:' at the top")
    if "/**" in document:
        name = "/**"
    elif len(document) == 1 and str(next(iter(document))).startswith("/"):
        name = str(next(iter(document)))
    elif len(document) == 1:
        raise ConfigError(f"rig file {path}: expected '/**: ros__parameters:' at the top")
    else:
        raise ConfigError(f"rig file {path}: several node sections and no '/**' "
                          f"({', '.join(map(str, document))}); put the rig under '/**'")
    section = document.get(name)
    params = section.get("ros__parameters") if isinstance(section, dict) else None
    if not isinstance(params, dict):
        raise ConfigError(f"rig file {path}: section {name!r} has no 'ros__parameters' mapping")
    return {str(key): value for key, value in params.items()}


def probe_new_rig(path: Path) -> None:
    """Before anything is measured: ``path`` must not exist (a description is never overwritten)
    and its directory must be writable; one-line ConfigError otherwise."""
    if os.path.lexists(path):
        raise ConfigError(f"--write-rig {path}: already exists; refusing to overwrite it (name a new file)")
    writable_dir(path.parent.absolute(), "--write-rig directory")


def write_rig(path: Path, params: Mapping[str, Any], header: Sequence[str]) -> Path:
    """Write ``params`` as a rig description (``/**: ros__parameters:``) to the new file ``path``,
    atomically and never over an existing file; ``header`` lines become comments at the top. The
    text is read back through :func:`parse_description` first, so a file is written only when
    :func:`read_rig` will accept it."""
    parse_description(dict(params), str(path))
    body = yaml.safe_dump({"/**": {"ros__parameters": dict(params)}}, sort_keys=False,
                          default_flow_style=False)
    text = "".join(f"# {line}\n" for line in header) + body
    return write_text_atomic(path, text, exclusive=True, error=ConfigError)
