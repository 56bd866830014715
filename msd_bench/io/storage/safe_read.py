"""Bounded readers for the JSON documents a user hands the tools.

A model file, a Q-table's metadata, a bag's ``custom_data`` or a run directory's
``result.json`` may come from anywhere. A reader must not let such a file
exhaust memory (a document of gigabytes), overflow the stack (nesting deep
enough for ``RecursionError``) or leak a library exception as a traceback. Each
function here reads with a size and a depth bound and raises the caller's own
one-line error naming the file.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from msd_bench.core.errors import MsdBenchError

MAX_JSON_BYTES = 16 << 20
"""Largest JSON document read (16 MiB): the biggest artifact written is under 1 MiB."""

MAX_JSON_DEPTH = 32
"""Deepest nesting accepted: the project's documents nest at most 6 levels."""


def json_depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value (a scalar is 0), without recursion."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict):
            children: Any = item.values()
        elif isinstance(item, list):
            children = item
        else:
            deepest = max(deepest, depth)
            continue
        deepest = max(deepest, depth + 1)
        stack.extend((child, depth + 1) for child in children)
    return deepest


def loads_bounded(
    text: str | bytes,
    what: str,
    error: type[MsdBenchError] = MsdBenchError,
    max_bytes: int = MAX_JSON_BYTES,
    max_depth: int = MAX_JSON_DEPTH,
) -> Any:
    """Parse ``text`` as JSON, refusing oversized or overly nested documents.

    ``what`` names the source in the one-line error (a path, or "bag X's custom_data").
    """
    if len(text) > max_bytes:
        raise error(f"{what}: JSON document of {len(text)} bytes exceeds the {max_bytes}-byte limit")
    try:
        value = json.loads(text)
    except RecursionError:
        raise error(f"{what}: JSON nested too deeply (limit {max_depth} levels)") from None
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, an int of over 4300 digits
        raise error(f"{what}: not valid JSON ({str(exc)[:200]})") from None
    if json_depth(value) > max_depth:
        raise error(f"{what}: JSON nested too deeply (limit {max_depth} levels)")
    return value


def read_json_bounded(
    path: Path,
    error: type[MsdBenchError] = MsdBenchError,
    max_bytes: int = MAX_JSON_BYTES,
    max_depth: int = MAX_JSON_DEPTH,
) -> Any:
    """Read and parse the JSON file at ``path`` under the size and depth bounds."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise error(f"{path}: JSON document of {size} bytes exceeds the {max_bytes}-byte limit")
        with path.open("rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise error(f"{path}: cannot read ({exc.strerror or exc})") from None
    return loads_bounded(data, str(path), error, max_bytes, max_depth)
