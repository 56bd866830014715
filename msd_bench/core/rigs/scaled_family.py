"""The ``scaled`` rig family: each rig is its default-family twin measured in other units.

Why: a user whose rig is not ours in size (a 0.25 m stage, a 20 m gantry) or in
speed has no evidence that the method works on it, and the method states its
paper constants in metres, newtons and samples. A scale-free method (every
constant scaled from the rig's stroke, force limit and time unit:
:class:`~msd_bench.core.rigs.scales.Scales`) must give on a rig the outcome it
gives on the same rig in other units. So rig N of this family is rig N of the
default family (:func:`msd_bench.core.rigs.population.draw`, unchanged) with
its length, mass and time units multiplied by factors drawn independently and
log-uniformly in 0.05-20 (:class:`ScaledDistribution`), every quantity
converted by its dimension (:class:`~msd_bench.core.rigs.units.RigUnits`).

The factors come from a stream of their own (:data:`SCALE_STREAM`), so the
twin's draw is the default family's, bit for bit; a seed names the same pair
of rigs for as long as the two draws stand.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from msd_bench.core.rigs import population
from msd_bench.core.rigs.units import RigUnits

SCALE_STREAM = 0x5CA1
"""Mixed into a rig's seed for its unit factors (independent of the population's own draw)."""


@dataclass(frozen=True)
class ScaledDistribution:
    """The ranges of a scaled rig's unit factors (each drawn independently)."""

    length: tuple[float, float] = (0.05, 20.0)
    """Log-uniform length factor: 0.25 m (a desktop stage) to 100 m (a crane runway) for the twin's 5 m
    stroke; ×0.05 and ×20 are alike under a log-uniform draw."""
    mass: tuple[float, float] = (0.05, 20.0)
    """Log-uniform mass factor: 50 g (a voice-coil flexure) to 20 kg (a carriage) for the twin's 1 kg."""
    time: tuple[float, float] = (0.05, 20.0)
    """Log-uniform time factor, dynamics and sample time together: 2 kHz sampling of a fast actuator to
    5 Hz of a slow thermal or hydraulic axis for the twin's 100 Hz."""


SCALED = ScaledDistribution()
"""The distribution every scaled rig's units are drawn from."""


def draw_units(seed: int, dist: ScaledDistribution = SCALED) -> RigUnits:
    """The unit factors of scaled rig ``seed``: length, mass, time in that order, from their own stream."""
    rng = np.random.default_rng((SCALE_STREAM, population.check_seed(seed)))

    def one(span: tuple[float, float]) -> float:
        return math.exp(float(rng.uniform(math.log(span[0]), math.log(span[1]))))

    return RigUnits(length=one(dist.length), mass=one(dist.mass), time=one(dist.time))


def draw(seed: int) -> population.RigSpec:
    """Scaled rig ``seed``: default-family rig ``seed`` in the units of :func:`draw_units`."""
    twin = population.draw(seed)
    units = draw_units(seed)
    return replace(twin, params=units.plant(twin.params),
                   imperfections=units.imperfections(twin.imperfections), family="scaled", units=units)


def twin(spec: population.RigSpec) -> population.RigSpec:
    """The default-family twin of a rig of any family (the draw of its seed)."""
    return population.draw(spec.seed)


def in_units(spec: population.RigSpec, units: RigUnits) -> population.RigSpec:
    """A rig of any family in other units, its family kept (itself, bit for bit, in the identity):
    ``msd-bench rigs --rig FILE`` carries each rig into the described rig's units this way."""
    if units.is_identity:
        return spec
    return replace(spec, params=units.plant(spec.params),
                   imperfections=units.imperfections(spec.imperfections), units=units)
