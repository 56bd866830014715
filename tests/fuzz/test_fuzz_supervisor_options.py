"""Fuzz: the supervisor's options file, read and resolved against the plant.

Property: whatever the file holds — random JSON, or an object of the real option names with
random values — ``read_options`` then ``limits`` give limits the filter can run on (finite,
the envelope and its margin inside the stroke) or one MsdBenchError line.
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

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.physics.plant import PRESETS
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.io.storage.supervisor_file import read_options
from tests.fuzz.json_values import JSON

NAMES = [f.name for f in fields(SupervisorOptions)]
VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
                   st.booleans(), st.none(), st.text(max_size=5), JSON)
PLANT = PRESETS["default"]


def check(text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "options.json"
        path.write_text(text)
        try:
            lim = read_options(path).limits(PLANT)
        except MsdBenchError as exc:
            assert "\n" not in str(exc)
            return
    assert all(math.isfinite(v) for v in lim)
    assert lim.envelope > 0 and lim.envelope + lim.margin < PLANT.x_max
    assert lim.brake > 0 and lim.v_max > 0 and lim.latency >= PLANT.dt


@given(doc=JSON)
def test_random_json_as_options(doc: Any) -> None:
    check(json.dumps(doc))


@given(doc=st.dictionaries(st.sampled_from(NAMES), VALUES, max_size=len(NAMES)))
def test_the_real_options_with_random_values(doc: dict[str, Any]) -> None:
    check(json.dumps(doc))


@given(text=st.text(max_size=200))
def test_random_text_as_options(text: str) -> None:
    check(text)
