"""Fuzz: risk records as a table reads them from a received ``result.json`` or a robustness cell.

Property: any JSON value in a record's place is either summed up (every figure
finite, counts whole) or counts as no record; the table cells render either way.
"""

from __future__ import annotations

import math
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.core.evaluation.risk_table import NUMBERS, compact, risk_cell, summarise, summary_of
from tests.fuzz.json_values import JSON, JSON_LEAF

GOOD = {"contacts": 1, "time_at_stop": 0.1, "peak_x": 2.5, "peak_v": 3.0, "time_outside": 0.5,
        "exits_beyond_margin": 1, "override_share": 0.25, "overrides": {"envelope": 3}, "aborted": None}

RECORD = st.one_of(JSON, st.fixed_dictionaries({k: JSON_LEAF for k in (*NUMBERS, "aborted")}),
                   st.builds(lambda k, v: {**GOOD, k: v}, st.sampled_from([*NUMBERS, "aborted"]), JSON))


@given(st.lists(RECORD, max_size=5))
def test_any_records_sum_up_or_count_as_none(records: list[Any]) -> None:
    s = summarise([*records, GOOD])
    assert s is not None and 1 <= s["runs"] <= len(records) + 1
    assert all(math.isfinite(float(s[k])) for k in ("time_at_stop", "peak_x", "peak_v", "override_share"))
    assert isinstance(s["contacts"], int) and s["contacts"] >= 1
    cells = compact(s)
    assert len(cells) == 4 and all(isinstance(c, str) and "\n" not in c for c in cells)


@given(JSON)
def test_any_cell_renders(cell: Any) -> None:
    assert isinstance(risk_cell(summary_of(cell)), str)
    assert len(compact(cell if isinstance(cell, dict) else None)) == 4
