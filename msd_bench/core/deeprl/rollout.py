"""A trained network in closed loop: a compiled batch rollout and the stepwise controller.

Both run one compiled decision, :func:`decide`, so a deterministic policy gives
the same force bit for bit in-process (:func:`greedy_under`) and over ROS
(:class:`NetworkController`, fed one measurement at a time by the agent node).
The rollout has :func:`msd_bench.core.evaluation.closed_loop.greedy_under`'s semantics:
the agent measures through the sensor (noise drawn by the caller, then
quantisation, then the ADC clip the environment applies, which the decision
makes), and the plant under test is the one loop's
(:func:`msd_bench.core.evaluation.closed_loop.run`: delay, lag, load, friction).
Metrics are the caller's, on the true positions returned.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.deeprl.mlp import Net, check_net, greedy
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation import closed_loop
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics.kernels import Kernel

FloatArray = NDArray[np.float64]


@kernel
def measure(x: float, noise: float, quant: float, bound: float) -> float:
    """What the agent reads for true position ``x``: noise, quantisation, then the ADC's range."""
    y = closed_loop.quantise(x + noise, quant)
    return min(max(y, -bound), bound)


@kernel
def decide(net: Net, j: int, forces: FloatArray, y: float, y_prev: float, target: float,
           u_prev: float, first: bool) -> float:
    """Policy ``j``'s force for measurement ``y`` (the first of an episode has no difference)."""
    dy = 0.0 if first else y - y_prev
    u: float = forces[greedy(net, j, y, dy, target, u_prev)]
    return u


class NetRun(NamedTuple):
    """A stack of policies as the one closed loop (:func:`closed_loop.run`) reads it: run j uses policy j."""

    net: Net
    """The stacked weights."""
    forces: FloatArray
    """The force of each network output, N."""
    bound: float
    """The measurement's clip, m (``inf``: none; the environment's lies at the stroke plus ten noise
    deviations plus one quantisation step, which a position on the stroke never reaches)."""
    memory: FloatArray
    """[last clipped measurement, last command]."""


@closed_loop.decision(NetRun)
@kernel
def net_decide(c: NetRun, j: int, k: int, y: float, target: float) -> float:
    """Policy j's force for ``y`` clipped to the ADC's range, as the environment observes it."""
    yc = min(max(y, -c.bound), c.bound)
    first = k == 0
    u = decide(c.net, j, c.forces, yc, yc if first else c.memory[0], target, 0.0 if first else c.memory[1],
               first)
    c.memory[0], c.memory[1] = yc, u
    return u


def greedy_under(model: Kernel, net: Net, forces: FloatArray, cond: Conditions, noise: FloatArray,
                 bound: float) -> tuple[FloatArray, FloatArray]:
    """Each policy's greedy run from rest in the one closed loop; ``noise[j, k]`` is added to the k-th
    measurement of run j, which the agent reads clipped to ±``bound``.

    Returns (true x, commanded u), each (n_policies, n_steps); ``x[j, k]`` is
    the position before command ``u[j, k]`` is issued.
    """
    c = NetRun(net, np.ascontiguousarray(forces, dtype=np.float64), float(bound), np.zeros(2))
    t = closed_loop.run(model, c, cond, np.ascontiguousarray(noise, dtype=np.float64), closed_loop.AT_REST,
                        closed_loop.NO_LIMITS, False, False, 0)
    return t.x, t.command


class NetworkController:
    """The stepwise form: one measured position in, one force out (the agent node's loop).

    ``reset()`` starts an episode (towards ``target``, or a new one if given:
    the stepwise face of the baseline designs, :mod:`msd_bench.core.baselines.designs`);
    ``act(y)`` takes the measurement of sample k and returns the force for it.
    The observation is built exactly as the environment builds it (the first
    difference of an episode is 0, the last force is the one this controller
    commanded).
    """

    def __init__(self, net: Net, forces: FloatArray, index: int = 0, target: float = 1.0) -> None:
        check_net(net)
        if not 0 <= index < net.w1.shape[0]:
            raise InvalidInputError(f"policy index {index} is not in 0..{net.w1.shape[0] - 1}")
        if np.asarray(forces).shape != (net.w3.shape[1],):
            raise InvalidInputError(f"need one force per network output ({net.w3.shape[1]}), got {forces!r}")
        self.net, self.index = net, index
        self.forces = np.ascontiguousarray(forces, dtype=np.float64)
        self.target = 0.0
        self._y_prev = 0.0
        self._u_prev = 0.0
        self._first = True
        self.reset(target)

    def reset(self, target: float | None = None) -> None:
        """Start an episode from rest towards ``target`` (m; the last one if None)."""
        if target is not None:
            if not math.isfinite(target):
                raise InvalidInputError(f"target must be finite, got {target!r}")
            self.target = float(target)
        self._u_prev, self._first = 0.0, True

    def act(self, y: float) -> float:
        """The force (N) for measurement ``y`` (m) of the current sample."""
        if not math.isfinite(y):
            raise InvalidInputError(f"measurement must be finite, got {y!r}")
        y_prev = y if self._first else self._y_prev
        u = float(decide(self.net, self.index, self.forces, float(y), y_prev, self.target,
                         self._u_prev, self._first))
        self._y_prev, self._u_prev, self._first = float(y), u, False
        return u
