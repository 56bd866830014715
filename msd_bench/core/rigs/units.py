"""A rig's physical units against its default-family twin: length, mass and time factors.

Why: the ``scaled`` rig family (:mod:`msd_bench.core.rigs.families`) asks whether
the method is free of scale: each of its rigs is a default-family rig measured
in other units, so the task is physically the same and a scale-free bench must
do on it what it does on the twin. Every quantity of a rig is converted here,
once, by its dimension (force = mass · length / time²):

=====================  ==============================  =====================
quantity               dimension                       factor
=====================  ==============================  =====================
stroke L, noise, quant  length                          ``length``
force limit F, friction force                           ``force``
m                      mass                            ``mass``
c (in c x')            force · time / length           ``mass / time``
k (in k sin(g x))      force                           ``force``
g (in sin(g x))        1 / length                      ``1 / length``
h (in h x³)            force / length³                 ``mass / (length² time²)``
dt, lag, jitter        time                            ``time``
delay                  samples                         unchanged
=====================  ==============================  =====================

The Euler map of the plant in samples is then the twin's map in other units,
sample for sample. The identity (every factor 1.0) leaves every value bit for
bit as it is (``x * 1.0 == x``), so the default family is untouched by it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.rig import RigImperfections


@dataclass(frozen=True)
class RigUnits:
    """Factors from a rig's default-family twin to the rig (each finite and > 0; 1.0: the twin's)."""

    length: float = 1.0
    """Metres of the rig per metre of the twin."""
    mass: float = 1.0
    """Kilograms of the rig per kilogram of the twin."""
    time: float = 1.0
    """Seconds of the rig per second of the twin: its dynamics and its sample time alike."""

    def __post_init__(self) -> None:
        for name in ("length", "mass", "time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise ConfigError(f"rig {name} unit must be a finite number > 0, got {value!r:.40}")

    @property
    def is_identity(self) -> bool:
        """Whether the rig is measured in its twin's units."""
        return self.length == 1.0 and self.mass == 1.0 and self.time == 1.0

    @property
    def force(self) -> float:
        """Newtons of the rig per newton of the twin: mass · length / time²."""
        return self.mass * self.length / (self.time * self.time)

    def plant_factors(self) -> dict[str, float]:
        """The factor of each plant field (:class:`PlantParams`' names), by its dimension."""
        ln, m, t, f = self.length, self.mass, self.time, self.force
        return {"m": m, "c": m / t, "k": f, "g": 1.0 / ln, "h": m / (ln * ln * t * t), "L": ln, "F": f,
                "dt": t}

    def plant(self, twin: PlantParams) -> PlantParams:
        """The twin's plant in these units (itself, bit for bit, in the identity)."""
        if self.is_identity:
            return twin
        return PlantParams(**{name: getattr(twin, name) * k for name, k in self.plant_factors().items()})

    def imperfections(self, twin: RigImperfections) -> RigImperfections:
        """The twin's imperfections in these units: friction and the offset forces, noise and
        quantisation lengths, lag and jitter times; the delay is in samples and stays."""
        if self.is_identity:
            return twin
        ln, t = self.length, self.time
        return replace(twin, friction=twin.friction * self.force, offset=twin.offset * self.force,
                       sensor_noise=twin.sensor_noise * ln,
                       sensor_quant=twin.sensor_quant * ln, actuator_tau=twin.actuator_tau * t,
                       jitter=twin.jitter * t)


def units_between(stroke: float, force_limit: float, dt: float, twin: PlantParams | None = None) -> RigUnits:
    """The units that carry the default plant (or ``twin``) onto a rig of this stroke, force limit and
    sample time: length from the strokes, time from the sample times, mass from the forces
    (force = mass · length / time²). Why: ``msd-bench rigs --rig FILE`` runs the population in a
    described rig's units, each rig its default-family twin in them, as the ``scaled`` family does
    with units it draws; exactly the identity for the default description."""
    base = twin if twin is not None else PlantParams()
    length, time = stroke / base.L, dt / base.dt
    force = force_limit / base.F
    return RigUnits(length=length, mass=force * time * time / length, time=time)

