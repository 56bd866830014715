"""check-rig against deliberately broken nodes: each fails exactly the clause it breaks, in one line."""

from __future__ import annotations

import pytest

from tests.rig import fakes
from tests.rig.conftest import check, failed, serving

pytestmark = pytest.mark.ros

DEFAULT_TIER = ("lockstep-double-step", "lockstep-silent-reset", "no-watchdog")
"""The fakes checked by ``make test``: both modes, a clause judged in each. Why not all: each real-time
check waits its protocol out (6-15 s a fake); the rest are the realtime tier's (docs/testing.md
§Tiers), and every clause's judgement is also tested on recorded data (tests/core/test_conformance.py)."""


REALTIME_TIER = pytest.mark.realtime


@pytest.mark.parametrize("name", [name if name in DEFAULT_TIER else pytest.param(name, marks=REALTIME_TIER)
                                  for name in sorted(fakes.FAKES)])
def test_a_broken_node_fails_exactly_its_clause(name: str) -> None:
    ns = "/fake_" + name.replace("-", "_")
    with serving(lambda ctx: fakes.build(name, ns, context=ctx)):
        clauses = check(ns)
    lines = "\n".join(c.line() for c in clauses)
    assert failed(clauses) == [fakes.FAKES[name][1]], lines
    assert all("\n" not in c.line() for c in clauses)


def test_delay_lag_and_sensor_noise_are_not_faults() -> None:
    """A conforming node with one sample of delay, a 30 ms lag and 2 mm of noise passes every clause,
    and the effort-step clause measures its delay and time constant."""
    with serving(lambda ctx: fakes.realistic("/fake_realistic", context=ctx)):
        clauses = check("/fake_realistic")
    lines = "\n".join(c.line() for c in clauses)
    assert failed(clauses) == [], lines
    step = next(c for c in clauses if c.name == "effort-step")
    delay = int(step.figure.split("delay ")[1].split()[0])
    tau_ms = float(step.figure.split("time constant ")[1].split()[0])
    assert delay >= 1, lines  # one sample (more when the node was starved of CPU and ran late)
    assert tau_ms == pytest.approx(30.0, abs=1.0), lines
