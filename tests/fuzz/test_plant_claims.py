"""Property: any text on ``<ns>/plant_claim`` is a claim or dropped, never a crash or an unbounded book."""

from __future__ import annotations

import json

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.nodes import plant_claim

SCALARS = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8)
JSON = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                    | st.dictionaries(st.text(max_size=8), inner, max_size=4), max_leaves=12)
FIELDS = {"start_ns": JSON, "pid": JSON, "token": JSON, "node": JSON, "sent_ns": JSON}
CLAIMISH = st.fixed_dictionaries(FIELDS, optional={"established": JSON}).map(json.dumps)


@given(st.one_of(st.text(max_size=200), JSON.map(json.dumps), CLAIMISH))
def test_any_text_is_a_claim_or_dropped(text: str) -> None:
    got = plant_claim.decode(text)
    assert got is None or isinstance(got[0], plant_claim.Claim)
    book = plant_claim.ClaimBook(plant_claim.Claim(10**18, 1, "own"), 0.0)
    book.hear(text, now_ns=10**18)
    assert len(book.heard) == (0 if got is None else 1)
    book.rival(10**18)
    book.ignored(10**18)
