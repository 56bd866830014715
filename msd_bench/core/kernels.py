"""Compiled one-step kernels shared by the plant, every surrogate and the learners.

Why one module: Q-learning runs ~10^6 sequential steps per agent, so the model
it learns on must be stepped in compiled code. Every plant-like model is
therefore packed into ``(kind, params)`` — an integer and a flat float64
array — and advanced by :func:`advance`, which numba compiles once. The same
kernel serves the in-process trainer, the ROS surrogate node and the tests,
so a model behaves identically wherever it runs.

State layout (float64[4], zeros = at rest at the origin):

* ``KIND_PLANT``: ``[x_k, v_k, 0, 0]``
* ARX-type models (linear, PLM, NLARX): ``[x_k, x_{k-1}, u_{k-1}, 0]``

``advance(kind, p, state, u_k)`` applies force ``u_k`` over one sample,
updates ``state`` in place and returns ``x_{k+1}``. Every model's output is
projected on the stroke ``[-L/2, L/2]`` like the plant's hard stops.

Parameter layouts (``p``):

* plant: ``[m, c, k, g, h, L, F, dt]`` (see :meth:`PlantParams.as_array`)
* linear: ``[L, n1, n2, d1, d2, u0, y0]`` — deviation form
  ``(y-y0)[k+1] = n1 (u-u0)[k] + n2 (u-u0)[k-1] - d1 (y-y0)[k] - d2 (y-y0)[k-1]``
* PLM: ``[L, 5 x (n1, n2, d1, d2, u0, y0)]`` — five local linear models in
  deviation form around their operating points, all fed the shared blended
  history, blended by the paper's memberships f1..f5 of the current position
* NLARX: ``[L, S, x_scale, u_scale, c0, w1, w2, w3, w4, S x (alpha, b1..b4, b0)]``
  with ``phi = [x_k/xs, x_{k-1}/xs, u_k/us, u_{k-1}/us]`` and
  ``x_{k+1} = xs (c0 + w.phi + sum_j alpha_j sigmoid(b_j.phi + b0_j))``.
  The paper form has ``w = 0``.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

KIND_PLANT = 0
KIND_LINEAR = 1
KIND_PLM = 2
KIND_NLARX = 3

KIND_NAMES = {KIND_PLANT: "plant", KIND_LINEAR: "linear", KIND_PLM: "plm", KIND_NLARX: "nlarx"}

PLM_CENTRES = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
"""Nominal centres of f1..f5 (f1 is 1 below -2, f5 is 1 above 1.5)."""

LINEAR_SIZE = 7
PLM_LOCAL_SIZE = 6
PLM_SIZE = 1 + 5 * PLM_LOCAL_SIZE
NLARX_HEAD = 9
NLARX_UNIT = 6


@numba.njit(cache=True)
def membership(i: int, x: float) -> float:
    """Triangular membership f_{i+1}(x) exactly as printed in the paper (eq. 13).

    The printed outer ramps are asymmetric (f1 ramps over [-2, -1] with slope 1,
    f5 over [1, 1.5] with slope 2); they are kept as printed.
    """
    if i == 0:
        if x < -2.0:
            return 1.0
        if x <= -1.0:
            return -(x + 1.0)
        return 0.0
    if i == 1:
        if x < -1.5:
            return 0.0
        if x <= -1.0:
            return 2.0 * (x + 1.5)
        if x <= -0.5:
            return -2.0 * (x + 0.5)
        return 0.0
    if i == 2:
        if x < -1.0:
            return 0.0
        if x <= 0.0:
            return x + 1.0
        if x <= 1.0:
            return -(x - 1.0)
        return 0.0
    if i == 3:
        if x < 0.5:
            return 0.0
        if x <= 1.0:
            return 2.0 * (x - 0.5)
        if x <= 1.5:
            return -2.0 * (x - 1.5)
        return 0.0
    if x < 1.0:
        return 0.0
    if x <= 1.5:
        return 2.0 * (x - 1.0)
    return 1.0


@numba.njit(cache=True)
def _clip(x: float, lim: float) -> float:
    if x > lim:
        return lim
    if x < -lim:
        return -lim
    if x != x:  # NaN from a diverged model: park it at the origin rather than poison the run
        return 0.0
    return x


@numba.njit(cache=True)
def _plant(p: NDArray[np.float64], s: NDArray[np.float64], u: float) -> float:
    m, c, k, g, h, L, F, dt = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    if u > F:
        u = F
    elif u < -F:
        u = -F
    x, v = s[0], s[1]
    v_new = v + dt * (u - c * v - k * math.sin(g * x) - h * x * x * x) / m
    x_free = x + dt * v_new
    x_new = _clip(x_free, 0.5 * L)
    if x_new != x_free:
        v_new = 0.0
    s[0] = x_new
    s[1] = v_new
    return x_new


@numba.njit(cache=True)
def _local(p: NDArray[np.float64], o: int, s: NDArray[np.float64], u: float) -> float:
    n1, n2, d1, d2, u0, y0 = p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5]
    return y0 + n1 * (u - u0) + n2 * (s[2] - u0) - d1 * (s[0] - y0) - d2 * (s[1] - y0)


@numba.njit(cache=True)
def _plm(p: NDArray[np.float64], s: NDArray[np.float64], u: float) -> float:
    xi = s[0]
    num = 0.0
    den = 0.0
    for i in range(5):
        w = membership(i, xi)
        if w > 0.0:
            num += w * _local(p, 1 + PLM_LOCAL_SIZE * i, s, u)
            den += w
    if den <= 0.0:  # cannot happen with f1..f5 as printed; nearest centre as a guard
        best = 0
        for i in range(5):
            if abs(xi - PLM_CENTRES[i]) < abs(xi - PLM_CENTRES[best]):
                best = i
        return _local(p, 1 + PLM_LOCAL_SIZE * best, s, u)
    return num / den


@numba.njit(cache=True)
def _nlarx(p: NDArray[np.float64], s: NDArray[np.float64], u: float) -> float:
    n_units = int(p[1])
    xs, us = p[2], p[3]
    f0, f1, f2, f3 = s[0] / xs, s[1] / xs, u / us, s[2] / us
    out = p[4] + p[5] * f0 + p[6] * f1 + p[7] * f2 + p[8] * f3
    for j in range(n_units):
        o = NLARX_HEAD + NLARX_UNIT * j
        z = p[o + 1] * f0 + p[o + 2] * f1 + p[o + 3] * f2 + p[o + 4] * f3 + p[o + 5]
        out += p[o] / (1.0 + math.exp(-z))
    return xs * out


@numba.njit(cache=True)
def advance(kind: int, p: NDArray[np.float64], s: NDArray[np.float64], u: float) -> float:
    """Apply force ``u`` for one sample; update ``s`` in place; return the new position."""
    if kind == KIND_PLANT:
        return _plant(p, s, u)
    if kind == KIND_LINEAR:
        y = _local(p, 1, s, u)
    elif kind == KIND_PLM:
        y = _plm(p, s, u)
    else:
        y = _nlarx(p, s, u)
    y = _clip(y, 0.5 * p[0])
    s[1] = s[0]
    s[0] = y
    s[2] = u
    return y


@numba.njit(cache=True)
def rollout(
    kind: int, p: NDArray[np.float64], u: NDArray[np.float64], state: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Free-run simulation: ``x[k]`` is the position before ``u[k]`` acts (``x[0]`` = state)."""
    n = u.shape[0]
    x = np.empty(n)
    for k in range(n):
        x[k] = state[0]
        advance(kind, p, state, u[k])
    return x


@numba.njit(cache=True)
def simulate_plant(
    p: NDArray[np.float64], u: NDArray[np.float64], x0: float, v0: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Plant trajectory (x, v) sampled before each force acts."""
    n = u.shape[0]
    x = np.empty(n)
    v = np.empty(n)
    s = np.zeros(4)
    s[0] = x0
    s[1] = v0
    for k in range(n):
        x[k] = s[0]
        v[k] = s[1]
        _plant(p, s, u[k])
    return x, v


@numba.njit(cache=True)
def one_step(
    kind: int, p: NDArray[np.float64], x: NDArray[np.float64], u: NDArray[np.float64]
) -> NDArray[np.float64]:
    """One-step-ahead prediction from measured history (ARX-type kinds only).

    ``yhat[k]`` predicts ``x[k]`` from ``x[k-1], x[k-2], u[k-1], u[k-2]``;
    the first two samples are copied from the measurement.
    """
    n = x.shape[0]
    yhat = x.copy()
    s = np.zeros(4)
    for k in range(2, n):
        s[0] = x[k - 1]
        s[1] = x[k - 2]
        s[2] = u[k - 2]
        yhat[k] = advance(kind, p, s, u[k - 1])
    return yhat
