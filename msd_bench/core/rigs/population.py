"""A population of rigs: a documented distribution of plants and imperfections, one rig per seed.

Why: one emulated rig says little about how often the method survives a rig
the user has not seen. A population answers that with statistics, and for
them to mean anything the distribution must be stated, each range with the
reason it is realistic (docs/rig.md §Population), and every member must be
reproducible from a number alone. So a rig *is* a seed: :func:`draw` maps it
deterministically to a :class:`RigSpec` (plant parameters and
:class:`~msd_bench.core.rigs.rig.RigImperfections`), and :meth:`RigSpec.line`
prints every parameter on one line.

Seed :data:`EMULATOR_SEED` (0) is reserved for the rig emulator's defaults
(the ``rig`` plant preset with :class:`RigImperfections`' defaults), so the
emulator as it always ran is one member, and every other seed is a draw.
Design rigs (:data:`DESIGN_RIGS`) are for choosing things (an excitation, a
threshold); held-out rigs (:data:`HELD_OUT_RIGS`) are for reporting: the two
ranges do not overlap, so a choice made on one cannot flatter the other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.physics.sensor import sensor_rng
from msd_bench.core.rigs.hold import HoldLoop, Operation
from msd_bench.core.rigs.rig import RigImperfections, lag_samples
from msd_bench.core.rigs.scales import DEFAULT_DT, Scales
from msd_bench.core.rigs.units import RigUnits

FloatArray = NDArray[np.float64]

POPULATION_STREAM = 0x9195
"""Mixed into a rig's seed for its draw (independent of the sensor and jitter streams)."""
EMULATOR_SEED = 0
"""The reserved member: the rig emulator's defaults (``rig`` preset, default imperfections)."""
MAX_SEED = 2**31 - 1
"""Largest rig seed (a ROS integer parameter's safe range)."""
DESIGN_RIGS = range(1, 1000)
"""Seeds of the design rigs: choose anything on these (excitations, thresholds, defaults)."""
HELD_OUT_RIGS = range(1000, 1_000_000)
"""Seeds of the held-out rigs: report these, never tune on them."""
_MULTIPLIED = ("m", "c", "k", "h")
"""Plant fields the population scales (g, L, F and dt are the rig owner's published contract)."""


@dataclass(frozen=True)
class Distribution:
    """The ranges a rig is drawn from; every draw is independent of the others.

    Each docstring says why the range is realistic for the small linear-motor
    bench the emulator stands for (docs/rig.md §Population repeats them).
    """

    multiplier: tuple[float, float] = (0.8, 1.25)
    """Log-uniform range of each of m, c, k, h relative to the ``default`` preset, drawn
    independently so directions mix: a payload, guide wear and a different spring batch move
    these by 10-25 % on a real bench, and a log-uniform range treats ×0.8 and ×1.25 alike."""
    friction: tuple[float, float] = (0.0, 0.5)
    """Uniform Coulomb friction, N: linear guides show 1-3 % of the rated force (F = 10 N);
    up to 5 % covers a dry or misaligned guide."""
    delay: tuple[int, int] = (0, 2)
    """Actuator dead time, whole samples, uniform over the closed range: 0 for a drive on the
    controller's own bus, 1 for a command that waits for the driver's next cycle, 2 for a
    serial or USB chain that adds one more."""
    lag: tuple[float, float] = (0.0, 0.04)
    """Uniform first-order time constant of the drive, s: a current loop and motor inductance
    give a few ms, a force filter up to tens; 40 ms (four samples) is still well above the
    plant's bandwidth (a fraction of a hertz)."""
    noise: tuple[float, float] = (0.0, 0.003)
    """Uniform standard deviation of the position noise, m: 0 for an optical encoder, 1-3 mm for
    a draw-wire or analogue sensor over a 5 m stroke read by a 12-bit converter."""
    quant: tuple[float, ...] = (0.0, 0.0001, 0.0005)
    """Encoder resolution, m, one of these with equal chance: none (an analogue chain read at
    full resolution), 0.1 mm counts (the emulator's default), 0.5 mm (a coarse magnetic strip)."""
    jitter: float = 0.002
    """Publish jitter, s, fixed at the emulator's: it is the PC's, not the rig's."""


DISTRIBUTION = Distribution()
"""The population every rig seed is drawn from."""


@dataclass(frozen=True)
class RigSpec:
    """One member of the population: its seed, its plant and its imperfections."""

    seed: int
    """The rig's seed (its name)."""
    params: PlantParams
    """The rig's plant (the pipeline is never told these)."""
    imperfections: RigImperfections = field(default_factory=RigImperfections)
    """The rig's sensor, actuator, friction and jitter."""
    family: str = "default"
    """The family the rig was drawn from (:mod:`msd_bench.core.rigs.families`)."""
    units: RigUnits = field(default_factory=RigUnits)
    """The rig's units against its default-family twin (the identity in the default family)."""
    pace: float | None = None
    """The time unit of the rig's dynamics against the paper plant's, as its family states it from what
    an owner knows (the ``stage`` family: stroke, force limit, nominal mass); None: from its units."""
    hold: HoldLoop | None = None
    """The position loop its records are taken under (a rig with no equilibrium of its own: a stage);
    None: open-loop records, as on the paper's plant."""

    def multipliers(self) -> dict[str, float]:
        """m, c, k, h relative to the ``default`` preset, in the rig's own units (its twin's multipliers)."""
        base, k = PRESETS["default"], self.units.plant_factors()
        return {f: getattr(self.params, f) / (getattr(base, f) * k[f]) for f in _MULTIPLIED}

    def scales(self) -> Scales:
        """The scales the method runs this rig in: its stroke, force limit and sample time, and (a rig in
        other units than its twin's) its dynamics' time unit, which is its sample time's
        (:class:`~msd_bench.core.rigs.scales.Scales`; exactly the default's in the default family)."""
        p = self.params
        if self.pace is not None:
            return Scales.of(p.L, p.F, p.dt, self.pace)
        pace = 1.0 if self.units.time == 1.0 else p.dt / DEFAULT_DT
        return Scales.of(p.L, p.F, p.dt, pace)

    def decision_samples(self) -> int:
        """Rig samples per decision: the paper's 10 ms decision in the rig's time unit, whole and at least
        one (1 for every rig whose dynamics run at its sampling's pace: the default and scaled families)."""
        if self.pace is None:
            return 1
        return max(1, round(DEFAULT_DT * self.pace / self.params.dt))

    def operation(self) -> Operation:
        """How the method runs this rig: under its hold loop (if its family states one), deciding every
        :meth:`decision_samples` samples."""
        return Operation(self.hold, self.decision_samples())

    def line(self) -> str:
        """Every parameter on one line, for logs, reports and tables."""
        p, i, u = self.params, self.imperfections, self.units
        if self.pace is None:
            mult = " ".join(f"{f}={getattr(p, f):.4g}(x{r:.3f})" for f, r in self.multipliers().items())
        else:  # a plant of its own, not a default one's multiples
            mult = f"[{self.family}] " + " ".join(f"{f}={getattr(p, f):.4g}" for f in _MULTIPLIED)
        units = "" if u.is_identity else (f" [{self.family}: length x{u.length:.4g}, mass x{u.mass:.4g}, "
                                          f"time x{u.time:.4g}]")
        return (f"rig {self.seed}{units}: {mult} g={p.g:g} L={p.L:g} F={p.F:g} dt={p.dt:g}; "
                f"friction {i.friction:.3f} N, delay {i.delay_samples} samples, "
                f"lag {i.actuator_tau * 1e3:.1f} ms, noise {i.sensor_noise * 1e3:.2f} mm, "
                f"quantisation {i.sensor_quant * 1e3:g} mm, jitter {i.jitter * 1e3:g} ms"
                + (f", offset {i.offset:.4g} N" if i.offset else "")
                + (f"; held by kp {self.hold.stiffness:.4g} N/m, kd {self.hold.damping:.4g} N s/m"
                   if self.hold is not None else ""))

    def description(self) -> dict[str, float]:
        """The rig description its owner would write (docs/rig-description.md): rate, stroke and force
        limit, the decision period :meth:`decision_samples` gives, and the hold loop it is run under.
        Why from what the owner states only: ``bench.py --rig`` must learn nothing a real rig's file
        would not hold (never the drawn mass, friction or drive)."""
        p = self.params
        out = {"rate": 1.0 / p.dt, "stroke": p.L, "force_limit": p.F,
               "decision_period": self.decision_samples() * p.dt}
        if self.hold is not None:
            out.update(self.hold.params())
        return out


def check_seed(seed: object) -> int:
    """``seed`` as a rig seed, or one ConfigError line saying what is wrong with it."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise ConfigError(f"rig seed must be a whole number 0..{MAX_SEED}, got {seed!r}")
    if not 0 <= int(seed) <= MAX_SEED:
        raise ConfigError(f"rig seed must be in 0..{MAX_SEED}, got {seed}")
    return int(seed)


def draw(seed: int, dist: Distribution = DISTRIBUTION) -> RigSpec:
    """The rig of ``seed``: the emulator's defaults for :data:`EMULATOR_SEED`, else a draw.

    The draw order is fixed (m, c, k, h, friction, delay, lag, noise, quantisation), so
    a seed names the same rig for as long as this function and ``dist`` stand.
    """
    seed = check_seed(seed)
    if seed == EMULATOR_SEED and dist == DISTRIBUTION:
        return RigSpec(seed, PRESETS["rig"], RigImperfections())
    rng = np.random.default_rng((POPULATION_STREAM, seed))
    lo, hi = (math.log(v) for v in dist.multiplier)
    base = PRESETS["default"]
    scaled = {f: getattr(base, f) * math.exp(float(rng.uniform(lo, hi))) for f in _MULTIPLIED}
    params = PlantParams(**{**{f: getattr(base, f) for f in ("g", "L", "F", "dt")}, **scaled})
    imp = RigImperfections(
        friction=float(rng.uniform(*dist.friction)),
        delay_samples=int(rng.integers(dist.delay[0], dist.delay[1] + 1)),
        actuator_tau=float(rng.uniform(*dist.lag)),
        sensor_noise=float(rng.uniform(*dist.noise)),
        sensor_quant=float(dist.quant[int(rng.integers(len(dist.quant)))]),
        jitter=dist.jitter,
    )
    return RigSpec(seed, params, imp)


def conditions(spec: RigSpec, target: float) -> Conditions:
    """The compiled closed loop's view of a validation on this rig (its actuator, friction, encoder).

    The sensor noise is drawn by :func:`measurement_noise`; with both, a
    :func:`~msd_bench.core.evaluation.closed_loop.greedy_under` run on ``spec.params``
    is the rig node's run, bit for bit (tests/core/test_population.py).
    """
    i = spec.imperfections
    return Conditions(float(target), i.sensor_quant, i.delay_samples, 0.0, 0, i.friction,
                      lag_samples(i.actuator_tau, spec.params.dt), i.offset)


def measurement_noise(spec: RigSpec, seeds: Sequence[int], steps: int) -> FloatArray:
    """Noise on each of ``steps`` measurements per run: the stream a :class:`Rig` seeded so draws."""
    std = spec.imperfections.sensor_noise
    noise = np.zeros((len(seeds), int(steps)))
    if std > 0.0:
        for j, seed in enumerate(seeds):
            noise[j] = std * sensor_rng(int(seed)).standard_normal(int(steps))
    return noise
