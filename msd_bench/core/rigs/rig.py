"""The rig emulator's physics: the NL-MSD as real hardware shows it (docs/rig.md §Model).

A real rig differs from the ideal plant in ways the pipeline must survive, and
each one here is a separate, switchable part of :class:`RigImperfections`:

* the sensor (:class:`~msd_bench.core.physics.sensor.SensorModel`, the one sensor model:
  Gaussian noise, then encoder quantisation) and a velocity *estimated* from the
  measured positions (a rig has no velocity sensor);
* the actuator (:func:`actuate`, :class:`Actuator`): the command acts ``delay_samples``
  samples late, through a first-order lag of time constant ``actuator_tau``;
* Coulomb friction of ``friction`` N (:func:`kernels.plant_step_loaded`: it
  opposes motion, holds the mass at rest while the other forces stay within it,
  and never reverses the velocity within a step);
* publish jitter: a random delay (uniform in ``[0, jitter)``) between acquiring
  a sample and publishing it; its stamp stays the acquisition time.

The actuator, friction and sensor are one compiled transition
(:func:`transition`), which :meth:`Rig.step` (the node) and the in-process
closed loops (:mod:`msd_bench.core.evaluation.closed_loop`, the baselines' plant half)
share, so an in-process run on a rig is the node's run bit for bit.

With every imperfection at 0 :meth:`Rig.step` *is* :func:`msd_bench.core.physics.plant.step`
(the same compiled transition, bit for bit), the measurement is the true position,
and the applied force is the saturated command.

Sample alignment is the plant node's: :meth:`Rig.step` returns row k (the
measured ``y_k``, the velocity estimate at k, the force applied over
``[t_k, t_k+1)``) and the measured ``y_{k+1}`` the node publishes on
``position``. Nothing here reads a clock or imports ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics import kernels
from msd_bench.core.physics.kernels import KIND_PLANT, Kernel
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.physics.sensor import SensorModel, VelocityEstimator, sensor_rng

if TYPE_CHECKING:
    from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]

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
    friction: float = field(default=0.2, metadata={"range": (0.0, 1e4)})
    """Coulomb friction (N): opposes motion; at rest it holds the mass while the other forces
    stay within it; 0 = none."""
    offset: float = field(default=0.0, metadata={"range": (-1e4, 1e4)})
    """A force that always acts on the mass (N, signed), whatever the drive does: the unbalanced weight
    of an inclined axis, the pull of a cable carrier or bellows; 0 = none (every rig of the default
    family). It enters as a load after the drive's saturation, so the drive's limit is unchanged."""
    jitter: float = field(default=0.002, metadata={"range": (0.0, 0.05)})
    """Largest publish delay (s): each sample is published a uniform random time in [0, jitter)
    after its acquisition (stamps stay the acquisition times); must be below the sample time;
    0 = none."""

    def __post_init__(self) -> None:
        SensorModel(self.sensor_noise, self.sensor_quant)  # a bad sensor is one ConfigError line
        if not math.isfinite(self.offset):
            raise ConfigError(f"rig offset must be finite, got {self.offset}")
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

    def scaled(self, scales: Scales) -> RigImperfections:
        """These imperfections, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md
        §Scales): the sensor's noise and step relative to the stroke, friction relative to the force
        limit, the dead time and the publish jitter the same seconds (the delay rounded to whole rig
        samples, the jitter the same share of a sample); the lag is in seconds already. Itself on
        the paper's plant, so the default rig is unchanged bit for bit."""
        if scales.is_default:
            return self
        m = scales.metres
        return replace(self, sensor_noise=m(self.sensor_noise), sensor_quant=m(self.sensor_quant),
                       friction=scales.newtons(self.friction), offset=scales.newtons(self.offset),
                       jitter=self.jitter * scales.time,
                       delay_samples=round(self.delay_samples / scales.time))

    def check_against(self, params: PlantParams) -> None:
        """Facts that need the plant: jitter must stay within one sample period."""
        if self.jitter >= params.dt:
            raise ConfigError(f"rig jitter {self.jitter} s must be below the sample time dt={params.dt} s "
                              f"(a sample is published before the next one is acquired)")


class Conditions(NamedTuple):
    """What a compiled closed loop runs against besides the model: a scenario on the emulated plant
    (plant multipliers are already in the model) or a rig with its own imperfections and a set-point.

    One type for both (the rig loop had a second tuple of the same seven fields in another order):
    :func:`msd_bench.core.rigs.rig_loop.conditions` fills it from a rig.
    """

    target: float
    """Set-point, m."""
    quant: float
    """Sensor quantisation step, m (0 = none)."""
    delay: int
    """Actuator delay, samples."""
    load: float
    """Force added after saturation from ``load_step`` on, N (an ARX-type model takes it on its input)."""
    load_step: int
    """First sample the load acts on."""
    friction: float
    """Coulomb friction, N (plant kind only)."""
    lag: float = 0.0
    """Time constant of the actuator's first-order lag in *samples* (τ/dt; 0 = none), after the
    delay (:func:`msd_bench.core.rigs.rig.actuate`)."""
    offset: float = 0.0
    """A force that always acts, N (a stage's unbalanced weight or cable drag: the rig's
    :attr:`RigImperfections.offset`), added to the load at every sample, the drain's included."""
    every: int = 1
    """Rig samples per decision: the controller decides at every ``every``-th sample and its command
    is held in between (a stage sampled at 1 kHz, decided at the paper's pace; 1: every sample)."""
    hold_kp: float = 0.0
    """The hold loop's stiffness, N/m on the measured position's error from ``held``: a stage run under
    its stated position loop (:class:`~msd_bench.core.rigs.hold.HoldLoop`) gets the loop's force added
    to the controller's command at every sample, before the drive. 0 with ``hold_kd``: no loop."""
    hold_kd: float = 0.0
    """The hold loop's damping per sample, N per metre of change of the measured position over one
    sample (the loop's N·s/m over the sample time: its velocity is that backward difference)."""
    held: float = 0.0
    """The position the hold loop holds, m."""


@kernel
def actuate(act: FloatArray, k: int, u: float, delay: int, lag: float) -> float:
    """The force over sample ``k`` for the command ``u`` held at ``k``; ``act`` is the drive's state.

    Why compiled and here: the rig node (:meth:`Rig.step`), the in-process
    closed loop (:func:`msd_bench.core.evaluation.closed_loop.greedy_under`) and the
    baselines' plant half all call this one function, so a lag means the same
    thing, bit for bit, on every path.

    ``act`` (length ``delay + 2``, zeros = drive off, :func:`actuator_state`)
    holds the dead-time ring ``act[0..delay]`` (the command held at k goes to
    slot ``k % (delay+1)`` and acts ``delay`` samples later) and, in
    ``act[delay+1]``, the lag's output at the start of the sample. ``lag`` is
    the first-order time constant in *samples* (τ/dt; 0 = none). The lag is
    discretised exactly for a target held over the sample (zero-order hold:
    ``s+ = r + (s - r) a`` with ``a = e^{-1/lag}``) and the force returned is
    the lag output's *mean* over the sample, ``r + (s - r) β`` with
    ``β = lag (1 - a)``, so the impulse the Euler step delivers is the
    continuous actuator's. With ``lag = 0`` it is the delayed command exactly.
    """
    n = delay + 1
    act[k % n] = u
    target: float = act[(k + 1) % n]
    if lag <= 0.0:
        act[n] = target
        return target
    decay = math.exp(-1.0 / lag)
    start: float = act[n]
    act[n] = target + (start - target) * decay
    return target + (start - target) * (lag * (1.0 - decay))


def actuator_state(delay: int) -> FloatArray:
    """A drive that is off, for :func:`actuate`: nothing in flight, no force."""
    return np.zeros(int(delay) + 2)


@kernel
def sense(x: float, noise: float, quant: float) -> float:
    """The measured position of true position ``x``: ``noise`` (m, already drawn) added, then the
    encoder rounds to the nearest multiple of ``quant`` (halves to even, as
    :meth:`SensorModel.measure`'s ``np.round``; 0 = no quantisation)."""
    y = x + noise
    if quant > 0.0:
        y = quant * np.rint(y / quant)
    return y


@kernel
def advance_rig(model: Kernel, state: FloatArray, force: float, load: float, friction: float) -> float:
    """One step of the loop's plant: a load acts on every kind, friction on the plant kind only.

    A load on an ARX-type model enters its input (:func:`kernels.advance_loaded`): that is what
    lets a surrogate stand in for the plant under a load in the robust agent's design loop.
    """
    if model.kind == KIND_PLANT and (load != 0.0 or friction != 0.0):
        x, v = kernels.plant_step_loaded(kernels.plant_of(model.params), state[0], state[1], force,
                                         load, friction)
        state[0] = x
        state[1] = v
        return x
    if load != 0.0:
        return kernels.advance_loaded(model, state, force, load)
    return kernels.advance(model, state, force)


@kernel
def with_hold(cond: Conditions, u: float, y: float, y_last: float) -> float:
    """The command ``u`` with the hold loop's force added (``u`` itself, bit for bit, with no loop):
    the loop reads the measured position ``y`` and its change since the last sample ``y_last``, as
    :class:`~msd_bench.core.rigs.hold.HoldLoop` does when a plan is played under it."""
    if cond.hold_kp == 0.0 and cond.hold_kd == 0.0:
        return u
    return u + (-cond.hold_kp * (y - cond.held) - cond.hold_kd * (y - y_last))


@kernel
def transition(model: Kernel, state: FloatArray, act: FloatArray, k: int, u: float, noise: float,
               delay: int, lag: float, load: float, friction: float,
               quant: float) -> tuple[float, float, float]:
    """One sample of a rig: actuator (delay, lag), plant (load, friction), sensor (noise, encoder).

    The one rig transition: :meth:`Rig.step` (the node) and the compiled closed
    loops run exactly this, so a node's record and an in-process run of the
    same rig and seed agree bit for bit. ``u`` is the command held at sample
    ``k`` (already saturated), ``noise`` the sensor noise of the *next*
    measurement. Returns (force applied over the sample, true ``x_{k+1}``,
    measured ``y_{k+1}``); ``state`` and ``act`` advance in place. With every
    imperfection at 0 it is :func:`kernels.advance` on the ideal model.
    """
    force = actuate(act, k, u, delay, lag)
    x = advance_rig(model, state, force, load, friction)
    return force, x, sense(x, noise, quant)


def lag_samples(tau: float, dt: float) -> float:
    """The actuator time constant τ (s) in samples, as :func:`actuate` reads it (0 = no lag)."""
    return float(tau) / float(dt) if tau > 0 else 0.0


class Actuator:
    """Dead time of ``delay`` samples, then a first-order lag ``tau`` (s), sampled every ``dt``.

    A stateful face of the compiled :func:`actuate` (the node's drive). For a
    step of size U reaching the lag at sample j0, the force at j0+j is
    ``U (1 - β e^{-j dt/τ})`` with ``β = (τ/dt)(1 - e^{-dt/τ})``: successive
    gaps to U shrink by ``e^{-dt/τ}``. With ``tau = 0`` the force is the
    delayed command exactly.
    """

    def __init__(self, delay: int, tau: float, dt: float) -> None:
        self.delay = int(delay)
        self.tau = float(tau)
        self.lag = lag_samples(tau, dt)
        """Time constant in samples (what :func:`actuate` reads)."""
        self.state = actuator_state(self.delay)
        self._k = 0

    def cut(self) -> None:
        """Drive disabled: no force now, nothing in flight (what a drive's watchdog does)."""
        self.state[:] = 0.0

    def tick(self) -> int:
        """The index of the sample now being held (for :func:`transition`); advances it."""
        k = self._k
        self._k += 1
        return k

    def apply(self, command: float) -> float:
        """Hold ``command`` for this sample; return the force that acts over it (N)."""
        return float(actuate(self.state, self.tick(), float(command), self.delay, self.lag))


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
        self._model = kernels.Kernel(KIND_PLANT, params.as_array(), params.F)
        self._state = np.zeros(4)
        self._noise = sensor_rng(seed)
        self._jitter = np.random.default_rng((JITTER_STREAM, int(seed)))
        self.actuator = Actuator(imperfections.delay_samples, imperfections.actuator_tau, params.dt)
        self._velocity = VelocityEstimator(params.dt)
        self.reset()

    def reset(self, x0: float = 0.0, v0: float = 0.0) -> None:
        """Put the mass at (x0, v0) with the actuator off (emulator start-up; a rig cannot do this)."""
        self._state[:] = (float(x0), float(v0), 0.0, 0.0)
        self.actuator.cut()
        self._velocity.reset()
        self._y = float(sense(float(x0), self._draw(), self.imperfections.sensor_quant))

    @property
    def x(self) -> float:
        """True position now (m)."""
        return float(self._state[0])

    @property
    def v(self) -> float:
        """True velocity now (m/s)."""
        return float(self._state[1])

    @property
    def measured(self) -> float:
        """The measured position now, y_k (m): what a controller deciding this sample's command reads."""
        return self._y

    def cut(self) -> None:
        """Disable the drive (watchdog): the applied force is 0 N from the next sample on."""
        self.actuator.cut()

    def _draw(self) -> float:
        """The next measurement's noise (m): one draw per measurement, none for a noise-free sensor
        (the stream :meth:`SensorModel.measure` uses, so records agree)."""
        std = self.imperfections.sensor_noise
        return std * float(self._noise.standard_normal()) if std > 0.0 else 0.0

    def step(self, command: float) -> RigRow:
        """Hold ``command`` (saturated to ±F; non-finite raises) for one sample; row k and y_{k+1}."""
        u = kernels.saturate(float(command), self.params.F)
        x, v, y = self.x, self.v, self._y
        imp = self.imperfections
        effort, _, self._y = transition(self._model, self._state, self.actuator.state, self.actuator.tick(),
                                        u, self._draw(), imp.delay_samples, self.actuator.lag, imp.offset,
                                        imp.friction, imp.sensor_quant)
        return RigRow(y, self._velocity.update(y), float(effort), x, v, float(self._y))

    def publish_delay(self) -> float:
        """Seconds between acquiring the next sample and publishing it (uniform in [0, jitter))."""
        top = self.imperfections.jitter
        return 0.0 if top <= 0 else float(self._jitter.uniform(0.0, top))
