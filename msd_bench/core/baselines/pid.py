"""PID baseline, tuned on the identified linear model at the set-point by a phase-margin rule.

The controller (``u = u_eq + P + I + D``, then saturation to ±F, then — for
``pid`` — the force of the paper's alphabet nearest to it; ``pid-continuous``
sends the saturated force itself, so the cost of the 5-force actuator shows):

* P on the error ``e = x* - y``;
* I by forward Euler, with **conditional integration** as anti-windup: the
  integral does not move while the unquantised command is beyond ±F and the
  error would push it further out. Why not back-calculation: with a 5-force
  actuator the quantiser is always "saturating" a little, and
  back-calculation on the quantised output would bleed the integral away by the
  quantisation error every sample;
* D on the *measurement* (no derivative kick at the step), filtered by a
  first-order lag ``Td / N`` (backward Euler), so sensor noise is not
  multiplied by ``Td / dt``;
* ``u_eq``, the model's equilibrium force at the set-point, as feed-forward
  (an industrial PID's manual reset): the integral then corrects the model's
  error instead of building the whole holding force.

Tuning rule (loop shaping for a target phase margin at a chosen crossover):
the linear model is the GLM itself or, for any other kind, the model
linearised at the set-point (:func:`base.operating_point`: for the PLM its
scheduled local model there). With ``Ti = alpha Td`` and ``Tf = Td / N``
fixed, the phase of the discrete loop ``C(z) G(z)`` at ``wc`` depends on
``Td`` only: ``Td`` is solved so that the phase is ``-180° + PM`` there and
``Kp`` so that ``|C G| = 1``. Why this rule and not pole placement: the
identified 2nd-order models differ most in their resonance, which pole
placement would cancel exactly (fragile to the model error the baseline is
meant to expose); a phase margin at a crossover is the robustness figure a
control engineer reads off first, and python-control computes it back
(``stability_margins``) so the artifact records what was achieved.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, NamedTuple

import control
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from msd_bench.core.baselines import base
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation import closed_loop
from msd_bench.core.evaluation.closed_loop import Conditions
from msd_bench.core.kernel_cache import kernel
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PidOptions:
    """The rule's constants (chosen on the design identification seeds, docs/baselines.md)."""

    crossover: float = 4.0
    """Target gain-crossover frequency wc, rad/s."""
    phase_margin: float = 60.0
    """Target phase margin at wc, degrees."""
    alpha: float = 4.0
    """Ti / Td (4: the classic ratio of a PID with two real zeros)."""
    n_filter: float = 10.0
    """N in the derivative filter Tf = Td / N."""
    quantised: bool = True
    """Send the nearest of the five alphabet forces (``pid``) or any force in ±F (``pid-continuous``)."""


class PidGains(NamedTuple):
    """The controller as compiled code reads it."""

    kp: float
    """Proportional gain, N/m."""
    ki: float
    """Integral gain, N/(m s)."""
    kd: float
    """Derivative gain, N s/m."""
    tf: float
    """Derivative filter time constant, s."""
    u_eq: float
    """Feed-forward: the model's equilibrium force at the set-point, N."""
    target: float
    """Set-point, m."""
    force: float
    """Saturation ±F, N."""
    dt: float
    """Sample time, s."""
    forces: FloatArray
    """The alphabet the output is quantised to (empty: continuous output)."""


@dataclass(frozen=True)
class PidDesign:
    """A tuned PID and the facts of its tuning."""

    gains: PidGains
    """The compiled controller."""
    facts: dict[str, float]
    """Tuning facts: the rule's targets and what python-control measured on the design loop."""
    surrogate: str
    """The model it was designed on."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready artifact: gains, targets, margins, bandwidth."""
        g = self.gains
        return {"design": "pid" if g.forces.size else "pid-continuous", "surrogate": self.surrogate,
                "kp": g.kp, "ki": g.ki, "kd": g.kd, "tf": g.tf, "u_eq": g.u_eq, "target": g.target,
                "force": g.force, "dt": g.dt, "forces": g.forces.tolist(), **self.facts}


def controller_tf(kp: float, td: float, opt: PidOptions, dt: float) -> control.TransferFunction:
    """``C(z)`` of the discrete law on the error: forward-Euler I, backward-Euler filtered D."""
    ti, tf = opt.alpha * td, td / opt.n_filter
    z = control.tf([1, 0], [1], dt)
    integral = control.tf([dt], [1, -1], dt)  # dt / (z - 1): forward Euler
    deriv = td * (z - 1) / ((tf + dt) * z - tf)
    return kp * (1 + integral / ti + deriv)


def _loop_phase(g: control.TransferFunction, td: float, opt: PidOptions, dt: float) -> float:
    """Unwrapped phase of C G at the crossover, degrees (independent of Kp)."""
    resp = (controller_tf(1.0, td, opt, dt) * g)(np.exp(1j * opt.crossover * dt))
    return math.degrees(float(np.angle(resp)))


def tune(g: control.TransferFunction, opt: PidOptions, dt: float) -> tuple[float, float]:
    """(Kp, Td) meeting the phase margin at the crossover; a one-line error when no Td does."""
    want = -180.0 + opt.phase_margin
    tds = np.logspace(-3, 1, 81)
    miss = [_loop_phase(g, td, opt, dt) - want for td in tds]
    for lo, hi, mlo, mhi in zip(tds[:-1], tds[1:], miss[:-1], miss[1:], strict=True):
        if mlo * mhi < 0.0 and abs(mlo - mhi) < 180.0:  # a real crossing, not the ±180° wrap
            td = float(brentq(lambda t: _loop_phase(g, t, opt, dt) - want, lo, hi, xtol=1e-10))
            kp = 1.0 / abs(complex((controller_tf(1.0, td, opt, dt) * g)(np.exp(1j * opt.crossover * dt))))
            return kp, td
    raise ConfigError(f"no PID with Ti = {opt.alpha} Td reaches a {opt.phase_margin}° phase margin "
                      f"at {opt.crossover} rad/s on this model")


def loop_facts(g: control.TransferFunction, c: control.TransferFunction) -> dict[str, float]:
    """What python-control measures on the design loop: margins, crossover, bandwidth, pole radius."""
    loop = c * g
    with warnings.catch_warnings():
        # python-control warns when it falls back from polynomial roots to its frequency-response
        # method for these near-unit-circle poles; the fallback is the accurate one here.
        warnings.filterwarnings("ignore", "stability_margins: Falling back", UserWarning)
        gm, pm, _, _, wc, _ = control.stability_margins(loop, returnall=False)
    closed = control.feedback(loop, 1)
    return {"phase_margin": float(pm), "crossover": float(wc),
            "gain_margin": float(gm) if math.isfinite(gm) else -1.0,
            "bandwidth": bandwidth(closed),
            "closed_loop_pole_radius": float(np.max(np.abs(control.poles(closed))))}


def bandwidth(closed: control.TransferFunction) -> float:
    """Closed-loop -3 dB bandwidth, rad/s: the first frequency where |T| falls below |T(1)|/sqrt(2).

    Measured on python-control's frequency response (its ``bandwidth`` handles
    continuous systems only); -1 when |T| stays above it up to Nyquist.
    """
    w = np.logspace(-2, math.log10(math.pi / closed.dt), 2000, endpoint=False)
    mag = np.abs(control.frequency_response(closed, w).complex).ravel()
    below = np.nonzero(mag < abs(float(control.dcgain(closed))) / math.sqrt(2.0))[0]
    return float(w[below[0]]) if below.size else -1.0


def design(model: StepModel, target: float, force: float, dt: float,
           options: PidOptions | None = None) -> PidDesign:
    """Tune the PID on ``model`` linearised at ``target`` (deterministic)."""
    opt = options or PidOptions()
    if not (opt.crossover > 0 and 0 < opt.phase_margin < 90 and opt.alpha > 0 and opt.n_filter > 0):
        raise ConfigError("PID options: need crossover > 0, 0 < phase_margin < 90, alpha > 0, n_filter > 0")
    if abs(dt - model.dt) > 1e-12:
        raise ConfigError(f"design dt {dt} differs from the model's {model.dt}")
    op = base.operating_point(model, target)
    g = base.transfer_function(op, dt)
    kp, td = tune(g, opt, dt)
    facts = {"target_phase_margin": opt.phase_margin, "target_crossover": opt.crossover,
             "alpha": opt.alpha, "n_filter": opt.n_filter, "td": td,
             **loop_facts(g, controller_tf(kp, td, opt, dt))}
    forces = base.alphabet(force) if opt.quantised else np.zeros(0)
    gains = PidGains(kp, kp / (opt.alpha * td), kp * td, td / opt.n_filter, op.u_eq, float(target),
                     float(force), float(dt), forces)
    return PidDesign(gains, facts, model.name)


def controller_state() -> FloatArray:
    """Zeroed memory: [integral, filtered derivative, last measurement]."""
    return np.zeros(3)


@kernel
def act(g: PidGains, cs: FloatArray, y: float, first: bool) -> float:
    """The force for measurement ``y``; updates the memory ``cs`` (integral, D filter, last y)."""
    if first:
        cs[:] = 0.0
        cs[2] = y
    e = g.target - y
    a = g.tf / (g.tf + g.dt)
    cs[1] = a * cs[1] - g.kd / (g.tf + g.dt) * (y - cs[2])
    cs[2] = y
    u: float = g.u_eq + g.kp * e + cs[0] + cs[1]
    if not ((u > g.force and e > 0.0) or (u < -g.force and e < 0.0)):
        cs[0] += g.ki * g.dt * e
    u = min(max(u, -g.force), g.force)
    if g.forces.size > 0:
        u = base.nearest(g.forces, u)
    return u


class PidRun(NamedTuple):
    """The PID as the one closed loop (:func:`closed_loop.run`) reads it: its gains and its memory."""

    gains: PidGains
    """The compiled controller."""
    memory: FloatArray
    """[integral, filtered derivative, last measurement] (:func:`controller_state`)."""


@closed_loop.decision(PidRun)
@kernel
def decide(c: PidRun, j: int, k: int, y: float, target: float) -> float:
    """The PID's force for ``y`` (its set-point is the one it was tuned at; the first sample resets it)."""
    return act(c.gains, c.memory, y, k == 0)


class Pid:
    """The stepwise form for an agent node: ``reset()``, then ``act(y)`` once per sample."""

    def __init__(self, d: PidDesign) -> None:
        self.gains = d.gains
        self.cs = controller_state()
        self.first = True

    def reset(self) -> None:
        """Back to rest: the next measurement starts a new run."""
        self.cs[:] = 0.0
        self.first = True

    def act(self, y: float) -> float:
        """The force for the measured position ``y`` (m)."""
        u = float(act(self.gains, self.cs, base.measured(y), self.first))
        self.first = False
        return u


Options = PidOptions
"""The baseline face (:mod:`msd_bench.core.baselines.catalogue`): its keyword options."""
Stepwise = Pid
"""The baseline face: the stepwise form built from a design."""


def rollout(plant: Kernel, d: PidDesign, cond: Conditions,
            noise: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The baseline face: every row of ``noise`` one run from rest in the one closed loop; (true x, u)."""
    t = closed_loop.run(plant, PidRun(d.gains, controller_state()), cond, noise, closed_loop.AT_REST,
                        closed_loop.NO_LIMITS, False, False, 0)
    return t.x, t.command
