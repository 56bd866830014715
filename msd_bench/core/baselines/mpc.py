"""Finite-alphabet MPC baseline: a search over the paper's five forces on an identified surrogate.

Every sample the controller searches force sequences over a horizon of
``sum(blocks)`` samples (default 4 + 12 + 24 + 60 = 100 = 1 s) with **move
blocking**: the force is held constant over each block, so a plan is one force
per block, 5^4 = 625 plans. The plans form a **tree whose nodes are blocks**:
a node advances the surrogate (the compiled ``kernels.advance_loaded``, so any
model kind works) once per sample of its block from its parent's state, so
plans sharing a prefix share its simulation. The search is depth-first with
**branch and bound**: stage costs are non-negative, so a node whose partial
cost already reaches the best complete plan is cut — the result is the exact
minimum over all 625 plans, found in a fraction of the work. Optionally
(``tail``) the prediction continues after the last block in *hold mode*: the
alphabet's way of holding still (:func:`_hold_tail`); cheaper, but it tracked
worse on the design seeds (docs/baselines.md).

Integral action on the reference: the plans track ``x* - ki * integral of
(x_hat - x*)``, clamped. Without it the receding-horizon search settles into
limit cycles whose mean is 4.7-8.9 % off at ±0.5 and ±1.5 m, even on the exact
plant model: the offset is the search's own, which the bias state cannot see.

Cost (ours, stated): the sum over the horizon of the squared predicted
tracking error ``(x - r)²`` (m², r the reference below) plus ``move_weight`` times the squared change
of force at each block start (N², the first against the last command) — a
small penalty that breaks the near-ties between plans which hold the mass
equally well by switching more.

Observer: the fixed-gain filter of :mod:`~msd_bench.core.baselines.base` on
the same surrogate (a steady-state Kalman gain at the set-point's
linearisation, with a force-bias state). The bias estimate drives every
prediction as a constant load, which makes the MPC offset-free against a
load or a surrogate whose equilibrium force is wrong.

The first force of the best plan is sent (receding horizon); it is an
alphabet force by construction.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.baselines import base
from msd_bench.core.baselines.base import Observer, ObserverNoise
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import closed_loop
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import POS, Kernel
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MIN_HORIZON_S = 1.0
"""The shortest horizon allowed, s: the mass needs about that long to reach a set-point."""


@dataclass(frozen=True)
class MpcOptions:
    """The search's shape and cost (chosen on the design identification seeds, docs/baselines.md)."""

    blocks: tuple[int, ...] = (4, 12, 24, 60)
    """Samples per searched block, first to last."""
    tail: int = 0
    """Samples of the hold-mode tail after the blocks; blocks plus tail are the horizon (at least 1 s)."""
    move_weight: float = 1e-6
    """Weight of the squared force change at each block start, m²/N²."""
    ki: float = 0.5
    """Integral action on the reference, 1/s (0: none; see the module docstring)."""
    max_shift: float = 0.3
    """Largest reference shift the integral may make, m."""
    noise: ObserverNoise = field(default_factory=ObserverNoise)
    """What the observer's Kalman gain is designed for."""


class MpcLaw(NamedTuple):
    """The search as compiled code reads it."""

    model: Kernel
    """The surrogate the plans are simulated on."""
    blocks: IntArray
    """Samples per block."""
    forces: FloatArray
    """The alphabet."""
    target: float
    """Set-point, m."""
    move_weight: float
    """Weight of the squared force change at a block start."""
    order: IntArray
    """Row i: the force indices nearest force i first (children are searched in that order)."""
    tail: int
    """Samples of the hold-mode tail after the last block (0: none)."""
    hold: float
    """The model's equilibrium force at the set-point, N (what the tail modulates)."""
    ki: float
    """Integral gain on the reference: the plans track ``target - ki * integral of (x_hat - target)``, 1/s."""
    max_shift: float
    """Largest shift of the reference the integral may make, m."""
    dt: float
    """Sample time, s."""


@dataclass(frozen=True)
class MpcDesign:
    """An MPC design: the search, its observer, and the facts."""

    law: MpcLaw
    """The compiled search."""
    observer: Observer
    """The compiled observer (on the same surrogate)."""
    facts: dict[str, Any]
    """Horizon, blocks, cost weights, observer design."""
    surrogate: str
    """The surrogate it searches on."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready artifact."""
        w = self.law
        return {"design": "mpc", "surrogate": self.surrogate, "target": w.target,
                "forces": w.forces.tolist(), "observer_gain": self.observer.gain.tolist(), **self.facts}


def design(model: StepModel, target: float, force: float, dt: float,
           options: MpcOptions | None = None) -> MpcDesign:
    """The MPC on ``model`` for ``target`` (deterministic)."""
    opt = options or MpcOptions()
    blocks = np.asarray(opt.blocks, dtype=np.int64)
    if blocks.ndim != 1 or blocks.size == 0 or np.any(blocks < 1):
        raise ConfigError(f"MPC blocks must be positive sample counts, got {opt.blocks}")
    if not 0 <= opt.tail <= 10_000:
        raise ConfigError(f"MPC tail must be 0..10000 samples, got {opt.tail}")
    horizon = int(blocks.sum()) + int(opt.tail)
    if horizon * dt < MIN_HORIZON_S - 1e-12:
        raise ConfigError(f"MPC horizon {horizon * dt:g} s is shorter than {MIN_HORIZON_S} s")
    if not opt.move_weight >= 0:
        raise ConfigError(f"MPC move_weight must be >= 0, got {opt.move_weight}")
    if abs(dt - model.dt) > 1e-12:
        raise ConfigError(f"design dt {dt} differs from the model's {model.dt}")
    op = base.operating_point(model, target)
    forces = base.alphabet(force)
    law = MpcLaw(model.kernel, blocks, forces, float(target), float(opt.move_weight), search_order(forces),
                 int(opt.tail), op.u_eq, float(opt.ki), float(opt.max_shift), float(dt))
    facts = {"blocks": [int(b) for b in blocks], "tail": int(opt.tail), "horizon_s": float(horizon * dt),
             "plans": int(5 ** blocks.size), "move_weight": opt.move_weight, "u_eq": op.u_eq,
             "observer_noise": opt.noise._asdict()}
    return MpcDesign(law, base.make_observer(model, op, opt.noise), facts, model.name)


def search_order(forces: FloatArray) -> IntArray:
    """Per force, every force index sorted by distance from it (stable: ties keep alphabet order).

    Why: the search tries first the force its parent block used (at the root: the
    last command), which is usually near the best plan, so the bound is tight early.
    """
    return np.array([np.argsort(np.abs(forces - f), kind="stable") for f in forces], dtype=np.int64)


class Workspace(NamedTuple):
    """Scratch arrays of the search (allocated once, reused every sample)."""

    states: FloatArray
    """Model state at the start of each depth (depth + 1, the model's state length)."""
    costs: FloatArray
    """Partial cost at the start of each depth."""
    choice: IntArray
    """How many children have been tried at each depth (-1: none yet)."""
    picked: IntArray
    """The force index of the child being expanded at each depth."""
    best: IntArray
    """The best plan so far (force index per block); kept between samples as the next warm start."""


def workspace(law: MpcLaw) -> Workspace:
    """Scratch arrays for ``law``'s tree."""
    depth = law.blocks.size
    return Workspace(np.zeros((depth + 1, kernels.state_size(law.model.kind))), np.zeros(depth + 1),
                     np.zeros(depth, dtype=np.int64), np.zeros(depth, dtype=np.int64),
                     np.full(depth, -1, dtype=np.int64))


@kernel
def _hold_tail(w: MpcLaw, s: FloatArray, bias: float, ref: float, c: float, best: float) -> float:
    """``c`` plus the tracking cost of the tail in hold mode (stops adding once it reaches ``best``).

    Hold mode is the 5-force actuator's way of holding still: a first-order
    sigma-delta modulation of the force that holds the model at the set-point
    (its equilibrium force minus the bias estimate), i.e. the bracketing
    alphabet forces in the right duty cycle.
    """
    want = w.hold - bias
    acc = 0.0
    for _ in range(w.tail):
        a = base.nearest(w.forces, want + acc)
        acc += want - a
        e = kernels.advance_loaded(w.model, s, a, bias) - ref
        c += e * e
        if c >= best:
            break
    return c


@kernel
def plan(w: MpcLaw, ws: Workspace, s0: FloatArray, bias: float, u_last: float, ref: float) -> float:
    """The first force of the cheapest plan tracking ``ref`` from ``s0`` (exact minimum, branch and bound).

    Children of a block are searched nearest-first around the force the last
    sample's best plan had in that block (a warm start: the first plan searched
    is the last one, so the bound is tight from the start); before any plan,
    around the last command. Among equally cheap plans the first one searched
    wins (deterministic).
    """
    depth = w.blocks.size
    na = w.forces.size
    if ws.best[0] < 0:
        root = 0
        for i in range(na):
            if abs(w.forces[i] - u_last) < abs(w.forces[root] - u_last):
                root = i
        ws.best[:] = root
    ws.states[0, :] = s0
    ws.costs[0] = 0.0
    ws.choice[:] = -1
    best = np.inf
    found = ws.best.copy()
    level = 0
    while level >= 0:
        ws.choice[level] += 1
        if ws.choice[level] >= na:
            ws.choice[level] = -1
            level -= 1
            continue
        ws.picked[level] = w.order[ws.best[level], ws.choice[level]]
        a = w.forces[ws.picked[level]]
        prev = u_last if level == 0 else w.forces[ws.picked[level - 1]]
        c = ws.costs[level] + w.move_weight * (a - prev) * (a - prev)
        s = ws.states[level + 1]
        s[:] = ws.states[level]
        for _ in range(w.blocks[level]):
            e = kernels.advance_loaded(w.model, s, a, bias) - ref
            c += e * e
            if c >= best:
                break
        if c >= best:
            continue
        if level == depth - 1:
            c = _hold_tail(w, s, bias, ref, c, best)
            if c < best:
                best = c
                found[:] = ws.picked
            continue
        ws.costs[level + 1] = c
        level += 1
    ws.best[:] = found
    first: float = w.forces[found[0]]
    return first


@kernel
def act(w: MpcLaw, ob: Observer, ws: Workspace, ost: FloatArray, cs: FloatArray, y: float,
        first: bool) -> float:
    """The force for measurement ``y``; ``ost`` is the observer's state, ``cs`` = [last u, integral]."""
    if first:
        base.observe_first(ob, ost, y)
        cs[:] = 0.0
        ws.best[:] = -1
    else:
        base.observe(ob, ost, cs[0], y)
    ref = w.target - w.ki * cs[1]
    u = plan(w, ws, base.model_state(ob, ost), ost[ob.size], cs[0], ref)
    shift = w.ki * (cs[1] + w.dt * (ost[POS] - w.target))
    if abs(shift) <= w.max_shift:  # clamped integral: it cannot wind up beyond the largest shift
        cs[1] += w.dt * (ost[POS] - w.target)
    cs[0] = u
    return u


class MpcRun(NamedTuple):
    """The MPC as the one closed loop (:func:`closed_loop.run`) reads it: law, observer, their memory."""

    law: MpcLaw
    """The plan's settings and prediction model."""
    observer: Observer
    """The observer the plan starts from."""
    ws: Workspace
    """The plan's scratch arrays (:func:`workspace`)."""
    ost: FloatArray
    """The observer's state (:func:`base.observer_state`)."""
    memory: FloatArray
    """[last command, integral]."""


@closed_loop.decision(MpcRun)
@kernel
def decide(c: MpcRun, j: int, k: int, y: float, target: float) -> float:
    """The MPC's force for ``y`` (its set-point is the one it was designed at; the first sample resets it)."""
    return act(c.law, c.observer, c.ws, c.ost, c.memory, y, k == 0)


class Mpc:
    """The stepwise form for an agent node: ``reset()``, then ``act(y)`` once per sample."""

    def __init__(self, d: MpcDesign) -> None:
        self.law, self.observer = d.law, d.observer
        self.ws = workspace(d.law)
        self.ost = base.observer_state(d.observer)
        self.cs = np.zeros(2)
        self.first = True

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""
        self.first = True

    def act(self, y: float) -> float:
        """The force for the measured position ``y`` (m)."""
        u = float(act(self.law, self.observer, self.ws, self.ost, self.cs, base.measured(y), self.first))
        self.first = False
        return u


Options = MpcOptions
"""The baseline face (:mod:`msd_bench.core.baselines.catalogue`): its keyword options."""
Stepwise = Mpc
"""The baseline face: the stepwise form built from a design."""


def rollout(plant: Kernel, d: MpcDesign, cond: Conditions,
            noise: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The baseline face: every row of ``noise`` one run from rest in the one closed loop; (true x, u)."""
    c = MpcRun(d.law, d.observer, workspace(d.law), base.observer_state(d.observer), np.zeros(2))
    t = closed_loop.run(plant, c, cond, noise, closed_loop.AT_REST, closed_loop.NO_LIMITS, False, False, 0)
    return t.x, t.command
