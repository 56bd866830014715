"""A policy's run on a rig, from where the rig rests: the one closed loop on the rig as plant under test.

A rig is never reset, and its drive lags: each run starts at the rig's true
state after a return to rest (:func:`msd_bench.core.rigs.rig_play.rest`), with
the drive idle, in the one closed loop
(:func:`msd_bench.core.evaluation.closed_loop.run` for a Q-table,
:func:`~msd_bench.core.evaluation.closed_loop.stepwise` for any other
controller object) with the rig's :func:`conditions`: its dead time and
first-order lag, Coulomb friction, its sensor (noise drawn here from the run's
stream, then quantisation), the command clipped to ±F at the rig's input as
:meth:`Rig.step` does. After the run the commands in flight are drained at
zero force (the start of the next rest), so the state handed back holds no
force the next run would not see.

Success is judged on the true position; the measured one is returned beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.evaluation.closed_loop import NO_LIMITS, Trace, q_run, run, stepwise
from msd_bench.core.learning.qconfig import QConfig, packed
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.rigs.hold import BARE, Operation
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Conditions, Rig, lag_samples
from msd_bench.core.rigs.rig_play import RestOutcome, rest
from msd_bench.core.safety.supervisor import Limits

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

DRAIN_FORCE = 1e-9
"""Force (N) below which the lag's output counts as gone when the commands in flight are drained."""


def conditions(rig: Rig, target: float, load: float = 0.0, load_step: int = 0,
               op: Operation = BARE) -> Conditions:
    """The compiled loop's view of ``rig`` at set-point ``target`` under an optional load (and its
    ``op``: its hold loop and decision period)."""
    imp, hold = rig.imperfections, op.hold
    kp, kd, held = (0.0, 0.0, 0.0) if hold is None else (
        hold.stiffness, hold.damping / rig.params.dt, hold.held)
    return Conditions(target=float(target), quant=float(imp.sensor_quant), delay=int(imp.delay_samples),
                      load=float(load), load_step=int(load_step), friction=float(imp.friction),
                      lag=lag_samples(imp.actuator_tau, rig.params.dt), offset=float(imp.offset),
                      every=int(op.every), hold_kp=float(kp), hold_kd=float(kd), held=float(held))


def drain_samples(rig: Rig) -> int:
    """Zero-force samples after which no command of a run is in flight (dead time, then the lag decayed)."""
    imp = rig.imperfections
    lag = 0
    if imp.actuator_tau > 0:
        lag = math.ceil(imp.actuator_tau / rig.params.dt * math.log(rig.params.F / DRAIN_FORCE))
    return imp.delay_samples + lag


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
               rest_config: RestConfig | None = None, limits: Limits | None = None,
               op: Operation = BARE) -> RigRun:
    """Rest, then one greedy run of table ``q`` through the rig; the rig is left where the run ended.

    ``limits``: the run goes through the supervisor with these limits (the rest does not: it
    applies 0 N, which the supervisor would pass anyway unless braking).

    The rest applied zero force for at least its window (300 samples), so the
    actuator holds no command and its lag output has decayed below
    ``F·exp(-300 dt/tau)`` (1e-32 N at the population's 40 ms); the loop starts
    it idle. ``rng`` draws the run's sensor noise.
    """
    before = rest(rig, rest_config, op.hold)
    noise = rig.imperfections.sensor_noise * rng.standard_normal(steps)
    ctl = q_run(packed(cfg), np.asarray(q, dtype=np.float64)[None], observer.kernel)
    lim = limits if limits is not None else NO_LIMITS
    t = run(plant_model(rig.params).kernel, ctl, conditions(rig, target, load, load_step, op), noise[None],
            np.array([rig.x, rig.v]), lim, limits is not None, True, drain_samples(rig))
    return _handed_back(rig, t, before, limits is not None)


def _handed_back(rig: Rig, t: Trace, before: RestOutcome, supervised: bool) -> RigRun:
    """The run's one row as a :class:`RigRun`; the rig is left in the drained state the run ended in
    (the next rest starts from it)."""
    rig.reset(float(t.end[0, 0]), float(t.end[0, 1]))
    return RigRun(t.x[0], t.y[0], t.command[0], t.effort[0], before, t.reason[0] if supervised else None,
                  int(t.aborts[0]))


class StepController(Protocol):
    """Any stepwise controller (a design's :class:`~msd_bench.designs.protocol.Controller`)."""

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""

    def act(self, y: float) -> float:
        """The force for the measured position ``y``, m."""


def run_controller_on_rig(rig: Rig, controller: StepController, target: float, steps: int,
                          rng: np.random.Generator, load: float = 0.0, load_step: int = 0,
                          rest_config: RestConfig | None = None, limits: Limits | None = None,
                          op: Operation = BARE) -> RigRun:
    """:func:`run_on_rig` for any stepwise controller (a baseline's PID, LQR or MPC), one sample at a time.

    The controller object runs through the one loop's stepwise shape
    (:func:`msd_bench.core.evaluation.closed_loop.stepwise`): the same compiled rig transition
    and supervisor step, the same noise draw, rest and drain as a Q-table's run, so a rig treats
    every design alike.
    """
    before = rest(rig, rest_config, op.hold)
    noise = rig.imperfections.sensor_noise * rng.standard_normal(steps)
    cond = conditions(rig, target, load, load_step, op)
    t = stepwise(controller, plant_model(rig.params).kernel, cond, noise, limits,
                 (float(rig.x), float(rig.v)),
                 True, drain_samples(rig))
    return _handed_back(rig, t, before, limits is not None)
