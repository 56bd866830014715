"""check-rig against deliberately broken nodes: each fails exactly the clause it breaks, in one line."""

from __future__ import annotations

import pytest

from tests.rig import fakes
from tests.rig.conftest import check, failed, serving

pytestmark = pytest.mark.ros


@pytest.mark.parametrize("name", sorted(fakes.FAKES))
def test_a_broken_node_fails_exactly_its_clause(name: str) -> None:
    ns = "/fake_" + name.replace("-", "_")
    with serving(lambda ctx: fakes.build(name, ns, context=ctx)):
        clauses = check(ns)
    lines = "\n".join(c.line() for c in clauses)
    assert failed(clauses) == [fakes.FAKES[name][1]], lines
    assert all("\n" not in c.line() for c in clauses)
