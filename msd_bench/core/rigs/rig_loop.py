"""A trained policy's greedy closed loop through a rig's own actuator and sensor, from where it rests.

Why not :func:`msd_bench.core.evaluation.closed_loop.greedy_under`: that loop starts every
run at rest at the origin and has no actuator lag. A rig is never reset, and
its drive lags: here each run starts at the rig's true state after a return to
rest (:func:`msd_bench.core.rigs.rig_play.rest`), the command goes through the rig's
dead time and first-order lag (the same arithmetic as
:class:`msd_bench.core.rigs.rig.Actuator`), Coulomb friction acts in the force
balance (:func:`kernels.plant_step_loaded`), and the agent sees the position
through the rig's sensor (noise drawn by the caller, then quantisation
rounded as :class:`~msd_bench.core.physics.sensor.SensorModel` rounds). After the run
the commands in flight are drained at zero force (the start of the next rest),
so the state handed back holds no force the next run would not see.

Success is judged on the true position; the measured one is returned beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numba
import numpy as np
from numpy.typing import NDArray

from msd_bench.core.learning.q_kernels import encode, greedy, observe, observer_state
from msd_bench.core.learning.qconfig import Learner, QConfig, packed
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Conditions, Rig, lag_samples, sense, transition
from msd_bench.core.rigs.rig_play import RestOutcome, rest
from msd_bench.core.safety.supervisor import S_ABORT, STATE_SIZE, Limits, SupervisorOptions, filter_step

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

DRAIN_FORCE = 1e-9
"""Force (N) below which the lag's output counts as gone when the commands in flight are drained."""


def conditions(rig: Rig, target: float, load: float = 0.0, load_step: int = 0) -> Conditions:
    """The compiled loop's view of ``rig`` at set-point ``target`` under an optional load."""
    imp = rig.imperfections
    return Conditions(target=float(target), quant=float(imp.sensor_quant), delay=int(imp.delay_samples),
                      load=float(load), load_step=int(load_step), friction=float(imp.friction),
                      lag=lag_samples(imp.actuator_tau, rig.params.dt))


def drain_samples(rig: Rig) -> int:
    """Zero-force samples after which no command of a run is in flight (dead time, then the lag decayed)."""
    imp = rig.imperfections
    lag = 0
    if imp.actuator_tau > 0:
        lag = math.ceil(imp.actuator_tau / rig.params.dt * math.log(rig.params.F / DRAIN_FORCE))
    return imp.delay_samples + lag


@numba.njit(cache=True)
def rig_greedy(model: Kernel, lr: Learner, q: FloatArray, c: Conditions, noise: FloatArray, obs: Kernel,
               x0: float, v0: float, drain: int, lim: Limits,
               supervised: bool) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray, int,
                                          float, float]:
    """One greedy run of table ``q`` from the true state (x0, v0) with the actuator idle; behind the
    supervisor's compiled ``filter_step`` (judging on the measured position) when ``supervised``.

    Each sample is the rig's one transition (:func:`msd_bench.core.rigs.rig.transition`,
    what :meth:`Rig.step` runs). ``noise[k]`` is added to the k-th measurement.
    Returns per sample the true position, the measured one, the command and the
    applied force (``x[k]`` before command ``u[k]``), the supervisor's reason per
    sample and its abort code (zeros without it), then the true state after
    ``drain`` zero-force samples.
    """
    n = noise.size
    xs, ys, us, fs = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    rs = np.zeros(n, dtype=np.int64)
    st = np.zeros(STATE_SIZE)
    state = np.zeros(4)
    state[0], state[1] = x0, v0
    act = np.zeros(c.delay + 2)  # the drive off: nothing in flight (rig.actuator_state)
    ost = observer_state(lr)
    x = x0
    y = sense(x0, noise[0], c.quant)
    xh, dh = observe(lr, obs, ost, 0.0, y, 0.0, 0.0, True)
    for k in range(n):
        u = lr.actions[greedy(q, encode(lr.enc, xh - c.target, dh, c.target))]
        xs[k], ys[k], us[k] = x, y, u
        load = c.load if k >= c.load_step else 0.0
        nxt = noise[k + 1] if k + 1 < n else 0.0
        cmd = kernels.saturate(u, model.force_limit)
        if supervised:
            cmd, rs[k] = filter_step(lim, st, y, c.target, cmd)
        fs[k], x, y = transition(model, state, act, k, cmd, nxt, c.delay, c.lag, load, c.friction, c.quant)
        if k + 1 < n:
            xh, dh = observe(lr, obs, ost, u, y, xh, dh, False)
    for j in range(drain):
        transition(model, state, act, n + j, 0.0, 0.0, c.delay, c.lag, 0.0, c.friction, c.quant)
    return xs, ys, us, fs, rs, int(st[S_ABORT]), float(state[0]), float(state[1])


@dataclass(frozen=True)
class RigRun:
    """One validation run on a rig."""

    x: FloatArray
    """True position per sample, m (what success is judged on)."""
    y: FloatArray
    """Measured position per sample, m (what the agent saw)."""
    u: FloatArray
    """Commanded force per sample, N."""
    effort: FloatArray
    """Applied force per sample, N."""
    rest: RestOutcome
    """The return to rest this run started from."""
    reason: IntArray | None = None
    """The supervisor's reason per sample (None: the run was not supervised)."""
    abort: int = 0
    """The supervisor's abort code at the end (0: ran to the end, or unsupervised)."""


def run_on_rig(rig: Rig, q: FloatArray, cfg: QConfig, observer: StepModel, target: float, steps: int,
               rng: np.random.Generator, load: float = 0.0, load_step: int = 0,
               rest_config: RestConfig | None = None, limits: Limits | None = None) -> RigRun:
    """Rest, then one greedy run of table ``q`` through the rig; the rig is left where the run ended.

    ``limits``: the run goes through the supervisor with these limits (the rest does not: it
    applies 0 N, which the supervisor would pass anyway unless braking).

    The rest applied zero force for at least its window (300 samples), so the
    actuator holds no command and its lag output has decayed below
    ``F·exp(-300 dt/tau)`` (1e-32 N at the population's 40 ms); the loop starts
    it idle. ``rng`` draws the run's sensor noise.
    """
    before = rest(rig, rest_config)
    noise = rig.imperfections.sensor_noise * rng.standard_normal(steps)
    table = np.ascontiguousarray(q, dtype=np.float64)
    lim = limits if limits is not None else SupervisorOptions().limits(rig.params)  # unused when off
    x, y, u, f, r, abort, x_end, v_end = rig_greedy(
        plant_model(rig.params).kernel, packed(cfg), table, conditions(rig, target, load, load_step), noise,
        observer.kernel, float(rig.x), float(rig.v), drain_samples(rig), lim, limits is not None)
    rig.reset(x_end, v_end)  # hand the drained state back: the next rest starts from it
    return RigRun(x, y, u, f, before, r if limits is not None else None, abort)


class StepController(Protocol):
    """Any stepwise controller (a design's :class:`~msd_bench.designs.protocol.Controller`)."""

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``, m."""


def run_controller_on_rig(rig: Rig, controller: StepController, target: float, steps: int,
                          rng: np.random.Generator, load: float = 0.0, load_step: int = 0,
                          rest_config: RestConfig | None = None, limits: Limits | None = None) -> RigRun:
    """:func:`run_on_rig` for any stepwise controller (a baseline's PID, LQR or MPC), one sample at a time.

    Why a second loop: :func:`rig_greedy` is compiled around a Q-table; a design that is not one
    runs through its stepwise face, sample by sample through the same compiled rig
    :func:`~msd_bench.core.rigs.rig.transition` and supervisor step, with the same noise draw,
    rest and drain, so a rig treats every design alike.
    """
    before = rest(rig, rest_config)
    noise = rig.imperfections.sensor_noise * rng.standard_normal(steps)
    c = conditions(rig, target, load, load_step)
    model = plant_model(rig.params).kernel
    lim = limits if limits is not None else SupervisorOptions().limits(rig.params)
    xs, ys, us, fs = np.empty(steps), np.empty(steps), np.empty(steps), np.empty(steps)
    rs = np.zeros(steps, dtype=np.int64)
    st = np.zeros(STATE_SIZE)
    state = np.array([rig.x, rig.v, 0.0, 0.0])
    act = np.zeros(c.delay + 2)
    x = float(rig.x)
    y = float(sense(x, noise[0], c.quant))
    controller.reset()
    for k in range(steps):
        u = float(controller.act(y))
        xs[k], ys[k], us[k] = x, y, u
        cmd = float(kernels.saturate(u, model.force_limit))
        if limits is not None:
            cmd, rs[k] = filter_step(lim, st, y, c.target, cmd)
        nxt = noise[k + 1] if k + 1 < steps else 0.0
        fs[k], x, y = transition(model, state, act, k, cmd, nxt, c.delay, c.lag,
                                 c.load if k >= c.load_step else 0.0, c.friction, c.quant)
    for j in range(drain_samples(rig)):
        transition(model, state, act, steps + j, 0.0, 0.0, c.delay, c.lag, 0.0, c.friction, c.quant)
    rig.reset(float(state[0]), float(state[1]))
    return RigRun(xs, ys, us, fs, before, rs if limits is not None else None, int(st[S_ABORT]))
