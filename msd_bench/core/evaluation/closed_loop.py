"""Greedy closed loops under a scenario: what a fixed Q-table does on a plant that is not ideal.

One compiled loop serves the nominal validation of observed agents and every
scenario of the suite (:mod:`msd_bench.core.evaluation.scenarios`): the agent sees the
plant through the sensor (noise drawn outside, then quantisation), its
commands act ``delay`` samples late through a first-order lag, a load force may
push from a given time on (on a plant-kind model in its force balance, on an
ARX-type surrogate on its input), and Coulomb friction may hold the mass (plant
kind only). Each sample is the rig's own compiled transition
(:func:`msd_bench.core.rigs.rig.transition`), so a validation on a rig runs through
the same actuator and sensor as the rig node. Metrics are computed by the
caller on the *true* positions this returns.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numba
import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning.q_kernels import encode, greedy, observe, observer_state
from msd_bench.core.learning.qconfig import Learner
from msd_bench.core.physics.kernels import RIG_STATE_SIZE, Kernel
from msd_bench.core.rigs.rig import Conditions, actuate, actuator_state, advance_rig, sense, transition
from msd_bench.core.safety.supervisor import S_ABORT, STATE_SIZE, Limits, filter_step

__all__ = ["Conditions", "SupervisedRuns", "actuate", "actuator_state", "greedy_under", "nominal", "quantise",
           "supervised_runs", "transition"]

FloatArray = NDArray[np.float64]


def nominal(target: float) -> Conditions:
    """The plain validation: set-point ``target``, no sensor, delay, lag, load or friction."""
    return Conditions(float(target), 0.0, 0, 0.0, 0, 0.0, 0.0)


@numba.njit(cache=True)
def quantise(y: float, step: float) -> float:
    """``y`` rounded to the nearest multiple of ``step`` (halves to even); identity for 0.

    The rig's encoder (:func:`msd_bench.core.rigs.rig.sense` without noise), so a scenario's
    quantisation and the rig's are one rule.
    """
    return sense(y, 0.0, step)


_advance = advance_rig
"""The loop's plant step (kept under this name for the baselines' plant half)."""


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
    state = np.zeros(RIG_STATE_SIZE)
    ost = observer_state(lr)
    act = np.zeros(cond.delay + 2)  # actuator_state(cond.delay), the drive off
    for j in range(n):
        state[:] = 0.0
        act[:] = 0.0
        x = 0.0
        xh, dh = observe(lr, obs, ost, 0.0, sense(x, noise[j, 0], cond.quant), 0.0, 0.0, True)
        for k in range(n_steps):
            s = encode(lr.enc, xh - cond.target, dh, cond.target)
            u = lr.actions[greedy(q[j], s)]
            xs[j, k] = x
            us[j, k] = u
            load = cond.load if k >= cond.load_step else 0.0
            e = noise[j, k + 1] if k + 1 < n_steps else 0.0
            _, x, y = transition(model, state, act, k, u, e, cond.delay, cond.lag, load, cond.friction,
                                 cond.quant)
            if k + 1 < n_steps:
                xh, dh = observe(lr, obs, ost, u, y, xh, dh, False)
    return xs, us


class Acts(Protocol):
    """A stepwise controller (:class:`msd_bench.designs.protocol.Controller`): the node's face."""

    def reset(self) -> None:
        """Back to rest."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``."""


class SupervisedRuns(NamedTuple):
    """Runs behind the supervisor, each (runs, steps) except ``aborts`` (runs,)."""

    x: FloatArray
    """True position before command k, m."""
    command: FloatArray
    """The controller's force, N."""
    force: FloatArray
    """The force the supervisor let through (the command unless it overrode), N."""
    reason: NDArray[np.int64]
    """Supervisor reason per sample (``supervisor.REASONS``)."""
    aborts: NDArray[np.int64]
    """Abort code at the end of each run (0 = ran to the end)."""


def supervised_runs(controllers: Sequence[Acts], model: Kernel, cond: Conditions, noise: FloatArray,
                    lim: Limits) -> SupervisedRuns:
    """Run ``controllers[j]`` from rest on row j of ``noise`` behind the compiled ``filter_step``.

    Why the stepwise controllers and not each design's compiled loop: this is the
    node path exactly (a controller sees the measured y_k and sends u_k, the
    supervisor node filters it on the same y_k, the rig runs the force), so an
    in-process supervised validation is the one a bench run behind the supervisor
    node makes, for every kind, without a supervised copy of every design's loop.
    The sample order and the rig transition are :func:`greedy_under`'s: with
    nothing overridden the true positions are the policy's own rollout, bit for bit
    (tests/core/test_supervised_runs.py).
    """
    n, n_steps = noise.shape
    if len(controllers) != n:
        raise InvalidInputError(f"need one controller per noise row, got {len(controllers)} for {n}")
    out = SupervisedRuns(np.empty((n, n_steps)), np.empty((n, n_steps)), np.empty((n, n_steps)),
                         np.zeros((n, n_steps), dtype=np.int64), np.zeros(n, dtype=np.int64))
    for j, ctl in enumerate(controllers):
        ctl.reset()
        _one_supervised(ctl, model, cond, noise[j], lim, out, j)
    return out


def _one_supervised(ctl: Acts, model: Kernel, cond: Conditions, noise: FloatArray, lim: Limits,
                    out: SupervisedRuns, j: int) -> None:
    """Row ``j`` of ``out``: one run from rest (the loop of :func:`supervised_runs`)."""
    n_steps = noise.shape[0]
    state = np.zeros(RIG_STATE_SIZE)
    act = np.zeros(cond.delay + 2)
    st = np.zeros(STATE_SIZE)
    x = 0.0
    y = float(sense(0.0, noise[0], cond.quant))
    for k in range(n_steps):
        u = float(ctl.act(y))
        f, r = filter_step(lim, st, y, cond.target, u)
        out.x[j, k], out.command[j, k], out.force[j, k], out.reason[j, k] = x, u, f, r
        load = cond.load if k >= cond.load_step else 0.0
        e = noise[k + 1] if k + 1 < n_steps else 0.0
        _, x, y = transition(model, state, act, k, f, e, cond.delay, cond.lag, load, cond.friction,
                             cond.quant)
    out.aborts[j] = int(st[S_ABORT])
