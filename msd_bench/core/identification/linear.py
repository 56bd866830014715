"""Second-order discrete output-error fit: our stand-in for MATLAB ``tfest`` + ``c2d``.

The paper (§3.2, §3.4.1) estimates a continuous-time second-order transfer
function with ``tfest`` and discretises it at Δt = 0.01 s. We fit the discrete
model directly,

    G(z) = (n1 z^-1 + n2 z^-2) / (1 + d1 z^-1 + d2 z^-2),

in deviation coordinates around an operating point ``(u0, y0)``. This is the
same model class: the zero-order-hold image of a strictly proper second-order
continuous system has exactly this form, and :meth:`LinearFit.to_continuous`
maps it back (exact inverse of ZOH, via the matrix logarithm).

Why output error: like ``tfest`` we minimise the *free-run simulation* error,
the quantity the paper reports and the one a Q-learner trained on the model
feels. Least-squares ARX only initialises it: with poles this close to 1
(Δt small against the plant's time constants) ARX is badly biased by any
output noise, while the output-error estimate is not.

Initial conditions: the two initial outputs of every experiment are
estimated jointly with the coefficients (``tfest``'s ``InitialCondition =
'estimate'``), starting from the first two measured outputs. Taking the raw
samples as exact instead turns sensor noise into an initial velocity error
(0.28 m/s for 2 mm at 10 ms) whose transient, with poles this close to 1,
lasts seconds; under 2 mm of noise it pulled the ±1 N PRBS fits of the PLM
into wrong optima.

Start: the ARX estimate on the raw record and the ARX estimate on the record
low-pass filtered with one zero-phase filter on both force and position (for
an LTI system the filtered pair obeys the same model, and the filter removes
most of the noise that biases ARX); the refinement starts from whichever of the
two has the smaller simulation error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.optimize import least_squares

from msd_bench.core.errors import IdentificationError, InvalidInputError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.physics.sensor import lowpass

if TYPE_CHECKING:  # python-control and scipy.signal load when used: every process that identifies
    import control  # imports this module, and they cost most of a command's start-up (0.8 s here)

FloatArray = NDArray[np.float64]

_SIM_CLAMP = 1e6
"""Simulated outputs are clamped here so an unstable trial step stays finite."""

PREFILTER_HZ = 4.0
"""Cut-off of the zero-phase low-pass of the filtered ARX start, Hz (the plant's modes are below 1 Hz)."""


@dataclass(frozen=True)
class LinearFit:
    """A fitted second-order discrete model in deviation coordinates."""

    n1: float
    """Numerator coefficient of z^-1 (gain of the force one sample back)."""
    n2: float
    """Numerator coefficient of z^-2."""
    d1: float
    """Denominator coefficient of z^-1."""
    d2: float
    """Denominator coefficient of z^-2."""
    u0: float
    """Operating-point force the deviations are taken around, N."""
    y0: float
    """Operating-point position the deviations are taken around, m."""
    dt: float
    """Sample time, s."""
    method: str = "oe"
    """``"oe"`` (simulation-error refined) or ``"arx"`` (fallback: refinement ended unstable)."""

    @property
    def coefficients(self) -> tuple[float, float, float, float]:
        """``(n1, n2, d1, d2)``."""
        return (self.n1, self.n2, self.d1, self.d2)

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Roots of z^2 + d1 z + d2."""
        return np.roots([1.0, self.d1, self.d2]).astype(complex)

    @property
    def is_stable(self) -> bool:
        """All poles strictly inside the unit circle."""
        return bool(np.all(np.abs(self.poles) < 1.0))

    @property
    def dc_gain(self) -> float:
        """Static gain (n1 + n2) / (1 + d1 + d2), m/N."""
        return (self.n1 + self.n2) / (1.0 + self.d1 + self.d2)

    def to_params(self, stroke: float) -> FloatArray:
        """Packed ``KIND_LINEAR`` parameters ``[L, n1, n2, d1, d2, u0, y0]``."""
        return np.array([stroke, self.n1, self.n2, self.d1, self.d2, self.u0, self.y0])

    def to_transfer_function(self) -> control.TransferFunction:
        """Discrete ``G(z) = (n1 z + n2) / (z^2 + d1 z + d2)`` with ``dt`` (deviation input -> output)."""
        import control

        return control.tf([self.n1, self.n2], [1.0, self.d1, self.d2], self.dt)

    def to_continuous(self) -> control.TransferFunction:
        """The continuous-time system whose zero-order-hold discretisation is this model.

        ``A_c = logm(A) / dt`` and ``B_c = A_c (A - I)^-1 B`` invert the ZOH map
        exactly. It exists only when no pole is on the negative real axis or at 1.
        """
        poles = self.poles
        if np.any((np.abs(poles.imag) < 1e-12) & (poles.real <= 0.0)) or np.any(
            np.abs(poles - 1.0) < 1e-12
        ):
            raise IdentificationError(
                f"no continuous-time equivalent: a discrete pole is at 1 or on the negative axis ({poles})"
            )
        a = np.array([[-self.d1, -self.d2], [1.0, 0.0]])
        b = np.array([[1.0], [0.0]])
        c = np.array([[self.n1, self.n2]])
        ac = np.real(scipy.linalg.logm(a)) / self.dt
        bc = ac @ np.linalg.solve(a - np.eye(2), b)
        num, den = _ss_to_tf(ac, bc, c)
        import control

        return control.tf(num, den)


def arx_fit(
    experiments: Sequence[Experiment], u0: float, y0: float, dt: float, fit_offset: bool = False
) -> LinearFit:
    """Least-squares ARX ``y[k] = n1 u[k-1] + n2 u[k-2] - d1 y[k-1] - d2 y[k-2]`` (deviations).

    With ``fit_offset`` an intercept is estimated too and folded into ``y0``.
    """
    rows, targets = [], []
    for e in experiments:
        u, y = e.u - u0, e.y - y0
        cols = [u[1:-1], u[:-2], -y[1:-1], -y[:-2]] + ([np.ones(len(e) - 2)] if fit_offset else [])
        rows.append(np.column_stack(cols))
        targets.append(y[2:])
    phi, target = np.vstack(rows), np.concatenate(targets)
    scale = np.linalg.norm(phi, axis=0)
    if np.any(scale == 0.0):
        raise IdentificationError("record has no excitation: force or position is constant")
    theta = np.linalg.lstsq(phi / scale, target, rcond=None)[0] / scale
    n1, n2, d1, d2 = theta[:4].tolist()
    if fit_offset and abs(1.0 + d1 + d2) > 1e-12:
        y0 += float(theta[4] / (1.0 + d1 + d2))
    return LinearFit(n1, n2, d1, d2, u0, y0, dt, method="arx")


def simulate_deviation(
    theta: FloatArray, e: Experiment, u0: float, y0: float, init: tuple[float, float] | None = None
) -> FloatArray:
    """Free-run output (absolute) of ``theta = (n1, n2, d1, d2)`` over ``e``.

    Outputs 0 and 1 are ``init = (y[0], y[1])`` (absolute), or the measured
    ones when ``init`` is None; the rest is simulated from them.
    """
    from scipy.signal import lfilter, lfiltic

    n1, n2, d1, d2 = theta
    u = e.u - u0
    ya, yb = (float(e.y[0]), float(e.y[1])) if init is None else init
    b, a = [0.0, n1, n2], [1.0, d1, d2]
    zi = lfiltic(b, a, y=[yb - y0, ya - y0], x=[u[1], u[0]])
    out, _ = lfilter(b, a, u[2:], zi=zi)
    return np.concatenate([[ya, yb], y0 + out])


def oe_fit(
    experiments: Sequence[Experiment],
    u0: float,
    y0: float,
    dt: float,
    max_nfev: int = 200,
    fit_offset: bool = False,
    units: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> LinearFit:
    """Output-error fit: ARX start, then least squares on the joint free-run error.

    ``units`` (metres per paper metre, newtons per paper newton, the time unit: a rig's
    :class:`~msd_bench.core.rigs.scales.Scales` length, force and pace) put the refinement in paper
    units (each coefficient, output and residual divided by its unit) and the prefilter's cut-off in
    the rig's time unit; all 1.0, the paper's plant, change nothing.

    The two initial outputs of every experiment are estimated too (see the
    module docstring). ``fit_offset`` also estimates ``y0`` (starting from the
    value given): the output the model assigns to the input ``u0``. Falls back
    to the ARX estimate if the refinement ends unstable; raises
    :class:`IdentificationError` when neither estimate is stable.
    """
    _check_experiments(experiments)
    length, force, pace = units
    start = _best_start(experiments, u0, y0, dt, fit_offset, PREFILTER_HZ / pace)
    n_head = 5 if fit_offset else 4
    gain = length / force  # n1, n2 are metres per newton
    scale = np.array([gain, gain, 1.0, 1.0] + ([length] if fit_offset else [])
                     + [length] * (2 * len(experiments)))

    def unpack(theta: FloatArray) -> tuple[FloatArray, float]:
        return theta[:4], (float(theta[4]) if fit_offset else y0)

    def residuals(z: FloatArray) -> FloatArray:
        theta = z * scale
        coef, off = unpack(theta)
        parts = []
        for i, e in enumerate(experiments):
            init = (float(theta[n_head + 2 * i]), float(theta[n_head + 2 * i + 1]))
            with np.errstate(over="ignore"):  # a diverging trial: clamped below, as before
                parts.append((simulate_deviation(coef, e, u0, off, init) - e.y) / length)
        r = np.concatenate(parts)
        return np.clip(np.nan_to_num(r, nan=_SIM_CLAMP), -_SIM_CLAMP, _SIM_CLAMP)

    inits = [v for e in experiments for v in (float(e.y[0]), float(e.y[1]))]
    x0 = np.array([*start.coefficients] + ([start.y0] if fit_offset else []) + inits) / scale
    sol = least_squares(residuals, x0, x_scale="jac", method="trf", max_nfev=max_nfev)
    coef, off = unpack(sol.x * scale)
    n1, n2, d1, d2 = (float(c) for c in coef)
    refined = LinearFit(n1, n2, d1, d2, u0, off, dt, method="oe")
    if refined.is_stable:
        return refined
    if start.is_stable:
        return start
    raise IdentificationError("linear fit is unstable (a pole on or outside the unit circle)")


def _best_start(
    experiments: Sequence[Experiment], u0: float, y0: float, dt: float, fit_offset: bool,
    prefilter_hz: float = PREFILTER_HZ,
) -> LinearFit:
    """The raw or the prefiltered ARX estimate (stabilised), whichever simulates the record better."""
    candidates = [arx_fit(experiments, u0, y0, dt, fit_offset)]
    filtered = [_prefiltered(e, dt, prefilter_hz) for e in experiments]
    if all(f is not None for f in filtered):
        candidates.append(arx_fit([f for f in filtered if f is not None], u0, y0, dt, fit_offset))
    candidates = [c if c.is_stable else _stabilised(c) for c in candidates]
    return min(candidates, key=lambda c: _sim_cost(c, experiments))


def _prefiltered(e: Experiment, dt: float, hz: float = PREFILTER_HZ) -> Experiment | None:
    """Force and position through the same zero-phase low-pass at ``hz`` (None if too short or dt too
    coarse)."""
    if 0.5 / dt <= hz or len(e) < 60:
        return None
    return Experiment(lowpass(e.u, dt, hz), lowpass(e.y, dt, hz), e.name)


def _sim_cost(fit: LinearFit, experiments: Sequence[Experiment]) -> float:
    """Sum of squared free-run errors from the measured starts (to rank candidate starts)."""
    total = 0.0
    for e in experiments:
        r = simulate_deviation(np.array(fit.coefficients), e, fit.u0, fit.y0) - e.y
        total += float(np.sum(np.clip(np.nan_to_num(r, nan=_SIM_CLAMP), -_SIM_CLAMP, _SIM_CLAMP) ** 2))
    return total


def _stabilised(fit: LinearFit) -> LinearFit:
    """Reflect unstable poles into the unit circle (keeps the start usable for refinement)."""
    poles = fit.poles
    poles = np.where(np.abs(poles) >= 1.0, 0.999 * poles / np.abs(poles) ** 2, poles)
    poles = np.where(np.abs(poles) >= 1.0, 0.999 * poles / np.abs(poles), poles)
    den = np.real(np.poly(poles))
    return LinearFit(fit.n1, fit.n2, float(den[1]), float(den[2]), fit.u0, fit.y0, fit.dt, "arx")


def _ss_to_tf(a: FloatArray, b: FloatArray, c: FloatArray) -> tuple[list[float], list[float]]:
    """Numerator and denominator of ``c (sI - a)^-1 b`` for a 2x2 system."""
    den = [1.0, -float(np.trace(a)), float(np.linalg.det(a))]
    # adj(sI - a) = s I + [[-a22, a12], [a21, -a11]]
    adj = np.array([[-a[1, 1], a[0, 1]], [a[1, 0], -a[0, 0]]])
    num = [float((c @ b)[0, 0]), float((c @ adj @ b)[0, 0])]
    return num, den


def _check_experiments(experiments: Sequence[Experiment]) -> None:
    if not experiments:
        raise InvalidInputError("linear fit needs at least one experiment")
    for e in experiments:
        if len(e) < 10:
            raise InvalidInputError(f"experiment {e.name!r} is too short to fit ({len(e)} samples)")
