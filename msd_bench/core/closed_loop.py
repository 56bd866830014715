"""Greedy closed loops under a scenario: what a fixed Q-table does on a plant that is not ideal.

One compiled loop serves the nominal validation of observed agents and every
scenario of the suite (:mod:`msd_bench.core.scenarios`): the agent sees the
plant through the sensor (noise drawn outside, then quantisation), its
commands act ``delay`` samples late, a load force may push from a given time
on (on a plant-kind model in its force balance, on an ARX-type surrogate on
its input), and Coulomb friction may hold the mass (plant kind only). Metrics are computed by the
caller on the *true* positions this returns.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from msd_bench.core import kernels
from msd_bench.core.kernels import KIND_PLANT, Kernel
from msd_bench.core.qconfig import Learner
from msd_bench.core.qlearning import encode, greedy, observe, observer_state

FloatArray = NDArray[np.float64]


class Conditions(NamedTuple):
    """A scenario as the compiled loop reads it (plant multipliers are already in the model)."""

    target: float
    """Set-point, m."""
    quant: float
    """Sensor quantisation step, m (0 = none)."""
    delay: int
    """Actuator delay, samples."""
    load: float
    """Force added after saturation from ``load_step`` on, N (an ARX-type model takes it on its input)."""
    load_step: int
    """First sample the load acts on."""
    friction: float
    """Coulomb friction, N (plant kind only)."""


def nominal(target: float) -> Conditions:
    """The plain validation: set-point ``target``, no sensor, delay, load or friction."""
    return Conditions(float(target), 0.0, 0, 0.0, 0, 0.0)


@numba.njit(cache=True)
def quantise(y: float, step: float) -> float:
    """``y`` rounded to the nearest multiple of ``step`` (halves away from zero); identity for 0."""
    if step <= 0.0:
        return y
    return step * math.floor(y / step + 0.5)


@numba.njit(cache=True)
def _advance(model: Kernel, state: FloatArray, u: float, load: float, friction: float) -> float:
    """One step of the loop's plant: a load acts on every kind, friction on the plant kind only.

    A load on an ARX-type model enters its input (:func:`kernels.advance_loaded`): that is what
    lets a surrogate stand in for the plant under a load in the robust agent's design loop.
    """
    if model.kind == KIND_PLANT and (load != 0.0 or friction != 0.0):
        x, v = kernels.plant_step_loaded(kernels.plant_of(model.params), state[0], state[1], u, load,
                                         friction)
        state[0] = x
        state[1] = v
        return x
    if load != 0.0:
        return kernels.advance_loaded(model, state, u, load)
    return kernels.advance(model, state, u)


@numba.njit(cache=True)
def greedy_under(model: Kernel, lr: Learner, q: FloatArray, cond: Conditions,
                 noise: FloatArray, obs: Kernel) -> tuple[FloatArray, FloatArray]:
    """Each table's greedy run from rest; ``noise[j, k]`` is added to the k-th measurement of run j.

    ``obs`` is the model a ``model`` observer predicts with (the surrogate the
    agent trained on; ignored by other observers). Returns (true x, commanded
    u), each (n_tables, n_steps); ``x[j, k]`` is the position before command
    ``u[j, k]`` is issued.
    """
    n, n_steps = noise.shape
    xs = np.empty((n, n_steps))
    us = np.empty((n, n_steps))
    state = np.zeros(4)
    ost = observer_state(lr)
    queue = np.zeros(cond.delay + 1)
    for j in range(n):
        state[:] = 0.0
        queue[:] = 0.0
        x = 0.0
        xh, dh = observe(lr, obs, ost, 0.0, quantise(x + noise[j, 0], cond.quant), 0.0, 0.0, True)
        for k in range(n_steps):
            s = encode(lr.enc, xh - cond.target, dh, cond.target)
            u = lr.actions[greedy(q[j], s)]
            xs[j, k] = x
            us[j, k] = u
            queue[k % (cond.delay + 1)] = u
            applied = queue[(k + 1) % (cond.delay + 1)]
            load = cond.load if k >= cond.load_step else 0.0
            x = _advance(model, state, applied, load, cond.friction)
            if k + 1 < n_steps:
                y = quantise(x + noise[j, k + 1], cond.quant)
                xh, dh = observe(lr, obs, ost, u, y, xh, dh, False)
    return xs, us
