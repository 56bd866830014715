"""LQR baseline with integral action, on the identified model linearised at the set-point.

Design: the model (the grey-box for ``greybox+lqr``; any kind works) is
linearised at its equilibrium at the set-point (:func:`base.operating_point`),
augmented with the integral of the position error ``xi+ = xi + dt (x - x*)``,
and python-control's ``dlqr`` gives the state feedback. Weights by Bryson's
rule — each term divided by the square of its acceptable size (position,
velocity, integral, force) — so the constants read in units.

Observer (ours, not the robust Q-learner's): the fixed-gain filter of
:mod:`~msd_bench.core.baselines.base`, which runs the *nonlinear* identified
model as its predictor and corrects it with a steady-state Kalman gain
designed on the linearisation augmented with a force-bias state. Why not the
robust agent's ``model`` observer: its gains were tuned for a 50-sample lead
error feeding a Q-table; here the feedback needs the velocity and an unbiased
position, which a Kalman design with a bias state gives by construction.
The bias estimate only keeps the estimate unbiased (under a load or a wrong
equilibrium force); the offset is removed by the integral action.

Output: ``u_eq - K z`` saturated to ±F and quantised to the paper's five
forces; the integral is frozen while the command is saturated and the error
would drive it further (conditional integration, as the PID).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import control
import numpy as np
from numpy.typing import NDArray

from msd_bench.core.baselines import base
from msd_bench.core.baselines.base import Observer, ObserverNoise
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import closed_loop
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics.kernels import POS, Kernel
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class LqrOptions:
    """Bryson's-rule sizes (chosen on the design identification seeds, docs/baselines.md)."""

    position: float = 0.05
    """Acceptable position error, m."""
    velocity: float = 0.5
    """Acceptable velocity, m/s."""
    integral: float = 0.05
    """Acceptable integral of the position error, m s."""
    force: float = 10.0
    """Acceptable force deviation from the equilibrium force, N."""
    noise: ObserverNoise = field(default_factory=ObserverNoise)
    """What the observer's Kalman gain is designed for."""


class LqrLaw(NamedTuple):
    """The state feedback as compiled code reads it."""

    k: FloatArray
    """Gains on the model's used slots' deviations, then on the error integral."""
    s_eq: FloatArray
    """The model's slots at the equilibrium."""
    u_eq: float
    """Equilibrium force, N."""
    target: float
    """Set-point, m."""
    force: float
    """Saturation ±F, N."""
    dt: float
    """Sample time, s."""
    forces: FloatArray
    """Alphabet the output is quantised to."""


@dataclass(frozen=True)
class LqrDesign:
    """An LQR design: the law, its observer and the facts of the design."""

    law: LqrLaw
    """The compiled feedback."""
    observer: Observer
    """The compiled observer (on the model designed on)."""
    facts: dict[str, Any]
    """Weights, closed-loop pole radius of the linear design, the observer's gains."""
    surrogate: str
    """The model it was designed on."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready artifact."""
        w = self.law
        return {"design": "lqr", "surrogate": self.surrogate, "k": w.k.tolist(), "s_eq": w.s_eq.tolist(),
                "u_eq": w.u_eq, "target": w.target, "force": w.force, "dt": w.dt,
                "forces": w.forces.tolist(), "observer_gain": self.observer.gain.tolist(), **self.facts}


def augmented(op: base.OperatingPoint, dt: float) -> tuple[FloatArray, FloatArray]:
    """The linearisation with the error integral appended as a last state."""
    n = op.b.size
    a = np.zeros((n + 1, n + 1))
    a[:n, :n] = op.a
    a[n, POS] = dt
    a[n, n] = 1.0
    b = np.zeros((n + 1, 1))
    b[:n, 0] = op.b
    return a, b


def weights(op: base.OperatingPoint, opt: LqrOptions) -> tuple[FloatArray, FloatArray]:
    """Bryson's Q (position, velocity, integral) and R (force) for the augmented state."""
    n = op.b.size
    pos = np.zeros(n + 1)
    pos[POS] = 1.0
    vel = np.zeros(n + 1)
    vel[:n] = op.velocity
    integ = np.zeros(n + 1)
    integ[n] = 1.0
    q = (np.outer(pos, pos) / opt.position ** 2 + np.outer(vel, vel) / opt.velocity ** 2
         + np.outer(integ, integ) / opt.integral ** 2)
    return q, np.array([[1.0 / opt.force ** 2]])


def design(model: StepModel, target: float, force: float, dt: float,
           options: LqrOptions | None = None) -> LqrDesign:
    """The LQR with integral action and its observer on ``model`` at ``target`` (deterministic)."""
    opt = options or LqrOptions()
    if min(opt.position, opt.velocity, opt.integral, opt.force) <= 0:
        raise ConfigError("LQR options: every Bryson size must be > 0")
    if abs(dt - model.dt) > 1e-12:
        raise ConfigError(f"design dt {dt} differs from the model's {model.dt}")
    op = base.operating_point(model, target)
    a, b = augmented(op, dt)
    q, r = weights(op, opt)
    k, _, poles = control.dlqr(a, b, q, r)
    law = LqrLaw(np.ascontiguousarray(k[0]), op.s_eq, op.u_eq, float(target), float(force), float(dt),
                 base.alphabet(force))
    facts = {"sizes": {"position": opt.position, "velocity": opt.velocity, "integral": opt.integral,
                       "force": opt.force},
             "observer_noise": opt.noise._asdict(),
             "closed_loop_pole_radius": float(np.max(np.abs(poles)))}
    return LqrDesign(law, base.make_observer(model, op, opt.noise), facts, model.name)


@kernel
def act(w: LqrLaw, ob: Observer, ost: FloatArray, cs: FloatArray, y: float, first: bool) -> float:
    """The force for measurement ``y``; ``ost`` is the observer's state, ``cs`` = [integral, last u]."""
    if first:
        base.observe_first(ob, ost, y)
        cs[:] = 0.0
    else:
        base.observe(ob, ost, cs[1], y)
    n = w.s_eq.size
    e = ost[POS] - w.target
    u = w.u_eq - w.k[n] * cs[0]
    for i in range(n):
        u -= w.k[i] * (ost[i] - w.s_eq[i])
    if not ((u > w.force and e < 0.0) or (u < -w.force and e > 0.0)):
        cs[0] += w.dt * e
    u = base.nearest(w.forces, min(max(u, -w.force), w.force))
    cs[1] = u
    return u


class LqrRun(NamedTuple):
    """The LQR as the one closed loop (:func:`closed_loop.run`) reads it: law, observer, their memory."""

    law: LqrLaw
    """The state feedback."""
    observer: Observer
    """The observer the law reads."""
    ost: FloatArray
    """The observer's state (:func:`base.observer_state`)."""
    memory: FloatArray
    """[integral, last command]."""


@closed_loop.decision(LqrRun)
@kernel
def decide(c: LqrRun, j: int, k: int, y: float, target: float) -> float:
    """The LQR's force for ``y`` (its set-point is the one it was designed at; the first sample resets it)."""
    return act(c.law, c.observer, c.ost, c.memory, y, k == 0)


class Lqr:
    """The stepwise form for an agent node: ``reset()``, then ``act(y)`` once per sample."""

    def __init__(self, d: LqrDesign) -> None:
        self.law, self.observer = d.law, d.observer
        self.ost = base.observer_state(d.observer)
        self.cs = np.zeros(2)
        self.first = True

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""
        self.first = True

    def act(self, y: float) -> float:
        """The force for the measured position ``y`` (m)."""
        u = float(act(self.law, self.observer, self.ost, self.cs, base.measured(y), self.first))
        self.first = False
        return u


Options = LqrOptions
"""The baseline face (:mod:`msd_bench.core.baselines.catalogue`): its keyword options."""
Stepwise = Lqr
"""The baseline face: the stepwise form built from a design."""


def rollout(plant: Kernel, d: LqrDesign, cond: Conditions,
            noise: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The baseline face: every row of ``noise`` one run from rest in the one closed loop; (true x, u)."""
    c = LqrRun(d.law, d.observer, base.observer_state(d.observer), np.zeros(2))
    t = closed_loop.run(plant, c, cond, noise, closed_loop.AT_REST, closed_loop.NO_LIMITS, False, False, 0)
    return t.x, t.command
