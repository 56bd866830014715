"""Risk metrics of a run, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation.risk import run_risk
from msd_bench.core.safety.supervisor import DIVERGENCE, ENVELOPE, VELOCITY


def test_contacts_time_at_stop_peaks_and_exits() -> None:
    x = np.array([0.0, 2.3, 2.5, 2.5, 2.4, -2.5, 0.0, 2.26])
    v = np.array([0.0, 3.0, 0.0, 0.0, -1.0, 0.0, -4.0, 1.0])
    r = run_risk(x, v, dt=0.01, half_stroke=2.5, envelope=2.25, margin=0.1)
    assert r.contacts == 2 and r.time_at_stop == pytest.approx(0.03)
    assert r.peak_x == 2.5 and r.peak_v == 4.0
    assert r.time_outside == pytest.approx(0.06)
    assert r.exits_beyond_margin == 1  # 2.5 .. -2.5 is one exit; 2.3 and 2.26 stay within the margin
    assert r.override_share == 0.0 and r.overrides == {} and r.aborted is None


def test_overrides_and_aborts() -> None:
    x = np.zeros(4)
    r = run_risk(x, x, dt=0.01, half_stroke=2.5, envelope=2.25, margin=0.1,
                 reasons=[0, ENVELOPE, VELOCITY, DIVERGENCE], abort=DIVERGENCE)
    assert r.override_share == 0.75
    assert r.overrides == {"envelope": 1, "velocity": 1, "divergence": 1}
    assert r.aborted == "divergence" and r.as_dict()["aborted"] == "divergence"


@pytest.mark.parametrize("kwargs", [
    {"x": [], "v": []},
    {"x": [0.0, 1.0], "v": [0.0]},
    {"x": [np.nan], "v": [0.0]},
    {"x": [0.0], "v": [0.0], "reasons": [9]},
    {"x": [0.0], "v": [0.0], "abort": 1},
    {"x": [0.0], "v": [0.0], "envelope": 2.5},
])
def test_bad_arrays_are_one_line(kwargs: dict[str, object]) -> None:
    args = {"dt": 0.01, "half_stroke": 2.5, "envelope": 2.25, "margin": 0.1, **kwargs}
    with pytest.raises(InvalidInputError):
        run_risk(**args)  # type: ignore[arg-type]
