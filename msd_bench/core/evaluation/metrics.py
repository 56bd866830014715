"""Closed-loop validation metrics of paper §5 on one trajectory.

Conventions (the paper leaves them open; these are ours, stated once here):

* ``e_k = x_k - x*`` over all N samples of the validation run, ``x[0]`` included.
* STD is the printed formula ``sqrt(Σ (|e_k| - MAE)^2 / (N - 1))``: the spread
  of the *absolute* error around the MAE, not the standard deviation of e.
* PO is measured in the direction of the step (from ``x[0]`` toward ``x*``):
  ``100 max(0, max_k d (x_k - x*)) / |x*|`` with ``d = sign(x* - x[0])``; for a
  positive step from rest this is the paper's ``100 max_k (x_k - x*) / |x*|``
  clipped at 0. It is computed even when the run never settles; a report may
  print N/A then, as the paper's Table 1 does.
* ts is ``k dt`` for the first sample k after which ``|e_j| <= ε |x*|`` for all
  j >= k (to the end of the run); NaN when the last sample is outside the band
  (report as N/A). Given for ε = 2 % (the paper's) and 5 % (docs/decisions.md §Metrics: the
  paper's ts ≈ 7 s is inconsistent with a 3 % SSE under a 2 % band).
* SSE is ``100 |mean(e over the last W samples)| / |x*|``, W = 500 (5 s) by
  default; success means SSE < 5 %.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError

FloatArray = NDArray[np.float64]

SUCCESS_SSE = 5.0
"""SSE (%) below which a validation run counts as a success."""


class MetricsInputError(InvalidInputError):
    """A trajectory or target handed to the metrics cannot be scored."""


@dataclass(frozen=True)
class Metrics:
    """Paper §5 metrics of one validation run (NaN settling time = never settled, N/A)."""

    mae: float
    """Mean absolute error, m."""
    std: float
    """Spread of |e| around the MAE (printed formula, N - 1 denominator), m."""
    po: float
    """Percent overshoot in the direction of the step, % of |x*| (>= 0)."""
    ts2: float
    """Settling time into the ±2 % band, s (NaN if never)."""
    ts5: float
    """Settling time into the ±5 % band, s (NaN if never)."""
    sse: float
    """Steady-state error over the last ``window`` samples, % of |x*|."""
    success: bool
    """SSE < 5 %."""
    target: float
    """Reference x*, m."""
    n: int
    """Samples scored."""
    window: int
    """Terminal window W of the SSE, samples."""

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (floats, bool, ints) for JSON/CSV reports."""
        return asdict(self)


def compute(x: FloatArray, target: float, dt: float, window: int = 500) -> Metrics:
    """All §5 metrics of trajectory ``x`` sampled every ``dt`` s, tracking the constant ``target``."""
    x = _check(x, target, dt, window)
    e = x - target
    ae = np.abs(e)
    ref = abs(target)
    mae = float(ae.mean())
    std = float(math.sqrt(np.sum((ae - mae) ** 2) / (x.size - 1)))
    d = math.copysign(1.0, target - x[0]) if target != x[0] else math.copysign(1.0, target)
    po = 100.0 * max(0.0, float(np.max(d * e))) / ref
    sse = 100.0 * abs(float(e[-window:].mean())) / ref
    return Metrics(mae, std, po, settling_time(ae, ref, 0.02, dt), settling_time(ae, ref, 0.05, dt),
                   sse, bool(sse < SUCCESS_SSE), float(target), int(x.size), int(window))


def settling_time(abs_err: FloatArray, ref: float, eps: float, dt: float) -> float:
    """``k dt`` for the first k with ``abs_err[j] <= eps ref`` for all j >= k; NaN if none."""
    outside = np.flatnonzero(abs_err > eps * ref)
    if outside.size == 0:
        return 0.0
    k = int(outside[-1]) + 1
    return float("nan") if k >= abs_err.size else k * dt


def _check(x: FloatArray, target: float, dt: float, window: int) -> FloatArray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1 or arr.size < 2:
        raise MetricsInputError(f"trajectory must be 1-D with >= 2 samples, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise MetricsInputError("trajectory contains a non-finite value")
    if not math.isfinite(target) or target == 0.0:
        raise MetricsInputError(f"target must be finite and non-zero (metrics are % of |x*|), "
                                f"got {target}")
    if not (math.isfinite(dt) and dt > 0):
        raise MetricsInputError(f"dt must be finite and > 0, got {dt}")
    if not 1 <= window <= arr.size:
        raise MetricsInputError(f"SSE window must be in [1, {arr.size}] samples, got {window}")
    return arr
