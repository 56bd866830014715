"""The rig emulator's physics: the NL-MSD as real hardware shows it (docs/rig.md §Model).

A real rig differs from the ideal plant in ways the pipeline must survive, and
each one here is a separate, switchable part of :class:`RigImperfections`:

* the sensor (:class:`~msd_bench.core.sensor.SensorModel`, the one sensor model:
  Gaussian noise, then encoder quantisation) and a velocity *estimated* from the
  measured positions (a rig has no velocity sensor);
* the actuator (:class:`Actuator`): the command acts ``delay_samples`` samples
  late, through a first-order lag of time constant ``actuator_tau``;
* Coulomb friction of ``friction`` N (:func:`kernels.plant_step_loaded`: it
  opposes motion, holds the mass at rest while the other forces stay within it,
  and never reverses the velocity within a step);
* publish jitter: a random delay (uniform in ``[0, jitter)``) between acquiring
  a sample and publishing it; its stamp stays the acquisition time.

With every imperfection at 0 :meth:`Rig.step` *is* :func:`msd_bench.core.plant.step`
(the same compiled transition, bit for bit), the measurement is the true position,
and the applied force is the saturated command.

Sample alignment is the plant node's: :meth:`Rig.step` returns row k (the
measured ``y_k``, the velocity estimate at k, the force applied over
``[t_k, t_k+1)``) and the measured ``y_{k+1}`` the node publishes on
``position``. Nothing here reads a clock or imports ROS.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from msd_bench.core import kernels
from msd_bench.core.errors import ConfigError
from msd_bench.core.plant import PlantParams
from msd_bench.core.sensor import SensorModel, VelocityEstimator, sensor_rng

JITTER_STREAM = 0x717E
"""Mixed into the rig's seed for the publish-jitter generator (independent of the noise stream)."""


@dataclass(frozen=True)
class RigImperfections:
    """What makes the rig emulator unlike the ideal plant; each is switched off by 0.

    The defaults are those of a small linear-motor bench read by a 0.1 mm
    encoder through a noisy analogue chain (docs/rig.md §Parameters says why
    each is realistic).
    """

    sensor_noise: float = field(default=0.002, metadata={"range": (0.0, 0.1)})
    """Standard deviation (m) of the Gaussian noise on every measured position; 0 = none."""
    sensor_quant: float = field(default=0.0001, metadata={"range": (0.0, 0.01)})
    """Encoder resolution (m): measured positions are rounded to multiples of it, after the
    noise; 0 = none."""
    delay_samples: int = field(default=1, metadata={"range": (0, 50)})
    """Actuator dead time in samples: a command held at sample k starts acting at sample
    k + delay_samples; 0 = none."""
    actuator_tau: float = field(default=0.02, metadata={"range": (0.0, 1.0)})
    """Time constant (s) of the actuator's first-order lag (drive current loop, motor
    inductance); 0 = the force follows the delayed command at once."""
    friction: float = field(default=0.2, metadata={"range": (0.0, 5.0)})
    """Coulomb friction (N): opposes motion; at rest it holds the mass while the other forces
    stay within it; 0 = none."""
    jitter: float = field(default=0.002, metadata={"range": (0.0, 0.05)})
    """Largest publish delay (s): each sample is published a uniform random time in [0, jitter)
    after its acquisition (stamps stay the acquisition times); must be below the sample time;
    0 = none."""

    def __post_init__(self) -> None:
        SensorModel(self.sensor_noise, self.sensor_quant)  # a bad sensor is one ConfigError line
        for name in ("actuator_tau", "friction", "jitter"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(f"rig {name} must be finite and >= 0, got {value}")
        if not (isinstance(self.delay_samples, int) and self.delay_samples >= 0):
            raise ConfigError(f"rig delay_samples must be an integer >= 0, got {self.delay_samples!r}")

    @classmethod
    def none(cls) -> RigImperfections:
        """Every imperfection switched off: the rig is the ideal plant."""
        return cls(sensor_noise=0.0, sensor_quant=0.0, delay_samples=0, actuator_tau=0.0,
                   friction=0.0, jitter=0.0)

    @property
    def sensor(self) -> SensorModel:
        """The rig's position sensor."""
        return SensorModel(self.sensor_noise, self.sensor_quant)

    def check_against(self, params: PlantParams) -> None:
        """Facts that need the plant: jitter must stay within one sample period."""
        if self.jitter >= params.dt:
            raise ConfigError(f"rig jitter {self.jitter} s must be below the sample time dt={params.dt} s "
                              f"(a sample is published before the next one is acquired)")


class Actuator:
    """Dead time of ``delay`` samples, then a first-order lag, sampled every ``dt``.

    The lag is integrated exactly for a command held over each sample; the force
    it returns for sample k is the *mean* of the continuous lag output over
    ``[t_k, t_k+1)``, so the impulse the Euler step delivers equals the
    continuous actuator's. For a step of size U reaching the lag at sample j0,
    the force at j0+j is ``U (1 - β e^{-j dt/τ})`` with
    ``β = (τ/dt)(1 - e^{-dt/τ})``: successive gaps to U shrink by ``e^{-dt/τ}``.
    With ``tau = 0`` the force is the delayed command exactly.
    """

    def __init__(self, delay: int, tau: float, dt: float) -> None:
        self.delay = int(delay)
        self.tau = float(tau)
        self._decay = math.exp(-dt / tau) if tau > 0 else 0.0
        self._mean_gain = (tau / dt) * (1.0 - self._decay) if tau > 0 else 0.0
        self._line: deque[float] = deque()
        self._force = 0.0
        self.cut()

    def cut(self) -> None:
        """Drive disabled: no force now, nothing in flight (what a drive's watchdog does)."""
        self._line = deque([0.0] * self.delay, maxlen=self.delay + 1)
        self._force = 0.0

    def apply(self, command: float) -> float:
        """Hold ``command`` for this sample; return the force that acts over it (N)."""
        self._line.append(float(command))
        target = self._line.popleft()
        if self.tau <= 0:
            self._force = target
            return target
        start = self._force
        self._force = target + (start - target) * self._decay
        return target + (start - target) * self._mean_gain


class RigRow(NamedTuple):
    """One sample as the rig reports it (row k) and what it knows of the truth."""

    measured: float
    """Measured position y_k (m): what joint_states carries."""
    velocity: float
    """Velocity estimated from the measured positions at k (m/s); 0 at the first sample."""
    effort: float
    """Force the actuator applies over [t_k, t_k+1) (N), after saturation, delay and lag."""
    x: float
    """True position x_k (m)."""
    v: float
    """True velocity v_k (m/s)."""
    measured_next: float
    """Measured position y_{k+1} after the step (published on ``position``, repeated by row k+1)."""


class Rig:
    """A stateful emulated rig: one :meth:`step` per sample, from rest at the origin."""

    def __init__(self, params: PlantParams, imperfections: RigImperfections, seed: int = 0) -> None:
        imperfections.check_against(params)
        self.params = params
        self.imperfections = imperfections
        self._plant = params.kernel()
        self._sensor = imperfections.sensor
        self._noise = sensor_rng(seed)
        self._jitter = np.random.default_rng((JITTER_STREAM, int(seed)))
        self.actuator = Actuator(imperfections.delay_samples, imperfections.actuator_tau, params.dt)
        self._velocity = VelocityEstimator(params.dt)
        self.reset()

    def reset(self, x0: float = 0.0, v0: float = 0.0) -> None:
        """Put the mass at (x0, v0) with the actuator off (emulator start-up; a rig cannot do this)."""
        self.x, self.v = float(x0), float(v0)
        self.actuator.cut()
        self._velocity.reset()
        self._y = self._measure(self.x)

    def cut(self) -> None:
        """Disable the drive (watchdog): the applied force is 0 N from the next sample on."""
        self.actuator.cut()

    def _measure(self, x: float) -> float:
        return x if self._sensor.is_ideal else self._sensor.measure_one(x, self._noise)

    def step(self, command: float) -> RigRow:
        """Hold ``command`` (saturated to ±F; non-finite raises) for one sample; row k and y_{k+1}."""
        u = kernels.saturate(float(command), self.params.F)
        effort = self.actuator.apply(u)
        v_est = self._velocity.update(self._y)
        x, v, y = self.x, self.v, self._y
        self.x, self.v = kernels.plant_step_loaded(self._plant, x, v, effort, 0.0,
                                                   self.imperfections.friction)
        self._y = self._measure(self.x)
        return RigRow(y, v_est, effort, x, v, self._y)

    def publish_delay(self) -> float:
        """Seconds between acquiring the next sample and publishing it (uniform in [0, jitter))."""
        top = self.imperfections.jitter
        return 0.0 if top <= 0 else float(self._jitter.uniform(0.0, top))
