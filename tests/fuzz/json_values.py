"""Strategies shared by the reader fuzz files: arbitrary JSON values and deeply nested documents."""

from __future__ import annotations

from hypothesis import strategies as st

JSON_LEAF = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=8))
"""Any JSON scalar (floats include NaN and infinities, which Python's json reads and writes)."""

JSON = st.recursive(
    JSON_LEAF,
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=12,
)
"""Any small JSON value: scalars, lists and objects nested a few levels."""


def nested(prefix: str, depth: int) -> str:
    """``prefix`` followed by ``depth`` nested empty lists and the closing brace (a document that
    starts like a valid header and then nests far deeper than any reader accepts)."""
    return prefix + "[" * depth + "]" * depth + "}"
