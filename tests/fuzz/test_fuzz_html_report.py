"""Fuzz the run report's page (io/reports/html_report.py) over arbitrary report files.

Property: whatever a received run's ``table1.json``, ``robustness.json``,
``efficiency.json``, ``rigs.json`` or ``run.json`` holds, building the page
gives a page or :class:`ReportError` — never another exception — and the page
holds no markup from the files: every tag and attribute in it is one the
page's own markup uses.
"""

from __future__ import annotations

import json
import tempfile
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.io.reports.html_report import ReportError, render
from tests.fuzz.json_values import JSON

MARKUP = st.sampled_from(["<script>x</script>", "<img src=x onerror=y>", "\"'><b>", "&amp;", "</table>"])
TEXT = st.one_of(st.text(max_size=8), MARKUP)
VALUE = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), TEXT),
                     lambda inner: st.one_of(st.lists(inner, max_size=4),
                                             st.dictionaries(TEXT, inner, max_size=4)), max_leaves=12)
"""JSON values whose strings and keys are often markup."""

ALLOWED = {(t, a) for t, attrs in {
    "html": ["lang"], "head": [], "meta": ["charset", "http-equiv", "content", "name"], "title": [],
    "style": [], "body": [], "h1": [], "h2": [], "h3": [], "section": [], "p": ["class"], "div": ["class"],
    "table": ["class"], "thead": [], "tbody": [], "tr": [], "th": [], "td": ["class", "style"], "code": [],
    "small": [], "ol": [], "li": [], "details": [], "summary": [], "figure": [], "img": ["src", "alt"],
    "figcaption": [],
}.items() for a in [None, *attrs]}
"""Every (tag, attribute) the page's own markup uses: a text from a file that became markup is outside."""


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.seen: set[tuple[str, str | None]] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.seen.add((tag, None))
        self.seen.update((tag, name) for name, _ in attrs)


NAMES = {"table1.json": "msd-bench/table1", "robustness.json": "msd-bench/robustness",
         "efficiency.json": "msd-bench/efficiency", "rigs.json": "msd-bench/rigs", "run.json": None}
LISTS = {"table1.json": "agents", "robustness.json": "agents", "efficiency.json": "methods",
         "rigs.json": "kinds"}


def _shaped(name: str, body: Any) -> Any:
    """Half the documents look like the real one (schema and list key present), so the renderer is reached."""
    schema, key = NAMES[name], LISTS.get(name)
    if schema is None or not isinstance(body, dict):
        return body
    doc = {"schema": schema, **body}
    if key is not None and not isinstance(doc.get(key), list):
        doc[key] = [body]
    return doc


@given(name=st.sampled_from(sorted(NAMES)), body=st.one_of(VALUE, st.dictionaries(TEXT, VALUE, max_size=5)),
       shaped=st.booleans())
def test_any_report_file_gives_a_page_or_one_error(name: str, body: Any, shaped: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        doc = _shaped(name, body) if shaped else body
        (root / name).write_text(json.dumps(doc))
        try:
            page = render(root, "fuzz", root)
        except ReportError as err:
            assert "\n" not in str(err) and name in str(err)
            return
    tags = _Tags()
    tags.feed(page)
    assert tags.seen <= ALLOWED, tags.seen - ALLOWED


@given(raw=st.binary(max_size=64) | JSON.map(json.dumps))
def test_any_bytes_as_table1_give_a_page_or_one_error(raw: bytes | str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "table1.json").write_bytes(raw if isinstance(raw, bytes) else raw.encode())
        try:
            render(root, "fuzz", root)
        except ReportError as err:
            assert "\n" not in str(err)
