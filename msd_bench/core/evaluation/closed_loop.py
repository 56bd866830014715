"""The one closed loop: every design's controller against the plant under test.

The *plant under test* is a model kernel (the emulated plant, a scenario's
perturbed plant, a rig's own physics or a surrogate) together with
:class:`Conditions`: the command acts ``delay`` samples late through a
first-order lag, a load force may push from a given time on (on a plant-kind
model in its force balance, on an ARX-type surrogate on its input), Coulomb
friction may hold the mass (plant kind only), and the controller sees the
position through the sensor (noise drawn outside, then quantisation); a run
starts from a given state with the drive idle. A controller may decide every
``every`` samples (its command held in between), and a stage runs under its
stated hold loop, whose force is added to the command at every sample
(:func:`msd_bench.core.rigs.rig.with_hold`). The ideal plant is the plant
under test with nothing added (:func:`nominal`). Each sample is the rig's own
compiled transition (:func:`msd_bench.core.rigs.rig.transition`), so a run on a
rig here is the rig node's run bit for bit.

Two shapes, one plant side:

* :func:`run` is compiled. A design supplies only its *decision*: a
  ``NamedTuple`` holding its law and its memory, and a compiled function
  registered for that type with :func:`decision` (numba's ``overload``: the
  loop calls the generic :func:`decide` and numba picks the design's at
  compile time, so the loop is compiled once per design and cached like any
  other kernel). The Q-table greedy decision (:class:`QRun`) lives here; PID,
  LQR, MPC, the networks and the adversaries register theirs in their modules.
* :func:`stepwise` runs a Python controller object (``reset()``/``act(y)``,
  the agent node's face: :class:`Acts`) sample by sample through the same
  compiled transition: what a design that is not compiled, or a controller
  handed over as an object (a rig, the supervised validation), runs against.

Outside this module no function steps a plant in a loop (tests/core/test_one_loop.py).
Metrics are computed by the caller on the *true* positions returned.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple, Protocol, TypeVar

import numpy as np
from numba.core import types
from numba.extending import overload
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.learning.q_kernels import commanded, encode, greedy, observe, observer_state
from msd_bench.core.learning.qconfig import Learner
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import RIG_STATE_SIZE, Kernel
from msd_bench.core.rigs.rig import Conditions, actuate, actuator_state, sense, transition, with_hold
from msd_bench.core.safety.supervisor import S_ABORT, STATE_SIZE, Limits, filter_step

__all__ = ["AT_REST", "NO_LIMITS", "Acts", "Conditions", "QRun", "SupervisedRuns", "Trace", "actuate",
           "actuator_state", "decide", "decision", "greedy_under", "nominal", "q_run", "quantise", "run",
           "stepwise", "supervised_runs", "transition"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
T = TypeVar("T")

NO_LIMITS = Limits(*([0.0] * len(Limits._fields)))
"""The supervisor's limits when a run is not supervised (read by nothing: :func:`run` skips it)."""
AT_REST = np.zeros(2)
"""A run's start (x0, v0): at rest at the origin."""


def nominal(target: float) -> Conditions:
    """The plain validation: set-point ``target``, no sensor, delay, lag, load or friction."""
    return Conditions(float(target), 0.0, 0, 0.0, 0, 0.0, 0.0)


@kernel
def quantise(y: float, step: float) -> float:
    """``y`` rounded to the nearest multiple of ``step`` (halves to even); identity for 0.

    The rig's encoder (:func:`msd_bench.core.rigs.rig.sense` without noise), so a scenario's
    quantisation and the rig's are one rule.
    """
    return sense(y, 0.0, step)


def decide(ctl: Any, j: int, k: int, y: float, target: float) -> float:
    """The force a design's controller ``ctl`` commands at sample ``k`` of run ``j`` for the measured ``y``.

    A compiled generic: each design registers its implementation for its own
    ``NamedTuple`` with :func:`decision` (``k == 0`` starts a run: the
    implementation resets its memory there). Called from Python it is an error.
    """
    raise InvalidInputError(f"decide() runs inside the compiled loop only, not on {type(ctl).__name__}")


def decision(cls: type) -> Callable[[T], T]:
    """Register the compiled ``impl(ctl, j, k, y, target) -> force`` as :func:`decide` for ``cls``.

    Why numba's ``overload`` and not a function passed to the loop: a compiled
    function taken as an argument (or a closure over one) is typed by the
    function object, so numba's on-disk cache never hits and every process
    would compile every design's loop again; an overload picked by the
    controller's type is cached like any kernel. Like every cross-module call
    of a cached kernel, numba keys the cached loop on this file alone: after
    changing a decision, clear the caches (``*.nbi``/``*.nbc`` under msd_bench).
    """
    def register(impl: T) -> T:
        def typer(ctl: Any, j: Any, k: Any, y: Any, target: Any) -> Any:
            if isinstance(ctl, types.BaseNamedTuple) and getattr(ctl, "instance_class", None) is cls:
                def implementation(ctl: Any, j: Any, k: Any, y: Any, target: Any) -> Any:
                    return impl(ctl, j, k, y, target)  # type: ignore[operator]
                return implementation
            return None

        overload(decide)(typer)
        return impl
    return register


class Trace(NamedTuple):
    """Runs of :func:`run`, each (runs, steps) but ``aborts`` (runs,) and ``end`` (runs, 2)."""

    x: FloatArray
    """True position before command k, m."""
    v: FloatArray
    """The plant state's second slot before command k (the velocity, m/s, on a plant-kind model)."""
    y: FloatArray
    """The measured position the controller decided on, m."""
    command: FloatArray
    """The controller's force, N."""
    force: FloatArray
    """The force sent to the drive (the command, with the hold loop's force added under one, clipped to
    ±F on a rig, as the supervisor let it), N."""
    effort: FloatArray
    """The force the drive applied over the sample (after delay and lag), N."""
    reason: IntArray
    """Supervisor reason per sample (``supervisor.REASONS``); 0 unsupervised."""
    aborts: IntArray
    """The supervisor's abort code at the end of each run (0: ran to the end, or unsupervised)."""
    end: FloatArray
    """True (x, v) after the run and its drain."""


@kernel
def run(plant: Kernel, ctl: Any, cond: Conditions, noise: FloatArray, start: FloatArray, lim: Limits,
        supervised: bool, clip: bool, drain: int) -> Trace:
    """Every row of ``noise`` one run of ``ctl`` on the plant under test (``plant`` under ``cond``).

    ``noise[j, k]`` is added to the k-th measurement of run j. Each run starts
    at ``start`` = (x0, v0) with the drive idle. ``clip``: the command is
    clipped to ±F before the drive, as a rig's input does (:meth:`Rig.step`);
    otherwise the model saturates what the drive applies. ``supervised``: the
    command passes the supervisor's compiled ``filter_step`` (judging the
    measured position, ``lim``) first. After each run ``drain`` zero-force
    samples empty the drive (a rig's next rest starts from there).
    """
    n, n_steps = noise.shape
    out = Trace(np.empty((n, n_steps)), np.empty((n, n_steps)), np.empty((n, n_steps)),
                np.empty((n, n_steps)), np.empty((n, n_steps)), np.empty((n, n_steps)),
                np.zeros((n, n_steps), dtype=np.int64), np.zeros(n, dtype=np.int64), np.empty((n, 2)))
    state = np.zeros(RIG_STATE_SIZE)
    act = np.zeros(cond.delay + 2)  # actuator_state(cond.delay): the drive off
    st = np.zeros(STATE_SIZE)
    for j in range(n):
        state[:] = 0.0
        state[0], state[1] = start[0], start[1]
        act[:] = 0.0
        st[:] = 0.0
        x = start[0]
        y = sense(x, noise[j, 0], cond.quant)
        u, y_last = 0.0, y
        for k in range(n_steps):
            if k % cond.every == 0:
                u = decide(ctl, j, k // cond.every, y, cond.target)
            out.x[j, k], out.v[j, k], out.y[j, k], out.command[j, k] = x, state[1], y, u
            c = with_hold(cond, u, y, y_last)
            y_last = y
            f = kernels.saturate(c, plant.force_limit) if clip else c
            if supervised:
                f, out.reason[j, k] = filter_step(lim, st, y, cond.target, f)
            out.force[j, k] = f
            load = cond.offset + (cond.load if k >= cond.load_step else 0.0)
            e = noise[j, k + 1] if k + 1 < n_steps else 0.0
            out.effort[j, k], x, y = transition(plant, state, act, k, f, e, cond.delay, cond.lag, load,
                                                cond.friction, cond.quant)
        for i in range(drain):
            transition(plant, state, act, n_steps + i, 0.0, 0.0, cond.delay, cond.lag, cond.offset,
                       cond.friction, cond.quant)
        out.aborts[j] = int(st[S_ABORT])
        out.end[j, 0], out.end[j, 1] = state[0], state[1]
    return out


class QRun(NamedTuple):
    """A stack of Q-tables as :func:`run` reads them: run j acts greedily on ``q[j]``."""

    lr: Learner
    """The learner (its encoding, actions and observer)."""
    q: FloatArray
    """(runs, states, actions) tables."""
    obs: Kernel
    """The model a ``model`` observer predicts with (the surrogate the agent trained on)."""
    ost: FloatArray
    """The observer's state (:func:`msd_bench.core.learning.q_kernels.observer_state`)."""
    memory: FloatArray
    """[position estimate, displacement estimate, last command]."""


def q_run(lr: Learner, q: FloatArray, obs: Kernel) -> QRun:
    """The tables ``q`` with a fresh observer."""
    return QRun(lr, np.ascontiguousarray(q, dtype=np.float64), obs, observer_state(lr), np.zeros(3))


@decision(QRun)
@kernel
def q_decide(c: QRun, j: int, k: int, y: float, target: float) -> float:
    """Table j's greedy force on the observer's estimate after ``y`` (the first sample starts it)."""
    m = c.memory
    if k == 0:
        m[0], m[1] = observe(c.lr, c.obs, c.ost, 0.0, y, 0.0, 0.0, True)
    else:
        m[0], m[1] = observe(c.lr, c.obs, c.ost, m[2], y, m[0], m[1], False)
    chosen = c.lr.actions[greedy(c.q[j], encode(c.lr.enc, m[0] - target, m[1], target))]
    u: float = commanded(c.lr, c.ost, chosen, target)
    m[2] = u
    return u


def greedy_under(model: Kernel, lr: Learner, q: FloatArray, cond: Conditions,
                 noise: FloatArray, obs: Kernel) -> tuple[FloatArray, FloatArray]:
    """Each table's greedy run from rest on ``model`` under ``cond`` (:func:`run`); (true x, commanded u).

    ``obs`` is the model a ``model`` observer predicts with (the surrogate the
    agent trained on; ignored by other observers). ``x[j, k]`` is the position
    before command ``u[j, k]`` is issued.
    """
    t = run(model, q_run(lr, q, obs), cond, np.ascontiguousarray(noise, dtype=np.float64), AT_REST,
            NO_LIMITS, False, False, 0)
    return t.x, t.command


class Acts(Protocol):
    """A stepwise controller (:class:`msd_bench.designs.protocol.Controller`): the node's face."""

    def reset(self) -> None:
        """Back to rest."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``."""


def stepwise(ctl: Acts, plant: Kernel, cond: Conditions, noise: FloatArray, lim: Limits | None = None,
             start: tuple[float, float] = (0.0, 0.0), clip: bool = False, drain: int = 0) -> Trace:
    """One run of the Python controller ``ctl`` (reset first): :func:`run`'s sample order and transition.

    Why a second shape: a controller handed over as an object (a stepwise
    design on a rig, the supervised validation of every kind, a design written
    in Python) is called once per sample from Python; the plant side is the
    same compiled transition, so with the same decisions the runs are equal
    bit for bit. ``noise`` is the run's (steps,) row; ``lim``: behind the
    supervisor with these limits. Returns a one-run :class:`Trace`.
    """
    n_steps = noise.shape[0]
    row = (1, n_steps)
    out = Trace(np.empty(row), np.empty(row), np.empty(row), np.empty(row), np.empty(row), np.empty(row),
                np.zeros(row, dtype=np.int64), np.zeros(1, dtype=np.int64), np.empty((1, 2)))
    state = np.zeros(RIG_STATE_SIZE)
    state[0], state[1] = start
    act = actuator_state(cond.delay)
    st = np.zeros(STATE_SIZE)
    x = float(start[0])
    y = float(sense(x, noise[0], cond.quant))
    ctl.reset()
    u, y_last = 0.0, y
    for k in range(n_steps):
        if k % cond.every == 0:
            u = float(ctl.act(y))
        out.x[0, k], out.v[0, k], out.y[0, k], out.command[0, k] = x, state[1], y, u
        c = float(with_hold(cond, u, y, y_last))
        y_last = y
        f = float(kernels.saturate(c, plant.force_limit)) if clip else c
        if lim is not None:
            f, out.reason[0, k] = filter_step(lim, st, y, cond.target, f)
        out.force[0, k] = f
        load = cond.offset + (cond.load if k >= cond.load_step else 0.0)
        e = noise[k + 1] if k + 1 < n_steps else 0.0
        out.effort[0, k], x, y = transition(plant, state, act, k, f, e, cond.delay, cond.lag, load,
                                            cond.friction, cond.quant)
    for i in range(drain):
        transition(plant, state, act, n_steps + i, 0.0, 0.0, cond.delay, cond.lag, cond.offset, cond.friction,
                   cond.quant)
    out.aborts[0] = int(st[S_ABORT])
    out.end[0] = state[0], state[1]
    return out


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

    Why the stepwise controllers (:func:`stepwise`) and not each design's
    compiled decision: this is the node path exactly (a controller sees the
    measured y_k and sends u_k, the supervisor node filters it on the same y_k,
    the rig runs the force), so an in-process supervised validation is the one
    a bench run behind the supervisor node makes, for every kind. With nothing
    overridden the true positions are the policy's own rollout, bit for bit
    (tests/core/test_supervised_runs.py).
    """
    n, n_steps = noise.shape
    if len(controllers) != n:
        raise InvalidInputError(f"need one controller per noise row, got {len(controllers)} for {n}")
    runs = [stepwise(ctl, model, cond, noise[j], lim) for j, ctl in enumerate(controllers)]
    if not runs:
        return SupervisedRuns(np.empty((0, n_steps)), np.empty((0, n_steps)), np.empty((0, n_steps)),
                              np.zeros((0, n_steps), dtype=np.int64), np.zeros(0, dtype=np.int64))
    return SupervisedRuns(np.concatenate([t.x for t in runs]), np.concatenate([t.command for t in runs]),
                          np.concatenate([t.force for t in runs]), np.concatenate([t.reason for t in runs]),
                          np.concatenate([t.aborts for t in runs]))
