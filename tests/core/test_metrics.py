"""Validation metrics (paper §5) against hand-computed values, and the validate glue."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core.errors import MsdBenchError
from msd_bench.core.metrics import MetricsInputError, compute, settling_time
from msd_bench.core.model import plant_model
from msd_bench.core.plant import DT, PlantParams
from msd_bench.core.qconfig import QConfig
from msd_bench.core.qtrain import greedy_rollout
from msd_bench.core.validate import summary, validate


def test_mae_and_std_by_hand() -> None:
    m = compute(np.array([0.0, 1.0, 2.0]), 1.0, DT, window=3)
    # |e| = [1, 0, 1]: MAE = 2/3; STD = sqrt(((1/3)^2 + (2/3)^2 + (1/3)^2) / 2) = sqrt(1/3)
    assert m.mae == pytest.approx(2 / 3)
    assert m.std == pytest.approx(math.sqrt(1 / 3))


def test_settling_time_enters_band_at_known_index() -> None:
    x = np.array([0.0, 0.5, 0.9, 0.97, 0.99, 1.01, 1.0, 1.0])
    m = compute(x, 1.0, dt=0.1, window=2)
    assert m.ts2 == pytest.approx(0.4)  # last |e| > 0.02 is 0.97 at index 3
    assert m.ts5 == pytest.approx(0.3)  # last |e| > 0.05 is 0.9 at index 2


def test_never_settles_is_nan_and_always_inside_is_zero() -> None:
    assert math.isnan(compute(np.array([0.0, 0.5, 0.9]), 1.0, DT, window=1).ts2)
    assert settling_time(np.array([0.01, 0.0]), 1.0, 0.02, 0.01) == 0.0


def test_overshoot_positive_and_negative_steps() -> None:
    assert compute(np.array([0.0, 1.2, 1.0, 1.0]), 1.0, DT, window=2).po == pytest.approx(20.0)
    assert compute(np.array([0.0, -1.1, -1.0, -1.0]), -1.0, DT, window=2).po == pytest.approx(10.0)
    assert compute(np.array([0.0, 0.5, 0.9]), 1.0, DT, window=1).po == 0.0


def test_sse_of_constant_offset_and_success() -> None:
    x = np.concatenate([np.zeros(10), np.full(500, 0.9)])
    m = compute(x, 1.0, DT)
    assert m.sse == pytest.approx(10.0) and not m.success
    m = compute(np.concatenate([np.zeros(10), np.full(500, 1.03)]), 1.0, DT)
    assert m.sse == pytest.approx(3.0) and m.success
    # window covers the transient when it is too long: mean of the last 510 samples
    assert compute(x, 1.0, DT, window=510).sse == pytest.approx(100 * (10 + 500 * 0.1) / 510)


def test_as_dict_is_plain() -> None:
    d = compute(np.array([0.0, 1.0, 1.0]), 1.0, DT, window=2).as_dict()
    assert set(d) >= {"mae", "std", "po", "ts2", "ts5", "sse", "success"}
    assert d["success"] is True


@pytest.mark.parametrize(("x", "target", "window"), [
    (np.array([]), 1.0, 1), (np.array([1.0]), 1.0, 1), (np.array([0.0, np.nan]), 1.0, 1),
    (np.array([0.0, 1.0]), 0.0, 1), (np.array([0.0, 1.0]), np.inf, 1),
    (np.array([0.0, 1.0]), 1.0, 3), (np.array([0.0, 1.0]), 1.0, 0), (np.zeros((2, 2)), 1.0, 1)])
def test_bad_inputs_raise(x: np.ndarray, target: float, window: int) -> None:
    with pytest.raises(MetricsInputError):
        compute(x, target, DT, window=window)
    assert issubclass(MetricsInputError, MsdBenchError)


def test_validate_scores_each_greedy_run() -> None:
    m = plant_model(PlantParams())
    cfg = QConfig()
    q = np.zeros((2, 100, 5))
    q[0, :50, 3] = 1.0  # below target +F/2, else no force
    q[0, 50:, 2] = 1.0
    q[1, :, 4] = 1.0  # always +F: pinned near the +F equilibrium, far above 1
    results = validate(m, q, cfg, n_steps=1500)
    x0, _ = greedy_rollout(m, q[0], cfg, n_steps=1500)
    direct = compute(x0, 1.0, DT)
    assert (results[0].mae, results[0].sse, results[0].po) == (direct.mae, direct.sse, direct.po)
    assert results[0].sse < 1 and results[0].success  # chatters at the set-point
    assert results[1].sse > 50 and not results[1].success
    s = summary(results)
    pair = np.array([results[0].sse, results[1].sse])
    assert s == {"n": 2.0, "success_rate": 0.5, "sse_median": pytest.approx(pair.mean()),
                 "sse_mean": pytest.approx(pair.mean()),
                 "sse_sd": pytest.approx(abs(pair[1] - pair[0]) / math.sqrt(2))}
    with pytest.raises(MsdBenchError):
        summary([])
