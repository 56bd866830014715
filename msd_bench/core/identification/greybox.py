"""Grey-box surrogate: the plant's own structure with fitted parameters.

``m x'' = u - c x' - k sin(g x) - h x³`` with hard stops at ±L/2 and the force
saturated at ±F, stepped by the plant's own compiled transition
(``kernels.KIND_PLANT``). The stroke L, the saturation F and the sample time
are known (configuration and record), the five physical parameters
``(m, c, k, g, h)`` are fitted — what MATLAB's ``nlgreyest`` does for an
``idnlgrey`` model:

1. **Equation-error start.** With Euler steps the plant satisfies, for every
   sample clear of the stops, ``u_k = m a_k + c v_k + k sin(g x_k) + h x_k³``
   with ``v_k = (x_k - x_{k-1})/dt`` and ``a_k = (x_{k+1} - 2x_k + x_{k-1})/dt²``.
   For a fixed g this is linear in ``(m, c, k, h)``; g is found by a scan and a
   bounded scalar search (variable projection). Positions and forces are
   low-pass filtered first with the same zero-phase filter (a second
   difference of raw positions is dominated by sensor noise), and samples
   near the stops are masked (there the plant zeroes the velocity and the
   equation does not hold).
2. **Simulation-error refinement.** Least squares on the free-run output
   error over the whole record (``scipy.optimize.least_squares``), the
   parameters in log coordinates (all positive), the initial position and
   velocity of every experiment estimated alongside. The free run goes
   through the stops like the plant, so no sample needs masking here.
3. **A bounded retry** when the refinement runs off (a parameter more than
   a thousandfold from its start: a record that does not determine it, as a
   rig's Coulomb friction can make of the spring): the same least squares
   with every parameter held within a hundredfold of its start.

On noise-free records the start is already exact up to the filter's blur and
the refinement removes the rest; under sensor noise the simulation error is
unbiased where the equation error is not (noise on both sides of the
regression).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares, minimize_scalar

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification.data import Experiment
from msd_bench.core.physics import kernels
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.physics.sensor import clear_of_stops, lowpass, lowpass_reach
from msd_bench.core.rigs.scales import Scales

FloatArray = NDArray[np.float64]

PARAM_NAMES = ("m", "c", "k", "g", "h")
"""The fitted physical parameters, in :meth:`PlantParams.as_array` order."""


@dataclass(frozen=True)
class GreyboxConfig:
    """Settings of the grey-box fit; L, F are the plant's known stroke and saturation."""

    stroke: float = 5.0
    """Stroke L, m (known: the stops are part of the rig, not estimated)."""
    force: float = 10.0
    """Force saturation F, N (known: the actuator's limit)."""
    max_nfev: int = 60
    """Maximum residual evaluations of the simulation-error refinement."""
    filter_hz: float = 4.0
    """Cut-off of the zero-phase low-pass applied before the equation-error start, Hz."""
    g_range: tuple[float, float] = (0.05, 5.0)
    """Search interval of the spring's spatial frequency g in the start, rad/m."""
    scales: Scales = Scales.DEFAULT
    """The rig's scales (:meth:`scaled` sets them): the refinement works in the paper's units, every
    parameter and residual divided by its unit, so its steps and tolerances are the paper's."""

    def __post_init__(self) -> None:
        for name in ("stroke", "force", "filter_hz"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ConfigError(f"grey-box {name} must be finite and > 0, got {value}")
        if self.max_nfev < 1:
            raise ConfigError(f"grey-box max_nfev must be >= 1, got {self.max_nfev}")
        lo, hi = self.g_range
        if not (0 < lo < hi and np.isfinite(hi)):
            raise ConfigError(f"grey-box g_range must satisfy 0 < low < high, got {self.g_range}")

    def scaled(self, scales: Scales) -> GreyboxConfig:
        """This fit, stated on the paper's plant, on a rig of ``scales`` (docs/decisions.md §Scales): the
        filter's cut-off in the rig's time unit, g's search range per rig metre, the refinement in paper
        units. Itself on the paper's plant."""
        if scales.is_default:
            return self
        lo, hi = self.g_range
        return replace(self, filter_hz=self.filter_hz / scales.pace,
                       g_range=(lo / scales.length, hi / scales.length), scales=scales)

    def units(self) -> FloatArray:
        """The unit of each of (m, c, k, g, h) on the rig: what a paper value is multiplied by."""
        return param_units(self.scales)


def param_units(scales: Scales) -> FloatArray:
    """The unit of each of (m, c, k, g, h) on a rig of ``scales``: the similarity transform of
    docs/decisions.md §Scales (all 1.0 on the paper's plant)."""
    ln, f, t = scales.length, scales.force, scales.pace
    return np.array([f * t * t / ln, f * t / ln, f, 1.0 / ln, f / (ln * ln * ln)])


@dataclass(frozen=True)
class GreyboxFit:
    """Fitted parameters and the facts worth reporting."""

    params: PlantParams
    """The fitted plant (known L, F, dt; fitted m, c, k, g, h)."""
    start: tuple[float, ...]
    """Equation-error estimate of (m, c, k, g, h) the refinement started from."""
    initial_states: tuple[tuple[float, float], ...]
    """Estimated (x0, v0) of every training experiment."""
    cost: float
    """Final simulation-error cost ``0.5 Σ r²`` (m²)."""
    rms: float
    """Root-mean-square free-run error on the training record, m."""
    nfev: int
    """Residual evaluations the refinement used."""


def fit_greybox(experiments: Sequence[Experiment], dt: float, cfg: GreyboxConfig) -> GreyboxFit:
    """Equation-error start, then simulation-error least squares (see the module docstring)."""
    if not experiments:
        raise IdentificationError("grey-box fit needs at least one experiment")
    start = equation_error_start(experiments, dt, cfg)
    x_inits = [_initial_guess(e, dt, cfg) for e in experiments]
    units, sc = cfg.units(), cfg.scales  # the refinement in paper units: each value / its unit
    lu, vu = sc.length, sc.speed(1.0)
    paper_start = start / units
    state_units = np.tile([lu, vu], len(experiments))
    theta0 = np.concatenate([np.log(paper_start), np.ravel(x_inits) / state_units])
    n_samples = sum(len(e) for e in experiments)

    def residuals(theta: FloatArray) -> FloatArray:
        p = _plant_array(np.exp(theta[:5]) * units, dt, cfg)
        parts = []
        for i, e in enumerate(experiments):
            x0, v0 = theta[5 + 2 * i] * lu, theta[6 + 2 * i] * vu
            x, _ = kernels.simulate_plant(kernels.Plant(*(float(v) for v in p)), e.u, float(x0), float(v0))
            parts.append((x - e.y) / lu)
        return np.concatenate(parts)

    sol = least_squares(residuals, theta0, method="trf", x_scale="jac", max_nfev=cfg.max_nfev)
    if not _plausible(sol.x[:5], paper_start):  # a record that does not pin a parameter down (friction)
        lo, hi = _log_bounds(theta0, paper_start, cfg.g_range[0] / units[3], cfg.g_range[1] / units[3])
        sol = least_squares(residuals, theta0, method="trf", x_scale="jac", max_nfev=cfg.max_nfev,
                            bounds=(lo, hi))
    theta = sol.x
    if not np.all(np.isfinite(theta)):
        raise IdentificationError("grey-box refinement diverged (non-finite parameters)")
    m, c, k, g, h = (float(v) for v in np.exp(theta[:5]) * units)
    params = PlantParams(m=m, c=c, k=k, g=g, h=h, L=cfg.stroke, F=cfg.force, dt=dt)
    states = tuple((float(theta[5 + 2 * i] * lu), float(theta[6 + 2 * i] * vu))
                   for i in range(len(experiments)))
    cost = float(sol.cost) * lu * lu
    rms = float(np.sqrt(2.0 * cost / n_samples))
    return GreyboxFit(params, tuple(float(v) for v in start), states, cost, rms, int(sol.nfev))


RETRY_SPAN = 1e3
"""An unbounded refinement that moves a parameter more than this factor from its equation-error start
has run off along a direction the record does not determine (a rig's Coulomb friction made the
spring run to 1e54 on one held-out rig): it is refined again inside :data:`BOUND_SPAN`."""
BOUND_SPAN = 1e2
"""The bounded retry keeps every parameter within this factor of its start (and g in ``g_range``)."""


def _plausible(log_params: FloatArray, start: FloatArray) -> bool:
    """True when every refined parameter is finite and within :data:`RETRY_SPAN` of its start."""
    if not np.all(np.isfinite(log_params)):
        return False
    return bool(np.all(np.abs(log_params - np.log(start)) <= np.log(RETRY_SPAN)))


def _log_bounds(theta0: FloatArray, start: FloatArray, g_low: float,
                g_high: float) -> tuple[FloatArray, FloatArray]:
    """Bounds of the retry: parameters within :data:`BOUND_SPAN` of the start (g also within
    ``g_low``-``g_high``, the config's ``g_range`` in the units of ``start``, widened to hold the start),
    initial states free."""
    lo = np.full(theta0.size, -np.inf)
    hi = np.full(theta0.size, np.inf)
    lo[:5], hi[:5] = np.log(start) - np.log(BOUND_SPAN), np.log(start) + np.log(BOUND_SPAN)
    g_lo, g_hi = np.log(min(g_low, start[3])), np.log(max(g_high, start[3]))
    lo[3], hi[3] = max(lo[3], g_lo), min(hi[3], g_hi)
    return lo, hi


def equation_error_start(experiments: Sequence[Experiment], dt: float, cfg: GreyboxConfig) -> FloatArray:
    """``(m, c, k, g, h)`` from the filtered equation error, g by variable projection."""
    x, v, a, u = _regression_data(experiments, dt, cfg)
    if x.size < 10:
        raise IdentificationError("grey-box record spends almost all its time at the hard stops")

    def solve(g: float) -> tuple[float, FloatArray]:
        phi = np.column_stack([a, v, np.sin(g * x), x**3])
        scale = np.linalg.norm(phi, axis=0)
        if np.any(scale == 0.0):
            raise IdentificationError("grey-box record has no excitation: position or force is constant")
        theta, *_ = np.linalg.lstsq(phi / scale, u, rcond=None)
        theta = theta / scale
        return float(np.sum((phi @ theta - u) ** 2)), theta

    units = cfg.units()  # the grid in paper 1/m, then in the rig's: the same points on every rig
    lo, hi = cfg.g_range
    grid = np.geomspace(lo / units[3], hi / units[3], 60) * units[3]
    costs = [solve(float(g))[0] for g in grid]
    i = int(np.argmin(costs))
    bracket = (float(grid[max(i - 1, 0)]), float(grid[min(i + 1, grid.size - 1)]))
    best = minimize_scalar(lambda g: solve(g)[0], bounds=bracket, method="bounded",
                           options={"xatol": 1e-10 * units[3]})
    g = float(best.x)
    m, c, k, h = solve(g)[1]
    start = np.array([m, c, k, g, h])
    # A non-positive estimate has no log: start it at a small positive value instead
    # (the refinement moves it; a physical plant has every parameter > 0).
    return np.where(start > 0, start, 1e-3 * units)


def _regression_data(
    experiments: Sequence[Experiment], dt: float, cfg: GreyboxConfig
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Filtered ``(x_k, v_k, a_k, u_k)`` over samples whose neighbourhood is clear of the stops."""
    xs, vs, acc, us = [], [], [], []
    for e in experiments:
        y, u = lowpass(e.y, dt, cfg.filter_hz), lowpass(e.u, dt, cfg.filter_hz)
        free = clear_of_stops(e.y, cfg.stroke, lowpass_reach(dt, cfg.filter_hz))
        keep = free[2:] & free[1:-1] & free[:-2]
        xs.append(y[1:-1][keep])
        vs.append(((y[1:-1] - y[:-2]) / dt)[keep])
        acc.append(((y[2:] - 2 * y[1:-1] + y[:-2]) / dt**2)[keep])
        us.append(u[1:-1][keep])
    return np.concatenate(xs), np.concatenate(vs), np.concatenate(acc), np.concatenate(us)


def _initial_guess(e: Experiment, dt: float, cfg: GreyboxConfig) -> tuple[float, float]:
    """(x0, v0) from the filtered first samples (raw ones carry the sensor noise)."""
    y = lowpass(e.y, dt, cfg.filter_hz)
    return float(y[0]), float((y[1] - y[0]) / dt)


def _plant_array(phys: FloatArray, dt: float, cfg: GreyboxConfig) -> FloatArray:
    m, c, k, g, h = (float(v) for v in phys)
    return np.array([m, c, k, g, h, cfg.stroke, cfg.force, dt])


def one_step(params: FloatArray, y: FloatArray, u: FloatArray) -> FloatArray:
    """One-step-ahead prediction of a plant-structure model from measured positions.

    The state the model needs, ``(x_{k-1}, v_{k-1})``, is taken as the measured
    position and the backward-difference velocity ``(y[k-1] - y[k-2]) / dt``:
    with Euler steps that is exactly the plant's velocity on noise-free data
    away from the stops. ``yhat[:2] = y[:2]`` like the ARX-type predictors.
    """
    dt = float(params[7])
    yhat = np.array(y, dtype=float)
    s = np.zeros(4)
    for k in range(2, y.size):
        s[0] = y[k - 1]
        s[1] = (y[k - 1] - y[k - 2]) / dt
        yhat[k] = kernels.advance(kernels.Kernel(kernels.KIND_PLANT, params, float(params[6])), s,
                                  float(u[k - 1]))
    return yhat
