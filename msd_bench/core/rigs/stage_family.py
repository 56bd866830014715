"""The ``stage`` rig family: linear positioning stages, drawn from the ranges a lab's stages span.

Why: every other family is the default plant in some units; a user with a
positioning stage — tens of kilograms, a stroke under a metre, hundreds of
newtons, a kilohertz servo loop, Coulomb friction and an offset force, no
real spring — has a different plant, not a rescaled one. Rig N of this family
is a draw from :class:`StageDistribution` (each range with the reason it is
realistic; docs/rig-families.md §stage repeats them), in the NL-MSD's terms:
its spring is the weak pull of a cable carrier or bellows, never zero (the
plant's parameters must be > 0) but a few per cent of the force limit at most.

What its owner states, and the method may use: the stroke, the force limit,
the rate, and a *nominal* moving mass (the drawn mass off by a drawn factor:
an owner knows the payload roughly, never exactly). From these the stage's
time unit (:attr:`~msd_bench.core.rigs.population.RigSpec.pace`: how much
faster or slower its dynamics run than the paper's plant) and the position
loop its records are taken under (:class:`~msd_bench.core.rigs.hold.HoldLoop`,
as a springless stage has no equilibrium for an open-loop record).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from msd_bench.core.physics.plant import PRESETS, PlantParams
from msd_bench.core.rigs import population
from msd_bench.core.rigs.hold import HoldLoop
from msd_bench.core.rigs.rig import RigImperfections

STAGE_STREAM = 0x57A6
"""Mixed into a rig's seed for its draw (independent of every other family's)."""
SPRING_SPAN = 0.5
"""The spring's sinusoid reaches ``SPRING_SPAN`` rad at a stop (``g = SPRING_SPAN / (L/2)``): nearly
linear over the stroke, as a cable carrier's pull is."""


@dataclass(frozen=True)
class StageDistribution:
    """The ranges a stage is drawn from; every draw is independent of the others."""

    mass: tuple[float, float] = (10.0, 200.0)
    """Log-uniform moving mass, kg: the carriage, the motor's forcer and the payload, from a small
    precision stage to a gantry axis."""
    stroke: tuple[float, float] = (0.1, 1.0)
    """Log-uniform full travel, m: the strokes catalogue stages are sold in."""
    force: tuple[float, float] = (50.0, 1000.0)
    """Log-uniform force limit, N: the continuous force of ironless (tens of newtons) to iron-core
    (a kilonewton) linear motors."""
    rates: tuple[float, ...] = (500.0, 1000.0)
    """Servo rates, Hz, one of these with equal chance: a 2 ms fieldbus cycle or a 1 kHz real-time loop."""
    coast: tuple[float, float] = (1.0, 20.0)
    """Log-uniform mechanical time constant m/c, s: how long the stage coasts with the drive off.
    Recirculating-ball guides and seals damp little; a motor in current mode adds nothing."""
    spring: tuple[float, float] = (0.001, 0.03)
    """Log-uniform spring force at a stop, as a share of the force limit: a cable carrier or bellows
    pulls a little towards its relaxed position; a bare stage (0.1 %) hardly at all."""
    cubic: tuple[float, float] = (0.05, 0.5)
    """Uniform share of the spring's force at a stop that is its cubic part (a carrier stiffens as it
    bends further)."""
    friction: tuple[float, float] = (0.01, 0.05)
    """Uniform Coulomb friction as a share of the force limit: linear guides show 1-3 %, a preloaded or
    dirty guide up to 5 %."""
    offset: tuple[float, float] = (0.0, 0.03)
    """Uniform magnitude of the offset force as a share of the force limit, with a random sign: a slight
    tilt or an unbalanced carrier. Above the friction it moves a resting stage with the drive off."""
    delay: tuple[float, float] = (0.0, 0.002)
    """Uniform actuator dead time, s (rounded to whole samples): a fieldbus cycle or two."""
    lag: tuple[float, float] = (0.0002, 0.002)
    """Uniform first-order lag of the drive, s: a current loop of 80-800 Hz bandwidth."""
    quant: tuple[float, ...] = (1e-7, 1e-6, 5e-6)
    """Encoder resolution, m, one of these with equal chance: an interpolated optical scale (0.1 µm),
    a standard one (1 µm), a magnetic one (5 µm). No analogue noise: an encoder counts."""
    jitter: float = 0.1
    """Publish jitter as a share of the sample time: a real-time loop's."""
    mass_known: tuple[float, float] = (0.8, 1.25)
    """Log-uniform factor between the owner's nominal mass and the drawn one: a payload known roughly."""


STAGES = StageDistribution()
"""The distribution every stage is drawn from."""


def _log_uniform(rng: np.random.Generator, span: tuple[float, float]) -> float:
    return math.exp(float(rng.uniform(math.log(span[0]), math.log(span[1]))))


def time_unit(stroke: float, force_limit: float, mass: float) -> float:
    """A stage's time unit against the paper plant's: the time its force limit takes to move its mass
    across a stroke, sqrt(m L / F), over the paper plant's (sqrt(1 kg · 5 m / 10 N) ≈ 0.71 s)."""
    base = PRESETS["default"]
    return math.sqrt(mass * stroke / force_limit) / math.sqrt(base.m * base.L / base.F)


def draw(seed: int, dist: StageDistribution = STAGES) -> population.RigSpec:
    """Stage ``seed``. The draw order is fixed (mass, stroke, force, rate, coast, spring, cubic,
    friction, offset and its sign, delay, lag, quantisation, the owner's mass error), so a seed names
    the same stage for as long as this function and ``dist`` stand."""
    rng = np.random.default_rng((STAGE_STREAM, population.check_seed(seed)))
    m, L, F = _log_uniform(rng, dist.mass), _log_uniform(rng, dist.stroke), _log_uniform(rng, dist.force)
    dt = 1.0 / dist.rates[int(rng.integers(len(dist.rates)))]
    c = m / _log_uniform(rng, dist.coast)
    spring = _log_uniform(rng, dist.spring) * F
    cubic = float(rng.uniform(*dist.cubic))
    half = L / 2.0
    g = SPRING_SPAN / half
    k = spring * (1.0 - cubic) / math.sin(SPRING_SPAN)
    h = spring * cubic / half**3
    friction = float(rng.uniform(*dist.friction)) * F
    offset = float(rng.uniform(*dist.offset)) * F * (1.0 if rng.integers(2) else -1.0)
    imp = RigImperfections(
        sensor_noise=0.0, sensor_quant=float(dist.quant[int(rng.integers(len(dist.quant)))]),
        delay_samples=round(float(rng.uniform(*dist.delay)) / dt), actuator_tau=float(rng.uniform(*dist.lag)),
        friction=friction, offset=offset, jitter=dist.jitter * dt)
    nominal = m * _log_uniform(rng, dist.mass_known)
    params = PlantParams(m=m, c=c, k=k, g=g, h=h, L=L, F=F, dt=dt)
    return population.RigSpec(seed, params, imp, family="stage", pace=time_unit(L, F, nominal),
                              hold=HoldLoop.stated(L, F, nominal))
