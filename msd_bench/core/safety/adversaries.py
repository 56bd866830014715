"""Adversarial controllers for proving the supervisor, and the loops that run them (docs/supervisor.md).

Each is a controller no one should put on hardware: always +F, always −F, a
random alphabet (a random force of the five held for a random 1–50 samples),
a bang-bang square wave at the plant's small-signal resonance ω = √(k g / m)
(1.55 rad/s on the default plant: it pumps the mass into a stop), and a
*turncoat* that tracks the set-point well until 15 s and then pushes outward at
full force. The open-loop ones are a precomputed force sequence; the turncoat
reads the measured position, as any controller would.

Two loops run them: :func:`run_on_plant` (compiled, many runs at once, the
ideal plant seen through additive measurement noise) and :func:`run_on_rig`
(the rig emulator of :mod:`msd_bench.core.rigs.rig`, one run, the stepwise
supervisor a node holds). Both return the true trajectory, which only the
risk metrics read (:mod:`msd_bench.core.evaluation.risk`): the supervisor sees the
measurement.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import Plant
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.rig import Rig, RigImperfections
from msd_bench.core.safety.supervisor import NONE, S_ABORT, STATE_SIZE, Limits, Supervisor, filter_step

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


@numba.njit(cache=True)
def _nearest_action(u: float, F: float) -> float:
    """``u`` rounded to the nearest force of the alphabet."""
    half = 0.5 * F
    return max(-F, min(F, half * math.floor(u / half + 0.5)))


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _plant_runs(plant: Plant, lim: Limits, supervised: bool, adv: Adversary, reference: float,
                noise: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray,
                                            IntArray]:
    n, n_steps = noise.shape
    xs = np.empty((n, n_steps))
    vs = np.empty((n, n_steps))
    cs = np.empty((n, n_steps))
    fs = np.empty((n, n_steps))
    rs = np.zeros((n, n_steps), dtype=np.int64)
    aborts = np.zeros(n, dtype=np.int64)
    st = np.zeros(STATE_SIZE)
    for j in range(n):
        st[:] = 0.0
        x = 0.0
        v = 0.0
        y_prev = 0.0
        for k in range(n_steps):
            y = x + noise[j, k]
            u = command(adv, j, k, y, y_prev, reference, plant.dt)
            f = u
            if supervised:
                f, r = filter_step(lim, st, y, reference, u)
                rs[j, k] = r
            xs[j, k] = x
            vs[j, k] = v
            cs[j, k] = u
            fs[j, k] = f
            x, v = kernels.plant_step(plant, x, v, f)
            y_prev = y
        aborts[j] = int(st[S_ABORT]) if supervised else NONE
    return xs, vs, cs, fs, rs, aborts


def run_on_plant(plant: PlantParams, lim: Limits, adv: Adversary, noise: FloatArray,
                 reference: float = 1.0, supervised: bool = True) -> Runs:
    """Every row of ``noise`` (runs, steps: added to the true position) one run from rest."""
    noise = np.ascontiguousarray(noise, dtype=np.float64)
    return Runs(*_plant_runs(plant.kernel(), lim, supervised, adv, float(reference), noise))


def run_on_rig(plant: PlantParams, imperfections: RigImperfections, sup: Supervisor | None,
               adv: Adversary, n_steps: int, seed: int = 0, run: int = 0,
               reference: float = 1.0) -> Runs:
    """One run of ``adv`` on the rig emulator from rest, behind the stepwise ``sup`` if given.

    The controller and the supervisor see the rig's measured position y_k (row k), the way a
    controller on the wire would; ``run`` picks the adversary's sequence row.
    """
    rig = Rig(plant, imperfections, seed)
    if sup is not None:
        sup.reset()
    out = np.empty((4, n_steps))
    reasons = np.zeros(n_steps, dtype=np.int64)
    y, y_prev = 0.0, 0.0  # a run starts at rest at the origin; every later y is the rig's
    for k in range(n_steps):
        u = float(command(adv, run, k, y, y_prev, reference, plant.dt))
        f = u
        if sup is not None:
            d = sup.step(y, reference, u)
            f, reasons[k] = d.force, d.reason
        row = rig.step(f)
        out[:, k] = (row.x, row.v, u, f)
        y_prev, y = y, row.measured_next
    abort = 0 if sup is None else int(sup.state[S_ABORT])
    return Runs(out[0][None], out[1][None], out[2][None], out[3][None], reasons[None],
                np.array([abort], dtype=np.int64))

