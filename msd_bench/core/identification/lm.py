"""Levenberg–Marquardt on the normal equations, with the step projected on bounds.

Why not ``scipy.optimize.least_squares``: its trust-region step takes an SVD of
the full Jacobian every iteration — 12,000 rows or more here, against a few
dozen parameters — which cost as much as the simulations themselves (the
greybox-rig fit: ten times; the PLM's global refinement: half of its time).
The normal equations of a few dozen well-scaled parameters are as good and
cost next to nothing. Two users: the greybox-rig fit (forward differences,
:func:`forward_differences`) and the PLM's global refinement (its exact
Jacobian, :mod:`msd_bench.core.identification.plm`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import IdentificationError

FloatArray = NDArray[np.float64]
Residuals = Callable[[FloatArray], FloatArray]
Jacobian = Callable[[FloatArray, FloatArray], tuple[FloatArray, int]]
"""``(theta, residuals at theta) -> (d residuals / d theta, simulations it ran)``."""


def forward_differences(residuals: Residuals, hi: FloatArray, fd_step: float) -> Jacobian:
    """The Jacobian by forward differences of relative step ``fd_step``, stepping inward at an upper bound."""

    def jacobian(theta: FloatArray, r: FloatArray) -> tuple[FloatArray, int]:
        jac = np.empty((r.size, theta.size))
        for j in range(theta.size):
            h = fd_step * max(abs(theta[j]), 1e-3)
            h = -h if theta[j] + h > hi[j] else h
            t = theta.copy()
            t[j] += h
            jac[:, j] = (residuals(t) - r) / h
        return jac, theta.size

    return jacobian


def levenberg_marquardt(residuals: Residuals, jacobian: Jacobian, theta0: FloatArray, lo: FloatArray,
                        hi: FloatArray, max_iter: int, rel_stop: float = 1e-9,
                        what: str = "fit") -> tuple[FloatArray, float, int]:
    """Minimise half the squared ``residuals``; (theta, cost, simulations run).

    Marquardt's diagonal scaling, the damping raised 4x until a step lowers the cost (at most 12
    times: none does, so it has converged or is stuck on a bound) and lowered 3x after one; stops
    after ``max_iter`` iterations or when a step gains less than ``rel_stop`` of the cost.
    """
    theta = theta0.copy()
    r = residuals(theta)
    cost, nfev, lam = 0.5 * float(r @ r), 1, 1e-3
    for _ in range(max_iter):
        jac, used = jacobian(theta, r)
        nfev += used
        a, g = jac.T @ jac, jac.T @ r
        d = np.diag(a) + 1e-12
        for _ in range(12):
            trial = np.clip(theta - np.linalg.solve(a + lam * np.diag(d), g), lo, hi)
            rt = residuals(trial)
            nfev += 1
            ct = 0.5 * float(rt @ rt)
            if np.isfinite(ct) and ct < cost:
                break
            lam *= 4.0
        else:
            break  # no step along any damping improves: converged (or stuck on a bound)
        done = cost - ct <= rel_stop * cost
        theta, r, cost, lam = trial, rt, ct, max(lam / 3.0, 1e-9)
        if done:
            break
    if not np.all(np.isfinite(theta)):
        raise IdentificationError(f"{what} diverged (non-finite parameters)")
    return theta, cost, nfev
