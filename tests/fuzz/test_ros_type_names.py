"""Property: any advertised type name is a ROS message class or one TopicError; only ``.msg`` is imported."""

from __future__ import annotations

import sys

from hypothesis import given
from hypothesis import strategies as st

from msd_bench.commands.topics import TopicError, import_type

SEGMENT = st.one_of(st.sampled_from(["std_msgs", "msg", "srv", "os", "String", "path", "sys", "Float64"]),
                    st.text(max_size=12))
NAMES = st.one_of(st.text(max_size=60), st.lists(SEGMENT, min_size=1, max_size=4).map("/".join))


@given(NAMES)
def test_type_names_resolve_to_messages_or_one_error(name: str) -> None:
    before = set(sys.modules)
    try:
        cls = import_type(name)
    except TopicError as exc:
        assert str(exc).startswith("unsupported type ") and "\n" not in str(exc)
    else:
        assert hasattr(type(cls), "__import_type_support__")
    new = set(sys.modules) - before
    assert all(".msg" in m for m in new), new
