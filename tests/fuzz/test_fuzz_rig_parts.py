"""Fuzz the reader of a rig sweep's task results (``<out>/rigs/rig-<seed>.json`` of a resumed run).

Property: any value put anywhere in a good result (or any field removed) is either refused with the
project's one error line, or read and then pooled into ``rigs.json`` and rendered into ``rigs.md``
without a crash.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.app.rigs import document
from msd_bench.core.errors import MsdBenchError
from msd_bench.io.rigs.rig_parts import read_part
from msd_bench.io.rigs.rigs_report import render
from tests.fuzz.json_values import JSON
from tests.io.rig_part_sample import CFG, KINDS, SCENARIOS, part


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a JSON document."""
    out: list[tuple[Any, ...]] = [prefix] if prefix else []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
    for key, value in items:
        out += _paths(value, (*prefix, key))
    return out


PATHS = _paths(part())
REMOVE = object()


def _mutated(where: tuple[Any, ...], value: Any) -> Any:
    doc: Any = part()
    node = doc
    for key in where[:-1]:
        node = node[key]
    if value is REMOVE:
        del node[where[-1]]
    else:
        node[where[-1]] = value
    return doc


def _check(text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rig-1000.json"
        path.write_text(text)
        try:
            got = read_part(path, 1000, KINDS, SCENARIOS)
        except MsdBenchError as err:
            assert "\n" not in str(err)
            return
        render(json.loads(json.dumps(document(CFG, [got]))))


@given(st.sampled_from(PATHS), st.one_of(JSON, st.just(REMOVE)))
def test_a_mutated_part_is_read_or_refused_in_one_line(where: tuple[Any, ...], value: Any) -> None:
    _check(json.dumps(_mutated(where, value)))


@given(JSON)
def test_any_json_document_is_read_or_refused_in_one_line(doc: Any) -> None:
    _check(json.dumps(doc))
