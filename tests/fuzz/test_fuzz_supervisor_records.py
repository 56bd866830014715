"""Fuzz: the supervisor's record of a bench.py run (``agents/supervisor.json``, read by the report
stage) and bench.py's ``--supervisor-option`` items.

Property: whatever the record file holds — random JSON, or a record of the real shape with random
values in its fields — ``read_record`` then the report's ``report_line`` give one line of text, or
``read_record`` refuses it with one MsdBenchError line; an option item is a (name, finite number)
pair or one ConfigError line.
"""

from __future__ import annotations

import json
import math
import tempfile
from dataclasses import fields
from pathlib import Path
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.graph.supervise import parse_option, report_line
from msd_bench.io.storage.supervisor_file import read_record
from tests.fuzz.json_values import JSON, JSON_LEAF

REASONS = st.sampled_from(["envelope", "velocity", "stale", "estop", "x"])
COUNTS = st.dictionaries(REASONS, st.one_of(st.integers(-2, 10**6), JSON_LEAF), max_size=3)
RUN = st.fixed_dictionaries({}, optional={
    "overrides": st.one_of(COUNTS, JSON), "overridden": st.one_of(st.integers(0, 300), JSON_LEAF),
    "steps": JSON_LEAF, "aborted": st.one_of(st.none(), REASONS, JSON_LEAF)})
ABORT = st.fixed_dictionaries({}, optional={"scenario": JSON_LEAF, "seed": JSON_LEAF, "reason": JSON_LEAF})
RECORD = st.fixed_dictionaries({}, optional={
    "runs": st.one_of(st.lists(RUN, max_size=3), JSON),
    "totals": st.one_of(st.none(), st.fixed_dictionaries({}, optional={
        "outside_overrides": st.one_of(COUNTS, JSON), "outside_steps": JSON_LEAF}), JSON),
    "limits": JSON_LEAF, "stages": st.one_of(st.lists(st.text(max_size=5), max_size=2), JSON),
    "by_kind": st.one_of(st.fixed_dictionaries({}, optional={
        "attributed": JSON_LEAF, "note": JSON_LEAF,
        "kinds": st.dictionaries(st.text(max_size=4), st.fixed_dictionaries(
            {}, optional={"aborted": st.one_of(st.lists(ABORT, max_size=2), JSON)}), max_size=2)}), JSON)})


def check(text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "supervisor.json"
        path.write_text(text)
        try:
            record = read_record(path)
        except MsdBenchError as exc:
            assert "\n" not in str(exc)
            return
    line = report_line(record)["line"]
    assert isinstance(line, str) and line.startswith("Supervisor: on") and "\n" not in line


@given(doc=JSON)
def test_random_json_as_a_record(doc: Any) -> None:
    check(json.dumps(doc))


@given(doc=RECORD)
def test_a_record_of_the_real_shape_with_random_values(doc: dict[str, Any]) -> None:
    check(json.dumps(doc))


@given(text=st.one_of(st.text(max_size=30), st.builds(
    lambda k, v: f"{k}={v}", st.sampled_from([f.name for f in fields(SupervisorOptions)]),
    st.one_of(st.floats(), st.text(max_size=6)))))
def test_an_option_item_is_a_finite_number_or_one_line(text: str) -> None:
    try:
        key, value = parse_option(text)
    except ConfigError as exc:
        assert "\n" not in str(exc)
        return
    assert key in {f.name for f in fields(SupervisorOptions)} and math.isfinite(value)
