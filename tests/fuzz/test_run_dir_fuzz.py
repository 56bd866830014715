"""Fuzz the run-directory reader: any manifest or task record a received ``--out`` holds.

Property: :meth:`RunDir.open` resumes or raises the project's one error, and
:func:`is_complete` answers True or False — never a crash; neither touches a
file other than the manifest. Report text from a received ``result.json``
stays on its line and in its cell, whatever it holds.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import MsdBenchError
from msd_bench.io.reports.report import md_cell, md_text
from msd_bench.io.storage.run_dir import COMPLETE, MANIFEST, RunDir, config_hash, is_complete

TASKS = ["a", "b"]
CONFIG = {"seeds": 1}

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20)


def _manifest_like() -> st.SearchStrategy[bytes]:
    """Raw bytes, arbitrary JSON, and near-valid manifests with fields swapped for anything."""
    valid = {"schema": "msd-bench/run", "schema_version": 1, "command": "paper",
             "config_sha256": config_hash(CONFIG), "tasks": TASKS}
    near = st.dictionaries(st.sampled_from(sorted(valid)), json_values, max_size=5).map(
        lambda patch: json.dumps({**valid, **patch}).encode())
    return st.binary(max_size=200) | json_values.map(lambda v: json.dumps(v).encode()) | near


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@given(manifest=_manifest_like(), record=json_values, marker=st.booleans())
def test_a_received_run_directory_never_crashes_the_reader(manifest: bytes, record: object,
                                                           marker: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / MANIFEST).write_bytes(manifest)
        (root / "tasks").mkdir()
        (root / "tasks" / "a.json").write_text(json.dumps(record))
        if marker:
            (root / COMPLETE).write_text("{}")
        assert is_complete(root) in (True, False)
        before = {k: v for k, v in _files(root).items() if k != MANIFEST}
        try:
            rd = RunDir.open(root, "paper", TASKS, CONFIG)
        except MsdBenchError as exc:
            assert "\n" not in str(exc)
        else:
            assert rd.resumed and not marker
            assert rd.is_done("b") is False and rd.is_done("a") in (True, False)
        assert {k: v for k, v in _files(root).items() if k != MANIFEST} == before


@given(st.text(max_size=60))
def test_markdown_text_stays_in_its_line_and_cell(text: str) -> None:
    cell, line = md_cell(text), md_text(text)
    assert len(cell.splitlines()) <= 1 and len(line.splitlines()) <= 1
    unescaped = cell.replace("\\\\", "").replace("\\|", "")
    assert "|" not in unescaped
