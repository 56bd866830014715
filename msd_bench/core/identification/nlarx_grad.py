"""Compiled loss and gradient of the NLARX simulation stage (batched truncated rollouts).

Why: the improved NLARX's simulation stage (:func:`msd_bench.core.identification.nlarx._simulation_stage`)
runs Adam on the mean squared free-run error of 64 rollouts of 200 steps.
In torch every step is a handful of tiny tensor operations recorded for
autograd, and the Python-level loop and its backward pass were about half of
the NLARX's identification time. Here the same rollout (the kernel formula,
clamped at the stops like the kernel) is run in compiled code and
differentiated by hand, backwards through time, with respect to the
*effective* weights ``(c0, w, alpha, beta, beta0)`` of
:meth:`msd_bench.core.identification.nlarx.NlarxNet.effective`; torch then maps that
gradient onto the network's own parameters through ``effective`` (a small
linear map), and Adam steps exactly as before. Same model, same loss, same
optimiser; ``tests/core/test_nlarx_grad.py`` pins loss and gradient to torch's (both stages:
the one-step stage's loss, :func:`one_step_loss_grad`, is the improved form's only).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.kernel_cache import kernel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@kernel
def _sigmoid(z: float) -> float:
    return 1.0 / (1.0 + math.exp(-z))


@kernel
def rollout_loss_grad(
    c0: float, w: FloatArray, alpha: FloatArray, beta: FloatArray, beta0: FloatArray,
    x: FloatArray, xf: FloatArray, u: FloatArray, starts: IntArray, horizon: int, lim: float,
) -> tuple[float, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Loss ``mean((pred - x[idx + 1])²)`` of rollouts from ``starts`` and its gradient.

    Each rollout ``b`` starts from ``(xf[s], xf[s - 1], u[s - 1])`` with
    ``s = starts[b]`` and is driven by ``u[s : s + horizon]``; every step is
    ``clamp(c0 + φ·w + Σ α σ(β φ + β0), -lim, lim)`` with ``φ = (x_k, x_{k-1}, u_k, u_{k-1})``.
    Returns ``(loss, dc0, dw, dalpha, dbeta, dbeta0)`` (``dc0`` as a 1-element array).
    """
    n_b, units = starts.shape[0], alpha.shape[0]
    scale = 2.0 / (n_b * horizon)
    loss = 0.0
    gc0 = np.zeros(1)
    gw = np.zeros(4)
    ga = np.zeros(units)
    gb = np.zeros((units, 4))
    gb0 = np.zeros(units)
    phi = np.zeros((horizon, 4))
    sig = np.zeros((horizon, units))
    live = np.zeros(horizon)
    err = np.zeros(horizon)
    graw = np.zeros(horizon + 2)  # dL/d(raw output) of each step, 0 beyond the horizon
    fx = np.zeros(horizon + 2)  # d raw_k / d x_k (the step's own current position)
    fp = np.zeros(horizon + 2)  # d raw_k / d x_{k-1}
    for b in range(n_b):
        s = starts[b]
        xk, xp, up = xf[s], xf[s - 1], u[s - 1]
        for k in range(horizon):
            uk = u[s + k]
            phi[k, 0], phi[k, 1], phi[k, 2], phi[k, 3] = xk, xp, uk, up
            raw = c0 + w[0] * xk + w[1] * xp + w[2] * uk + w[3] * up
            for j in range(units):
                z = beta[j, 0] * xk + beta[j, 1] * xp + beta[j, 2] * uk + beta[j, 3] * up + beta0[j]
                sig[k, j] = _sigmoid(z)
                raw += alpha[j] * sig[k, j]
            xn = min(max(raw, -lim), lim)
            live[k] = 1.0 if -lim <= raw <= lim else 0.0
            err[k] = xn - x[s + k + 1]
            loss += err[k] * err[k]
            xp, xk, up = xk, xn, uk
        for k in range(horizon - 1, -1, -1):
            g = scale * err[k] + fx[k + 1] * graw[k + 1] + fp[k + 2] * graw[k + 2]
            graw[k] = g * live[k]
            dx, dp = w[0], w[1]
            gr = graw[k]
            gc0[0] += gr
            for q in range(4):
                gw[q] += gr * phi[k, q]
            for j in range(units):
                sj = sig[k, j]
                d = alpha[j] * sj * (1.0 - sj)
                dx += d * beta[j, 0]
                dp += d * beta[j, 1]
                ga[j] += gr * sj
                gb0[j] += gr * d
                for q in range(4):
                    gb[j, q] += gr * d * phi[k, q]
            fx[k], fp[k] = dx, dp
    return loss / (n_b * horizon), gc0, gw, ga, gb, gb0


@kernel
def one_step_loss_grad(
    c0: float, w: FloatArray, alpha: FloatArray, beta: FloatArray, beta0: FloatArray,
    phi: FloatArray, target: FloatArray, scale: float,
) -> tuple[float, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Loss ``mean(((pred - target) / scale)²)`` of the one-step predictions and its gradient by the
    effective weights (the one-step stage, :func:`msd_bench.core.identification.nlarx._one_step`; weight
    decay is torch's, on the parameters themselves).

    Why: full-batch L-BFGS evaluates this about 330 times on every row of the record, and torch's
    forward and backward over a 12,000 × 10 hidden layer, op by op, was most of each NLARX kind's
    identification time; one pass per row here computes both.
    """
    n, units = phi.shape[0], alpha.shape[0]
    g_c0 = 0.0
    g_w = np.zeros(4)
    g_alpha = np.zeros(units)
    g_beta = np.zeros((units, 4))
    g_beta0 = np.zeros(units)
    hidden = np.empty(units)
    loss = 0.0
    for i in range(n):
        p0, p1, p2, p3 = phi[i, 0], phi[i, 1], phi[i, 2], phi[i, 3]
        pred = c0 + p0 * w[0] + p1 * w[1] + p2 * w[2] + p3 * w[3]
        for j in range(units):
            s = _sigmoid(p0 * beta[j, 0] + p1 * beta[j, 1] + p2 * beta[j, 2] + p3 * beta[j, 3] + beta0[j])
            hidden[j] = s
            pred += alpha[j] * s
        err = (pred - target[i]) / scale
        loss += err * err
        g = 2.0 * err / (scale * n)
        g_c0 += g
        g_w[0] += g * p0
        g_w[1] += g * p1
        g_w[2] += g * p2
        g_w[3] += g * p3
        for j in range(units):
            s = hidden[j]
            g_alpha[j] += g * s
            d = g * alpha[j] * s * (1.0 - s)
            g_beta0[j] += d
            g_beta[j, 0] += d * p0
            g_beta[j, 1] += d * p1
            g_beta[j, 2] += d * p2
            g_beta[j, 3] += d * p3
    return loss / n, np.array([g_c0]), g_w, g_alpha, g_beta, g_beta0
