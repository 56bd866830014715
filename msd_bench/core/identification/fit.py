"""Goodness of fit as the paper defines it (§3.2), MATLAB's NRMSE "Best Fit"."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError


def fit_percent(y: NDArray[np.float64], yhat: NDArray[np.float64]) -> float:
    """``100 (1 - ||y - yhat|| / ||y - mean(y)||)``; 100 is perfect, <= 0 no better than the mean."""
    y = np.asarray(y, dtype=float)
    yhat = np.asarray(yhat, dtype=float)
    if y.shape != yhat.shape or y.size == 0:
        raise InvalidInputError(f"fit needs equal non-empty shapes, got {y.shape} and {yhat.shape}")
    spread = float(np.linalg.norm(y - y.mean()))
    if spread == 0.0:
        raise InvalidInputError("fit is undefined for a constant measured output")
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / spread))
