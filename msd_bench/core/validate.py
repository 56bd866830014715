"""Validation of trained tables on the true plant (paper §5): rollouts then metrics.

The trained tables are held fixed and act greedily from rest toward a constant
reference; each resulting trajectory is scored by :func:`metrics.compute`.
Keeping this glue separate lets the report layer and the agent node share it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from msd_bench.core import metrics
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.model import StepModel
from msd_bench.core.qconfig import QConfig
from msd_bench.core.qtrain import greedy_rollouts

FloatArray = NDArray[np.float64]


def validate(plant_model: StepModel, q_tables: FloatArray, cfg: QConfig, target: float = 1.0,
             n_steps: int = 3000, window: int = 500) -> list[metrics.Metrics]:
    """Metrics of each table's greedy run on ``plant_model`` (usually the true plant)."""
    xs, _ = greedy_rollouts(plant_model, q_tables, cfg, target, n_steps)
    return [metrics.compute(x, target, dt=plant_model.dt, window=window) for x in xs]


def summary(results: list[metrics.Metrics]) -> dict[str, float]:
    """Success rate, median and mean ± sd of the SSE over a batch (a distribution, not a number)."""
    if not results:
        raise InvalidInputError("no validation results to summarise")
    sse = np.array([m.sse for m in results])
    return {
        "n": float(sse.size),
        "success_rate": float(np.mean([m.success for m in results])),
        "sse_median": float(np.median(sse)),
        "sse_mean": float(sse.mean()),
        "sse_sd": float(sse.std(ddof=1)) if sse.size > 1 else 0.0,
    }

