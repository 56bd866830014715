"""Records, the paper's fit formula and the across-seed summaries."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation.results import AgentResult, per_seed_row
from msd_bench.core.evaluation.stats import summarize
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.fit import fit_percent


def test_fit_percent_by_hand() -> None:
    y = np.array([0.0, 1.0, 2.0, 3.0])  # ||y - mean|| = sqrt(5)
    yhat = y + np.array([0.5, -0.5, 0.5, -0.5])  # ||y - yhat|| = 1
    assert fit_percent(y, yhat) == pytest.approx(100 * (1 - 1 / math.sqrt(5)))
    assert fit_percent(y, y) == 100.0
    assert fit_percent(y, np.full(4, y.mean())) == pytest.approx(0.0)


def test_fit_percent_rejects_bad_shapes_and_constant_output() -> None:
    with pytest.raises(InvalidInputError, match="equal non-empty shapes"):
        fit_percent(np.zeros(3), np.zeros(4))
    with pytest.raises(InvalidInputError, match="constant"):
        fit_percent(np.ones(3), np.ones(3))


def test_experiment_validation_messages_are_one_line() -> None:
    cases = [
        (np.zeros(5), np.zeros(4), "lengths differ"),
        (np.zeros(2), np.zeros(2), "at least 3 samples"),
        (np.array([0.0, np.nan, 1.0]), np.zeros(3), "non-finite"),
    ]
    for u, y, message in cases:
        with pytest.raises(InvalidInputError, match=message) as info:
            Experiment(u, y, "bag-a")
        assert "\n" not in str(info.value) and "bag-a" in str(info.value)


def test_iodata_merge_and_empty() -> None:
    a = IOData.single(np.zeros(10), np.arange(10.0), 0.01, "a")
    b = IOData.single(np.ones(5), np.arange(5.0), 0.01, "b")
    both = a.merge(b)
    assert both.n_samples == 15 and len(both.experiments) == 2
    with pytest.raises(InvalidInputError, match="empty"):
        IOData(())
    with pytest.raises(InvalidInputError, match="cannot merge"):
        a.merge(IOData.single(np.zeros(5), np.arange(5.0), 0.02))


def test_summary_counts_undefined_values() -> None:
    s = summarize([1.0, 3.0, float("nan")])
    assert (s.n, s.n_defined, s.mean, s.median) == (3, 2, 2.0, 2.0)
    assert s.sd == pytest.approx(math.sqrt(2.0))
    assert s.as_dict()["mean"] == 2.0
    empty = summarize([float("nan")])
    assert empty.text() == "N/A" and empty.as_dict()["mean"] is None


def test_agent_result_success_rate() -> None:
    metrics = {"mae": 0.1, "std": 0.1, "po": 0.0, "ts": float("nan"), "ts5": 3.0}
    rows = tuple(per_seed_row(s, 0, {**metrics, "sse": sse}) for s, sse in enumerate([1, 4.9, 5, 30]))
    r = AgentResult("plm", "PLM", "plm", "paper", 60_000, 95.0, 99.0, rows)
    assert r.n == 4 and r.n_success == 2 and r.success_rate == 0.5
    assert r.summary()["ts"].n_defined == 0


def test_wilson_interval_matches_hand_computed_values():
    from msd_bench.core.evaluation.stats import rate_text, wilson

    lo, hi = wilson(55, 60)  # the reviewer quoted 82-96 % for 55/60
    assert (round(100 * lo), round(100 * hi)) == (82, 96)
    assert wilson(0, 20)[0] == 0.0 and 0.15 < wilson(0, 20)[1] < 0.17
    assert wilson(20, 20)[1] == 1.0 and 0.83 < wilson(20, 20)[0] < 0.85
    assert rate_text(55, 60) == "55/60 (92 %, CI 82–96 %)"
    assert all(v != v for v in wilson(1, 0))  # no trials: no interval


def test_prediction_interval_covers_the_stored_count_and_widens_with_less_data():
    from msd_bench.core.evaluation.stats import prediction_interval

    lo, hi = prediction_interval(55, 60, 60)
    assert lo <= 55 <= hi and hi <= 60 and lo >= 40
    assert prediction_interval(0, 64, 64)[0] == 0 and prediction_interval(64, 64, 64)[1] == 64
    narrow, wide = prediction_interval(320, 640, 64), prediction_interval(32, 64, 64)
    assert wide[1] - wide[0] > narrow[1] - narrow[0]
