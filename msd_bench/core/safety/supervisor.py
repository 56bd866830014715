"""A safety supervisor between any controller and the plant (docs/supervisor.md).

It is a *safety filter*: each sample it takes the controller's command and the
position the rig *measured* (never a truth a rig does not have), and passes
the command through unless the mass could then no longer be kept inside the
position envelope with the actuator it has. Only then does it override, with
the braking force of the alphabet (∓F), and it hands control back as soon as
the controller's command is safe again. Around the filter sit the run guards:
a velocity limit, a stale-state timeout, an episode time limit, a divergence
detector (the tracking error staying above its best for T s) and an e-stop
latch. A stale state, the time limit, a divergence and an e-stop end the run as
*aborted* with their reason; after an abort the supervisor holds 0 N (still
filtered, so a moving mass is braked), and after an e-stop 0 N unconditionally.

Why a conservative bound and not a model rollout: the braking distance must be
an upper bound on every rig the supervisor may face (a heavier mass, a lagging
drive, friction), and it must cost a few flops so the node can run it every
sample. From position ``p`` (towards one stop) and outward speed ``w``, the
mass first coasts for the latency ``T`` (the sample the command holds plus the
drive's dead time and lag) under the candidate's outward push
``a = max(u_out, 0) / m_min``, reaching ``p1 = p + w T + a T²/2`` at speed
``w1 = w + a T``; from there it brakes at least at ``B + β v``:

    stop = p1 + w1/β − (B/β²) ln(1 + β w1 / B)          (→ p1 + w1²/(2B) as β → 0)

with ``B = (brake_share · F + passive_share · s(p1)) / m_max`` and
``β = passive_share · c / m_max``. ``s(p1) = k sin(g p1) + h p1³`` is the
stated plant's spring force at ``p1`` when ``p1`` lies on the side of the stop
(0 otherwise): the spring force only grows from there to the stop (checked for
the stated plant by :meth:`SupervisorOptions.limits`; if it did not, the
spring is not counted). The damping ``c v`` brakes for as long as the mass
moves outward. ``passive_share`` derates both for a rig whose spring and damper
are weaker than stated. What is left out only helps: the spring and damping
during the latency, and friction. On the far side of the origin the spring
pushes the mass outward, but its potential is even and grows with ``|x|`` over
the stroke (``g L/2 < π``), so it takes back what it gave before the mass
passes its start's mirror image. ``w`` is the velocity estimated from the
measured positions plus ``v_margin`` (noise on that estimate), never below 0.

Two forms, bit for bit the same (tests/core/test_supervisor.py): the compiled
:func:`filter_step` on a flat state vector (what the batch loops of
:mod:`msd_bench.core.safety.adversaries` call) and :class:`Supervisor`, the stepwise
shell a node holds, which calls the same compiled functions.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics.plant import PlantParams

if TYPE_CHECKING:
    from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]

# Reasons: why the supervisor chose the force (NONE: the controller's command went through).
NONE = 0
ENVELOPE = 1
VELOCITY = 2
STALE = 3
TIME_LIMIT = 4
DIVERGENCE = 5
ESTOP = 6
REASONS = ("none", "envelope", "velocity", "stale", "time_limit", "divergence", "estop")
"""Reason names by code; the last four end a run as aborted."""
ABORTS = (STALE, TIME_LIMIT, DIVERGENCE, ESTOP)

# Slots of the state vector (float64[STATE_SIZE]); zeros = a new run at rest.
S_Y = 0
"""Last measured position, m."""
S_HAVE_Y = 1
"""1 once a position was measured (the first velocity estimate is 0)."""
S_T = 2
"""Run time, s: samples filtered × dt (never a clock)."""
S_E_LOW = 3
"""Lowest tracking error since the divergence timer last restarted, m."""
S_DIV = 4
"""Divergence timer: how long the error has stayed above S_E_LOW + div_tol, s."""
S_ABORT = 5
"""Abort reason code (NONE while the run goes on)."""
S_V = 6
"""Last velocity estimate, m/s (reported)."""
STATE_SIZE = 7


@dataclass(frozen=True)
class SupervisorOptions:
    """What the supervisor guards; ``None`` = derived from the plant's stroke and F (:meth:`limits`)."""

    envelope: float | None = None
    """Position envelope |x| <= envelope, m; default 0.9 of the half stroke (2.25 m of 2.5:
    the ±10 N bias records hold the mass near 1.98 m, inside it)."""
    margin: float | None = None
    """Stated tolerance beyond the envelope, m: the supervisor claims never to let the mass
    past envelope + margin (the tests hold it to that); must leave room before the stop.
    Default: a third of the gap between the envelope and the stop."""
    v_max: float | None = None
    """Velocity limit, m/s: beyond it a command pushing along the motion is replaced by the
    brake. Default: the speed the derated brake stops from within the envelope."""
    v_margin: float = 0.5
    """Added to the estimated outward speed, m/s: covers the noise of a velocity differenced
    from measured positions (0.28 m/s standard deviation for the rig's 2 mm sensor noise)."""
    brake_share: float = 0.6
    """Share of F the braking distance counts on (model error: a weaker or lagging drive)."""
    passive_share: float = 0.5
    """Share of the stated plant's spring and damping forces the braking distance counts on
    (model error: a rig's spring and damper may be weaker than stated; the population draws
    them down to 0.8 of the default, the robustness suite's damping is 0.7). 0 counts on the
    drive alone, which overrides a good controller that approaches the envelope fast."""
    mass_factor: float = 1.3
    """The mass is assumed within [m / mass_factor, m · mass_factor] of the stated plant's."""
    latency: float = 0.04
    """Seconds before a braking command fully acts: the sample it holds plus dead time and
    drive lag (the rig emulator's defaults: 1 sample and a 20 ms lag)."""
    stale_timeout: float = 0.1
    """No measured state for this long (s) ends the run as aborted with 0 N (10 samples)."""
    time_limit: float = 0.0
    """Episode time limit, s: the run is aborted when it is reached; 0 = none."""
    div_time: float = 3.0
    """Divergence: the tracking error staying above its best + div_tol this long (s) aborts;
    0 = no divergence detector."""
    div_tol: float = 0.25
    """Divergence tolerance, m (noise and an overshoot stay below it)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None and f.default is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"supervisor option {f.name} must be a finite number, got {value!r}")
            if value < 0:
                raise ConfigError(f"supervisor option {f.name} must be >= 0, got {value}")
        if not 0 < self.brake_share <= 1:
            raise ConfigError(f"supervisor option brake_share must be in (0, 1], got {self.brake_share}")
        if self.passive_share > 1:
            raise ConfigError(f"supervisor option passive_share must be in [0, 1], got {self.passive_share}")
        if self.mass_factor < 1:
            raise ConfigError(f"supervisor option mass_factor must be >= 1, got {self.mass_factor}")
        if self.stale_timeout <= 0:
            raise ConfigError(f"supervisor option stale_timeout must be > 0, got {self.stale_timeout}")

    def scaled(self, scales: Scales) -> SupervisorOptions:
        """These options, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md §Scales):
        lengths × length, speeds × length / pace, times × pace; shares and factors are ratios and stay.
        Itself on the paper's plant, bit for bit."""
        if scales.is_default:
            return self
        m, s = scales.metres, scales.seconds

        def opt(value: float | None, f: Callable[[float], float]) -> float | None:
            return None if value is None else f(value)

        return replace(self, envelope=opt(self.envelope, m), margin=opt(self.margin, m),
                       v_max=opt(self.v_max, scales.speed), v_margin=scales.speed(self.v_margin),
                       latency=s(self.latency), stale_timeout=s(self.stale_timeout),
                       time_limit=s(self.time_limit), div_time=s(self.div_time), div_tol=m(self.div_tol))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], what: str = "supervisor options") -> SupervisorOptions:
        """Options from a parameter file's object; an unknown or mistyped key is one line."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(str(k) for k in values if k not in known)
        if unknown:
            raise ConfigError(f"{what}: unknown option {unknown[0]!r}; known: {sorted(known)}")
        return cls(**{str(k): v for k, v in values.items()})

    def limits(self, plant: PlantParams) -> Limits:
        """The options resolved against ``plant`` (its stroke, F, m and dt) for compiled code."""
        half = plant.x_max
        envelope = 0.9 * half if self.envelope is None else float(self.envelope)
        if not 0 < envelope < half:
            raise ConfigError(
                f"supervisor envelope must be in (0, {half}) m (inside the stroke), got {envelope}")
        margin = (half - envelope) / 3.0 if self.margin is None else float(self.margin)
        if envelope + margin >= half:
            raise ConfigError(f"supervisor envelope + margin ({envelope} + {margin} m) must stay below "
                              f"the stop at {half} m")
        brake = self.brake_share * plant.F / (plant.m * self.mass_factor)
        if not brake > 0:
            raise ConfigError(f"supervisor brake_share {self.brake_share} and mass_factor {self.mass_factor} "
                              f"leave no braking deceleration")
        v_max = math.sqrt(2.0 * brake * envelope) if self.v_max is None else float(self.v_max)
        if v_max <= 0:
            raise ConfigError(f"supervisor option v_max must be > 0, got {v_max}")
        passive = float(self.passive_share) / (plant.m * self.mass_factor)
        spring = passive if _spring_grows(plant) else 0.0
        return Limits(envelope=envelope, margin=margin, v_max=v_max, v_margin=float(self.v_margin),
                      brake=brake, spring_k=spring * plant.k, spring_g=plant.g, spring_h=spring * plant.h,
                      damping=passive * plant.c, push=self.mass_factor / plant.m,
                      latency=max(float(self.latency), plant.dt), stale_timeout=float(self.stale_timeout),
                      time_limit=float(self.time_limit), div_time=float(self.div_time),
                      div_tol=float(self.div_tol), F=plant.F, dt=plant.dt)


def _spring_grows(plant: PlantParams) -> bool:
    """Whether the stated spring force grows from the origin to the stop (the braking bound counts the
    spring at the start of the braking path as its least): stiffness k g cos(g x) + 3 h x² > 0."""
    x = np.linspace(0.0, plant.x_max, 1001)
    return bool(np.all(plant.k * plant.g * np.cos(plant.g * x) + 3.0 * plant.h * x * x > 0.0))


class Limits(NamedTuple):
    """Resolved options as compiled code reads them (units and meaning: :class:`SupervisorOptions`)."""

    envelope: float
    margin: float
    v_max: float
    v_margin: float
    brake: float
    """Derated braking deceleration of the drive, m/s²."""
    spring_k: float
    """Derated spring gain per kilogram counted as braking, k · passive_share / m_max (0: the spring
    is not counted)."""
    spring_g: float
    """The stated spring's spatial frequency, rad/m."""
    spring_h: float
    """Derated cubic hardening per kilogram, h · passive_share / m_max."""
    damping: float
    """Derated damping per kilogram, c · passive_share / m_max, 1/s."""
    push: float
    """Largest acceleration per newton of outward command, 1/kg (1 / m_min)."""
    latency: float
    stale_timeout: float
    time_limit: float
    div_time: float
    div_tol: float
    F: float
    dt: float

    def describe(self) -> str:
        """One line for the start-up log: every limit the run is held to."""
        return (f"supervisor: envelope ±{self.envelope:.3g} m (margin {self.margin:.3g} m), "
                f"v_max {self.v_max:.3g} m/s (+{self.v_margin:.3g} m/s estimate margin), "
                f"brake {self.brake:.3g} m/s² after {self.latency:.3g} s (+ spring "
                f"{'counted' if self.spring_k > 0 else 'not counted'}, damping {self.damping:.3g}/s), "
                f"stale {self.stale_timeout:.3g} s, time limit "
                f"{'none' if self.time_limit <= 0 else f'{self.time_limit:.3g} s'}, divergence "
                f"{'off' if self.div_time <= 0 else f'{self.div_tol:.3g} m for {self.div_time:.3g} s'}")


@kernel
def stop_position(lim: Limits, p: float, w: float, u_out: float) -> float:
    """Bound on how far towards one stop the mass gets (module docstring): position ``p`` and
    outward speed ``w`` on that side, ``u_out`` the candidate's outward force."""
    w = max(w + lim.v_margin, 0.0)
    a = max(u_out, 0.0) * lim.push
    t = lim.latency
    p1 = p + w * t + 0.5 * a * t * t
    w1 = w + a * t
    spring = lim.spring_k * math.sin(lim.spring_g * p1) + lim.spring_h * p1 * p1 * p1 if p1 > 0.0 else 0.0
    return p1 + braking_distance(lim.brake + max(spring, 0.0), lim.damping, w1)


@kernel
def braking_distance(b: float, beta: float, w: float) -> float:
    """How far a mass moving at ``w`` (>= 0) goes under the deceleration ``b + beta * v`` (``b`` > 0):
    the integral of v dv / (b + beta v), in the closed form of the module docstring."""
    r = beta * w / b
    if r < 1e-6:  # the series (w²/2b)(1 - 2r/3): no cancellation when the damping is small
        return w * w / (2.0 * b) * (1.0 - 2.0 * r / 3.0)
    return w / beta - b / (beta * beta) * math.log1p(r)


@kernel
def _filter(lim: Limits, y: float, v: float, u: float) -> tuple[float, int]:
    """The envelope and velocity checks on a candidate ``u``: (force, reason)."""
    for side in (1.0, -1.0):
        if stop_position(lim, side * y, side * v, side * u) > lim.envelope:
            brake = -side * lim.F
            return brake, NONE if brake == u else ENVELOPE
    if abs(v) > lim.v_max and u * v > 0.0:
        brake = -lim.F if v > 0.0 else lim.F
        return brake, VELOCITY
    return u, NONE


@kernel
def _diverging(lim: Limits, st: FloatArray, error: float) -> bool:
    """Update the divergence timer with this sample's tracking error; True once it ran out."""
    if lim.div_time <= 0.0:
        return False
    if error <= st[S_E_LOW] + lim.div_tol:
        st[S_E_LOW] = min(st[S_E_LOW], error)
        st[S_DIV] = 0.0
        return False
    st[S_DIV] += lim.dt
    return bool(st[S_DIV] >= lim.div_time - 0.5 * lim.dt)


@kernel
def filter_step(lim: Limits, st: FloatArray, y: float, reference: float, u: float) -> tuple[float, int]:
    """One sample: the measured position ``y``, the set-point and the controller's ``u`` in;
    the force to apply and the reason it was chosen (``NONE``: ``u`` itself) out.

    ``st`` (``STATE_SIZE`` zeros for a new run) is updated in place. A non-finite ``u`` is the
    plant's to refuse; the supervisor passes it on unless it overrides.
    """
    v = (y - st[S_Y]) / lim.dt if st[S_HAVE_Y] > 0.0 else 0.0
    error = abs(y - reference)
    if st[S_HAVE_Y] == 0.0:
        st[S_E_LOW] = error
    st[S_Y] = y
    st[S_HAVE_Y] = 1.0
    st[S_V] = v
    st[S_T] += lim.dt
    if st[S_ABORT] == NONE:
        if lim.time_limit > 0.0 and st[S_T] >= lim.time_limit - 0.5 * lim.dt:
            st[S_ABORT] = TIME_LIMIT
        elif _diverging(lim, st, error):
            st[S_ABORT] = DIVERGENCE
    abort = int(st[S_ABORT])
    if abort == ESTOP:
        return 0.0, ESTOP
    if abort != NONE:
        force, why = _filter(lim, y, v, 0.0)
        return force, abort if why == NONE else why
    return _filter(lim, y, v, u)


@kernel
def mark_abort(st: FloatArray, reason: int) -> None:
    """End the run as aborted for ``reason`` (a stale state, an e-stop); an e-stop outranks all."""
    if st[S_ABORT] == NONE or reason == ESTOP:
        st[S_ABORT] = reason


MAX_LATCH_TEXT = 20
"""Longest e-stop clear that is parsed (a latch count is a few digits)."""


def parse_latch(text: str) -> int:
    """The latch count an e-stop clear names; -1 if it names none, so it matches no latch.

    The count must be written as ``str(count)`` is (surrounding blanks allowed): ASCII decimal
    digits without a sign or a leading zero, so exactly one spelling clears a latch (``'01'``,
    ``'+1'`` and ``'1.0'`` clear nothing). The count is printed in the log and on /diagnostics:
    a clear proves its sender saw the current latch, not who the sender is (docs/faults.md
    §Trust boundary)."""
    t = text.strip()
    if not (0 < len(t) <= MAX_LATCH_TEXT and t.isascii() and t.isdigit()) or (t[0] == "0" and t != "0"):
        return -1
    return int(t)


class LogThrottle:
    """At most one log line per ``period`` seconds, each saying how many events it stands for.

    Why: a wrong e-stop clear is logged (an operator must see it was ignored), but anyone on the
    domain can send thousands; one line per second with a count keeps the log readable and its
    size bounded. The clock is passed in, so the science stays testable without ROS.
    """

    def __init__(self, period: float = 1.0) -> None:
        self.period = period
        self._last: float | None = None
        self.pending = 0
        """Events not yet reported by a line."""

    def note(self, now: float) -> int:
        """Count one event at ``now``; return how many events a line written now stands for (0: stay
        quiet)."""
        self.pending += 1
        if self._last is not None and now - self._last < self.period:
            return 0
        self._last, count, self.pending = now, self.pending, 0
        return count


class Decision(NamedTuple):
    """What the supervisor did with one command."""

    force: float
    """The force to send to the plant, N."""
    reason: int
    """Why it was chosen (``REASONS[reason]``); ``NONE``: the controller's command."""

    @property
    def overridden(self) -> bool:
        """True when the supervisor, not the controller, chose the force."""
        return self.reason != NONE


class Supervisor:
    """The stepwise form a node holds: the compiled filter plus counters and the e-stop latch.

    The e-stop follows docs/faults.md §Trust boundary: anyone may latch it, any number of
    times (each latch counts); only :meth:`clear_estop` naming the current latch count
    clears it, so a clear sent before a later latch, or replayed, clears nothing. A
    :meth:`reset` (a new run) never clears it.
    """

    def __init__(self, options: SupervisorOptions, plant: PlantParams) -> None:
        self.limits = options.limits(plant)
        self.state = np.zeros(STATE_SIZE)
        self.counts = dict.fromkeys(REASONS[1:], 0)
        self.steps = 0
        self.estop_latches = 0
        self.estop_latched = False

    def reset(self) -> None:
        """A new run from rest: the filter state and the run's counters start over (not the e-stop)."""
        self.state[:] = 0.0
        if self.estop_latched:
            mark_abort(self.state, ESTOP)
        self.counts = dict.fromkeys(REASONS[1:], 0)
        self.steps = 0

    def step(self, y: float, reference: float, u: float) -> Decision:
        """Filter the controller's ``u`` given the measured ``y``; counts overrides by reason."""
        force, reason = filter_step(self.limits, self.state, float(y), float(reference), float(u))
        return self._count(Decision(float(force), int(reason)))

    def stale(self) -> Decision:
        """No state arrived for ``stale_timeout``: the run is aborted and the force is 0 N."""
        mark_abort(self.state, STALE)
        return self._count(Decision(0.0, ESTOP if self.estop_latched else STALE))

    def latch_estop(self) -> int:
        """Latch the e-stop (always honoured); returns the latch count a clear must name."""
        self.estop_latches += 1
        self.estop_latched = True
        mark_abort(self.state, ESTOP)
        return self.estop_latches

    def clear_estop(self, latch: int) -> bool:
        """Clear the e-stop if ``latch`` is the current latch count; True if it was cleared.

        A cleared e-stop lets the *next* run go (:meth:`reset`); the aborted run stays aborted.
        """
        if not self.estop_latched or latch != self.estop_latches:
            return False
        self.estop_latched = False
        return True

    @property
    def aborted(self) -> str | None:
        """The reason the run was aborted, or None while it goes on."""
        code = int(self.state[S_ABORT])
        return None if code == NONE else REASONS[code]

    def _count(self, d: Decision) -> Decision:
        self.steps += 1
        if d.reason != NONE:
            self.counts[REASONS[d.reason]] += 1
        return d
