"""Adversarial controllers for proving the supervisor, and the loops that run them (docs/supervisor.md).

Each is a controller no one should put on hardware: always +F, always −F, a
random alphabet (a random force of the five held for a random 1–50 samples),
a bang-bang square wave at the plant's small-signal resonance ω = √(k g / m)
(1.55 rad/s on the default plant: it pumps the mass into a stop), and a
*turncoat* that tracks the set-point well until 15 s and then pushes outward at
full force. The open-loop ones are a precomputed force sequence; the turncoat
reads the measured position, as any controller would.

An adversary is a decision of the one closed loop
(:func:`msd_bench.core.evaluation.closed_loop.run`): :func:`run_on_plant` runs
many at once on the ideal plant seen through additive measurement noise,
:func:`run_on_rig` one on the rig emulator of :mod:`msd_bench.core.rigs.rig`
(its actuator, friction and sensor, its noise stream), each behind the
supervisor's compiled filter if asked. Both return the true trajectory, which
only the risk metrics read (:mod:`msd_bench.core.evaluation.risk`): the
supervisor sees the measurement.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import closed_loop
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.physics.sensor import sensor_rng
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.rigs.rig_loop import conditions
from msd_bench.core.safety.supervisor import Limits

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

OPEN_LOOP = 0
TURNCOAT = 1
SWITCH_TIME = 15.0
"""When the turncoat turns, s."""


class Adversary(NamedTuple):
    """A controller as compiled code reads it."""

    kind: int
    """``OPEN_LOOP`` (play ``sequence``) or ``TURNCOAT`` (track, then push outward)."""
    sequence: FloatArray
    """(runs, steps) forces for ``OPEN_LOOP``; run j plays row ``j % rows``."""
    F: float
    """Force magnitude, N (the alphabet is {-F, -F/2, 0, F/2, F})."""
    switch_step: int
    """Turncoat: first sample it pushes outward."""


@kernel
def _nearest_action(u: float, F: float) -> float:
    """``u`` rounded to the nearest force of the alphabet."""
    half = 0.5 * F
    return max(-F, min(F, half * math.floor(u / half + 0.5)))


@kernel
def command(adv: Adversary, run: int, k: int, y: float, y_prev: float, reference: float,
            dt: float) -> float:
    """The adversary's force at sample ``k`` of run ``run`` from the measured ``y`` (and the one before)."""
    if adv.kind == OPEN_LOOP:
        return float(adv.sequence[run % adv.sequence.shape[0], k])
    if k >= adv.switch_step:
        return adv.F if y >= 0.0 else -adv.F
    v = (y - y_prev) / dt if k > 0 else 0.0
    return _nearest_action(3.0 + 8.0 * (reference - y) - 3.0 * v, adv.F)


def always(plant: PlantParams, n_steps: int, sign: float) -> Adversary:
    """Full force in one direction for the whole run."""
    return Adversary(OPEN_LOOP, np.full((1, n_steps), sign * plant.F), plant.F, n_steps)


def random_alphabet(plant: PlantParams, n_steps: int, seeds: list[int]) -> Adversary:
    """One row per seed: a random force of the alphabet, held for a random 1-50 samples."""
    rows = np.empty((len(seeds), n_steps))
    for j, seed in enumerate(seeds):
        rng = np.random.default_rng((0xAD5E, int(seed)))
        k = 0
        while k < n_steps:
            hold = int(rng.integers(1, 51))
            rows[j, k:k + hold] = plant.actions()[rng.integers(0, 5)]
            k += hold
    return Adversary(OPEN_LOOP, rows, plant.F, n_steps)


def resonance(plant: PlantParams) -> float:
    """The plant's small-signal natural frequency ω = √(k g / m), rad/s."""
    return math.sqrt(plant.k * plant.g / plant.m)


def bang_bang(plant: PlantParams, n_steps: int) -> Adversary:
    """±F square wave at the resonance (:func:`resonance`), starting with +F."""
    t = np.arange(n_steps) * plant.dt
    wave = np.where(np.sin(resonance(plant) * t) >= 0.0, plant.F, -plant.F)
    return Adversary(OPEN_LOOP, wave[None, :], plant.F, n_steps)


def turncoat(plant: PlantParams, n_steps: int, switch: float = SWITCH_TIME) -> Adversary:
    """Tracks the set-point (a PD with a 3 N hold, rounded to the alphabet) until ``switch`` s,
    then pushes outward at full force."""
    return Adversary(TURNCOAT, np.zeros((1, 1)), plant.F, round(switch / plant.dt))


ADVERSARIES: dict[str, Callable[[PlantParams, int, list[int]], Adversary]] = {
    "always_plus": lambda p, n, seeds: always(p, n, 1.0),
    "always_minus": lambda p, n, seeds: always(p, n, -1.0),
    "random": random_alphabet,
    "bang_bang": lambda p, n, seeds: bang_bang(p, n),
    "turncoat": lambda p, n, seeds: turncoat(p, n),
}
"""Every adversary by name: a builder of (plant, steps, seeds)."""


def adversary(name: str, plant: PlantParams, n_steps: int, seeds: list[int] | None = None) -> Adversary:
    """The adversary ``name``; an unknown name is one line listing the known ones."""
    if name not in ADVERSARIES:
        raise ConfigError(f"unknown adversary {name!r}; choose one of {sorted(ADVERSARIES)}")
    return ADVERSARIES[name](plant, int(n_steps), list(seeds or [0]))


class Runs(NamedTuple):
    """Runs of one adversary, each (runs, steps) except ``aborts`` (runs,)."""

    x: FloatArray
    """True position before command k, m."""
    v: FloatArray
    """True velocity, m/s."""
    command: FloatArray
    """The controller's force, N."""
    force: FloatArray
    """The force sent to the plant (the command unless the supervisor overrode it), N."""
    reason: IntArray
    """Supervisor reason per sample (``supervisor.REASONS``); all 0 without it."""
    aborts: IntArray
    """Abort reason code at the end of each run (0 = ran to the end)."""


class AdversaryRun(NamedTuple):
    """An adversary as the one closed loop (:func:`closed_loop.run`) reads it."""

    adv: Adversary
    """The controller."""
    dt: float
    """Sample time, s (the turncoat's velocity estimate)."""
    first: int
    """Run j of the loop is the adversary's run ``first + j`` (which sequence row it plays)."""
    memory: FloatArray
    """[the measured position of the sample before]."""


@closed_loop.decision(AdversaryRun)
@kernel
def decide(c: AdversaryRun, j: int, k: int, y: float, target: float) -> float:
    """The adversarial force of run ``first + j`` at sample ``k`` (:func:`command`, towards ``target``)."""
    y_prev = 0.0 if k == 0 else c.memory[0]
    c.memory[0] = y
    return command(c.adv, c.first + j, k, y, y_prev, target, c.dt)


def _runs(t: closed_loop.Trace) -> Runs:
    return Runs(t.x, t.v, t.command, t.force, t.reason, t.aborts)


def run_on_plant(plant: PlantParams, lim: Limits, adv: Adversary, noise: FloatArray,
                 reference: float = 1.0, supervised: bool = True) -> Runs:
    """Every row of ``noise`` (runs, steps: added to the true position) one run from rest on the ideal
    plant (the one closed loop with nothing added but the noise)."""
    noise = np.ascontiguousarray(noise, dtype=np.float64)
    return _runs(closed_loop.run(plant_model(plant).kernel, AdversaryRun(adv, plant.dt, 0, np.zeros(1)),
                                 closed_loop.nominal(reference), noise, closed_loop.AT_REST, lim,
                                 supervised, False, 0))


def run_on_rig(plant: PlantParams, imperfections: RigImperfections, lim: Limits | None,
               adv: Adversary, n_steps: int, seed: int = 0, run: int = 0,
               reference: float = 1.0) -> Runs:
    """One run of ``adv`` on the rig emulator from rest, behind the supervisor with limits ``lim`` if given.

    The controller and the supervisor see the rig's measured position y_k (row k), the way a
    controller on the wire would; the first is the rest position itself. The rig of ``seed`` is
    the one closed loop's plant under test (:func:`msd_bench.core.rigs.rig_loop.conditions`,
    its noise the rig's own stream: one draw per measurement); ``run`` picks the adversary's
    sequence row.
    """
    rig = Rig(plant, imperfections, seed)
    noise = np.zeros((1, n_steps))
    if imperfections.sensor_noise > 0.0:  # the rig's stream: its start-up draw, then one per sample
        noise[0, 1:] = imperfections.sensor_noise * sensor_rng(seed).standard_normal(n_steps)[1:]
    t = closed_loop.run(plant_model(plant).kernel, AdversaryRun(adv, plant.dt, int(run), np.zeros(1)),
                        conditions(rig, reference), noise, closed_loop.AT_REST,
                        lim if lim is not None else closed_loop.NO_LIMITS, lim is not None, True, 0)
    return _runs(t)
