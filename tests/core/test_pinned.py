"""Every agent kind learns exactly what it learned before a refactor (bit for bit).

The models are stored artifacts and the plant is the default preset, so the
digests pin the learner and the kernels, not identification (whose last digits
differ between CPUs). Regenerate with ``tests/data/pinned/make_pins.py`` only
when a change is *meant* to alter results, and say so in the commit.
"""

from __future__ import annotations

import json

import pytest

from tests.data.pinned.make_pins import HERE, digest
from tests.data.pinned.pinned_runs import RUNS, run_case

PINS = json.loads((HERE / "digests.json").read_text())


def test_every_case_is_pinned() -> None:
    assert sorted(PINS) == sorted(RUNS)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_learner_output_is_unchanged(name: str) -> None:
    q, x = run_case(name)
    assert (digest(q), digest(x)) == (PINS[name]["q"], PINS[name]["x"]), (
        f"{name}: Q-table or validation run changed; final position now {x[0, -1]!r}, "
        f"pinned {PINS[name]['x_last']!r}")
