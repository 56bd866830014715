"""Compiled free run of the scheduled PLM with its exact Jacobian (forward sensitivities).

Why: the global refinement of the PLM (:func:`msd_bench.core.identification.plm.refine_global`)
minimises the blend's free-run error over five 12,000-sample records with 35
unknowns. With finite differences every Jacobian costs 35 free runs of all
five records through Python (about 85 % of the PLM's identification time).
The same free run, differentiated along the way, gives the exact Jacobian
in one pass: the output obeys ``y[k+1] = f(y[k], y[k-1], u[k-1], u[k]; p)``, so
its derivative ``S[k] = dy[k]/dθ`` obeys ``S[k+1] = f_y S[k] + f_y' S[k-1] + f_θ``
(zero where the output is held at a stop). Same model, same criterion, same
optimiser; only the derivative is computed instead of approximated.

The step is the kernel's (:mod:`msd_bench.core.physics.kernels`, scheduled PLM
layout): the two local models whose centres bracket ``y[k]`` interpolated
linearly, the outer ones alone beyond the outer centres, the output
projected on the stroke. ``tests/test_plm_jac.py`` pins the free run to
:func:`msd_bench.core.physics.kernels.rollout` and the Jacobian to finite differences.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics import kernels

FloatArray = NDArray[np.float64]

REFINED = np.array([0, 1, 2, 3, 5])
"""Slots of a local ``(n1, n2, d1, d2, u0, y0)`` the refinement moves (``u0`` stays the bias)."""

N_LOCAL = 5
"""Local models in a PLM."""

N_FREE = N_LOCAL * REFINED.size
"""Model parameters the refinement moves (before each record's two initial outputs)."""


@kernel
def _bracket(c: FloatArray, x: float) -> tuple[int, int, float, float]:
    """Local models ``(lo, hi)``, weight ``t`` of ``hi`` and ``dt/dx`` at position ``x``."""
    if x <= c[0]:
        return 0, 0, 0.0, 0.0
    if x >= c[4]:
        return 4, 4, 0.0, 0.0
    j = 0
    while j < 3 and x >= c[j + 1]:
        j += 1
    width = c[j + 1] - c[j]
    return j, j + 1, (x - c[j]) / width, 1.0 / width


@kernel
def _local(p: FloatArray, i: int, yk: float, yp: float, up: float, u: float) -> float:
    """Local model ``i`` of packed ``p`` in deviation form (the kernel's formula, same order)."""
    o = 1 + kernels.PLM_LOCAL_SIZE * i
    n1, n2, d1, d2, u0, y0 = p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5]
    y: float = y0 + n1 * (u - u0) + n2 * (up - u0) - d1 * (yk - y0) - d2 * (yp - y0)
    return y


@kernel
def _add_direct(p: FloatArray, i: int, w: float, yk: float, yp: float, up: float, u: float,
                out: FloatArray) -> None:
    """Add ``w`` times local model ``i``'s derivative in its own refined slots to ``out``."""
    o = 1 + kernels.PLM_LOCAL_SIZE * i
    d1, d2, u0, y0 = p[o + 2], p[o + 3], p[o + 4], p[o + 5]
    col = REFINED.size * i
    out[col] += w * (u - u0)
    out[col + 1] += w * (up - u0)
    out[col + 2] -= w * (yk - y0)
    out[col + 3] -= w * (yp - y0)
    out[col + 4] += w * (1.0 + d1 + d2)


@kernel
def free_run_jac(p: FloatArray, u: FloatArray, y0: float, y1: float, u_first: float,
                 force_limit: float, with_jac: bool) -> tuple[FloatArray, FloatArray]:
    """Free run from outputs ``(y0, y1)`` over ``u[1:]`` and, if asked, its Jacobian.

    Returns ``(y, J)``: ``y[k]`` as :func:`msd_bench.core.identification.plm._free_run`;
    ``J[k]`` the derivative of ``y[k]`` by the :data:`N_FREE` refined model
    parameters (local model by local model, slots :data:`REFINED`) followed
    by ``y0`` and ``y1`` (``J`` is empty when ``with_jac`` is False).
    """
    n = u.shape[0]
    m = N_FREE + 2
    c = p[kernels.PLM_SIZE:kernels.PLM_SIZE + 5]
    half = 0.5 * p[0]
    y = np.empty(n)
    jac = np.zeros((n if with_jac else 0, m))
    y[0] = y0
    if n > 1:
        y[1] = y1
    if with_jac:
        jac[0, N_FREE] = 1.0
        if n > 1:
            jac[1, N_FREE + 1] = 1.0
    up = u_first
    for k in range(1, n - 1):
        uk = min(max(u[k], -force_limit), force_limit)
        yk, yp = y[k], y[k - 1]
        lo, hi, t, dtdx = _bracket(c, yk)
        a = _local(p, lo, yk, yp, up, uk)
        b = _local(p, hi, yk, yp, up, uk) if hi != lo else a
        raw = (1.0 - t) * a + t * b if hi != lo else a
        y[k + 1] = min(max(raw, -half), half)
        if with_jac and raw == y[k + 1]:
            olo, ohi = 1 + kernels.PLM_LOCAL_SIZE * lo, 1 + kernels.PLM_LOCAL_SIZE * hi
            wl = 1.0 - t if hi != lo else 1.0
            wh = t if hi != lo else 0.0
            fy = -(wl * p[olo + 2] + wh * p[ohi + 2]) + (b - a) * dtdx
            fp = -(wl * p[olo + 3] + wh * p[ohi + 3])
            row = jac[k + 1]
            for q in range(m):
                row[q] = fy * jac[k, q] + fp * jac[k - 1, q]
            _add_direct(p, lo, wl, yk, yp, up, uk, row)
            if wh != 0.0:
                _add_direct(p, hi, wh, yk, yp, up, uk, row)
        up = uk
    return y, jac
