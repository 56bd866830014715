"""Playing the experiment plan through a rig: the records its bags would hold, rest without reset.

Why not :func:`msd_bench.core.identification.identify.bias_record`: that drives the ideal plant
from rest at the origin and records the force it applied and the true
position. A rig has no ``reset`` and its records are what its sensor and drive
report, so here every planned experiment is played through a
:class:`~msd_bench.core.rigs.rig.Rig`:

* before each experiment the rig gets zero force until it is still, as
  :mod:`msd_bench.core.rigs.rest` defines still (on the *measured* position): the
  experiment starts wherever the previous one left the mass, never at a reset;
* each sample records what the bag would hold: the command, the measured
  position, the velocity estimated from measured positions and the force the
  actuator applied (the ``effort`` row), with the truth beside it for scoring;
* the identification records are built from those only: ``u`` is the applied
  force (``joint_states.effort``), ``y`` the measured position, the settle
  segment of a PRBS record dropped as the identifier drops it.

With every imperfection 0 the first experiment is bit for bit
:func:`~msd_bench.core.identification.identify.bias_record`'s (both start at rest at the
origin); later ones start where the rest left the mass, a few millimetres off
the origin, which is the point of playing the plan this way.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig, multilevel, prbs
from msd_bench.core.identification.records import Records
from msd_bench.core.rigs.actuation import EffortAgreement, effort_agreement
from msd_bench.core.rigs.hold import HoldLoop, beyond_loop
from msd_bench.core.rigs.rest import RestConfig, RestDetector
from msd_bench.core.rigs.rig import Rig, RigRow

FloatArray = NDArray[np.float64]
TRAIN, VALIDATION = "train", "validation"


@dataclass(frozen=True)
class RestOutcome:
    """How one return to rest went."""

    samples: int
    """Zero-force samples it took (at least the rest window)."""
    still: bool
    """False when the timeout ended the wait (the mass never looked still)."""
    x0: float
    """Measured rest position the next experiment or run starts from, m."""


@dataclass(frozen=True)
class PlayedExperiment:
    """One experiment as the rig's bag would hold it, plus the truth (for scoring only)."""

    name: str
    role: str
    """``train`` or ``validation``."""
    bias: float | None
    """Operating-point force of a PRBS record; None for the broad record."""
    settle: int
    """Leading samples dropped for identification (a PRBS record's settle segment)."""
    command: FloatArray
    """The force commanded at each sample, N (the planned signal, plus the hold loop's force on a rig
    recorded under one)."""
    effort: FloatArray
    """The force the actuator applied over each sample (joint_states.effort), N."""
    measured: FloatArray
    """Measured position y_k (joint_states.position), m."""
    velocity: FloatArray
    """Velocity estimated from the measured positions (joint_states.velocity), m/s."""
    truth: FloatArray
    """True position x_k, m (never used for identification)."""
    rest: RestOutcome
    """The return to rest before this experiment."""

    def experiment(self) -> Experiment:
        """The identification record: applied force and measured position, settle dropped."""
        s = self.settle
        label = "broad" if self.bias is None else f"bias={self.bias:+g}"
        return Experiment(self.effort[s:], self.measured[s:], name=label, truth=self.truth[s:])


class PlanItem(Protocol):
    """What :func:`play_plan` needs of a planned experiment (``app/plan.PlannedExperiment`` has it:
    core may not import the application layer)."""

    @property
    def name(self) -> str: ...
    @property
    def role(self) -> str: ...
    @property
    def bias(self) -> float | None: ...
    @property
    def signal(self) -> PrbsConfig | MultilevelConfig: ...
    @property
    def seed(self) -> int: ...


def rest(rig: Rig, config: RestConfig | None = None, hold: HoldLoop | None = None) -> RestOutcome:
    """Zero force (or only the ``hold`` loop's) until the measured position is still (or the rest
    timeout); the rig stays there."""
    detector = RestDetector(config)
    most = round(detector.config.timeout / rig.params.dt)
    loop = HeldDrive(rig, hold)
    while detector.samples < most:
        if detector.push(loop.step(0.0).measured):
            return RestOutcome(detector.samples, True, detector.x0)
    return RestOutcome(detector.samples, False, detector.x0)


class HeldDrive:
    """A rig stepped with the ``hold`` loop's force added to each command (the command itself without
    one). The loop reads what a lab's loop reads: the measured position now and the velocity estimated
    from the last two (0 at the first sample, as the rig's own estimate). The rig emulator's drive runs
    the same class at every real-time sample (``nodes/rig_node.py``), so a bag of a held stage holds what
    a played plan holds here."""

    def __init__(self, rig: Rig, hold: HoldLoop | None) -> None:
        self.rig, self.hold = rig, hold
        self._last: float | None = None

    def command(self, signal: float) -> float:
        """The force commanded at this sample: the signal, plus the loop's force when there is one."""
        if self.hold is None:
            return signal
        y = self.rig.measured
        v = 0.0 if self._last is None else (y - self._last) / self.rig.params.dt
        self._last = y
        return signal + self.hold.force(y, v)

    def step(self, signal: float) -> RigRow:
        return self.rig.step(self.command(signal))


def signal_of(item: PlanItem) -> tuple[FloatArray, int]:
    """The planned command sequence and the samples identification drops from its start."""
    if isinstance(item.signal, PrbsConfig):
        return prbs(item.signal, item.seed), item.signal.settle
    return multilevel(item.signal, item.seed), 0


def play(rig: Rig, signal: FloatArray,
         hold: HoldLoop | None = None) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Hold each command for one sample: the signal's, plus the ``hold`` loop's force when there is one;
    (command, effort, measured, velocity, truth) per sample."""
    n = len(signal)
    out = np.empty((5, n))
    loop = HeldDrive(rig, hold)
    for k in range(n):
        out[0, k] = loop.command(float(signal[k]))
        row = rig.step(out[0, k])
        out[1, k], out[2, k], out[3, k], out[4, k] = row.effort, row.measured, row.velocity, row.x
    return out[0], out[1], out[2], out[3], out[4]


def play_experiment(rig: Rig, item: PlanItem, rest_config: RestConfig | None = None,
                    hold: HoldLoop | None = None) -> PlayedExperiment:
    """Rest, then play one planned experiment through ``rig`` (under ``hold`` when given: both)."""
    before = rest(rig, rest_config, hold)
    signal, settle = signal_of(item)
    command, effort, measured, velocity, truth = play(rig, signal, hold)
    return PlayedExperiment(item.name, item.role, item.bias, settle, command, effort, measured, velocity,
                            truth, before)


def play_plan(rig: Rig, plan: Sequence[PlanItem], rest_config: RestConfig | None = None,
              hold: HoldLoop | None = None) -> list[PlayedExperiment]:
    """Every planned experiment in order, each from where the rig came to rest after the last; a rig
    with no equilibrium of its own (a stage) is rested and excited under its ``hold`` loop."""
    return [play_experiment(rig, item, rest_config, hold) for item in plan]


def records_of(played: Sequence[PlayedExperiment], dt: float, hold: HoldLoop | None = None) -> Records:
    """The identification records of a played plan: the bags' applied force and measured position only.
    With the ``hold`` loop the plan was played under, the records of the *held* system: the force
    applied beyond the loop's (:func:`~msd_bench.core.rigs.hold.beyond_loop`) and the position."""
    bias: dict[str, dict[float, IOData]] = {TRAIN: {}, VALIDATION: {}}
    broad: dict[str, IOData] = {}
    for p in played:
        e = p.experiment()
        if hold is not None:
            e = replace(e, u=beyond_loop(p.effort, p.measured, hold, dt)[p.settle:])
        data = IOData((e,), dt, {"rig_experiment": p.name, "rest_samples": p.rest.samples})
        if p.bias is None:
            broad[p.role] = data
        else:
            bias[p.role][p.bias] = data
    return Records(bias[TRAIN], bias[VALIDATION], broad[TRAIN], broad[VALIDATION])


def measured_actuator(played: Sequence[PlayedExperiment], dt: float) -> EffortAgreement:
    """The actuator between the commands and the effort of the broad training record, as its bag holds them.

    What a rig's records show of its drive (dead time and lag), fitted as check-rig and the
    ros2_control reader fit it (:func:`~msd_bench.core.rigs.actuation.effort_agreement`): the
    identification records carry the applied force, so no surrogate sees the drive, but an
    agent's observer can be told its delay (docs/rigs.md §The robust agent told the drive's delay).
    """
    broad = [p for p in played if p.bias is None and p.role == TRAIN]
    if not broad:
        raise InvalidInputError("the played plan has no broad training record")
    return effort_agreement(broad[0].command, broad[0].effort, dt)
