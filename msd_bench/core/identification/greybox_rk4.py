"""Grey-box for real rigs: a Duffing-type mass-spring-damper integrated by RK4 (kernel ``rk4``).

Why a kind of its own: the plant's kernel (one semi-implicit Euler step per
sample, every parameter log-positive) is the bench's emulated plant and its
pinned results; a real rig needs an integrator accurate at ``omega dt ~ 0.7``
(the Silverbox resonates at 69 Hz sampled at 610 Hz), springs and offsets of
either sign, and the input between samples as the rig saw it. The model is

``m x'' = f(t) - c x' - k1 x - k2 x² - k3 x³ - ks sin(gs x) - fc tanh(x'/vc) + f0``

stepped by :func:`msd_bench.core.physics.kernels.rk4_advance`, which the
Q-learners train on like any kernel. Two input structures are compared by fit
on the training record and the winner is recorded (``info["structure"]``):

* ``hold``: the command acts held over the sample (a ZOH actuator, the
  bench's own drive): ``x[k+1]`` from ``u[k]``.
* ``ramp``: the record samples a continuous force (a band-limited generator):
  between samples k and k+1 the force ramps from ``u[k]`` to ``u[k+1]``, so
  ``x[k+1] = x(t_{k+1})`` depends on ``u[k+1]`` (no anticipation: it is the
  force's value at that instant). The kernel steps it causally with the
  ramp's start in its state; on a record the input is fed one sample on
  (``info["input_lead"] = 1``, :func:`fed_input`).

Method (``nlgreyest`` for an ``idnlgrey`` model, :class:`ParamSpec` per
parameter: value, bounds, fixed):

1. **Linear start.** A second-order ARX fit by least squares; its poles and
   static gain give mass, damping and stiffness (``k = m s1 s2``, ``c = -m
   (s1 + s2)``, ``m = 1 / (K s1 s2)``); nonlinear terms, friction and offset
   start at 0. Parameters are not log-transformed, so a spring, damping
   or offset may be zero or negative; bounds are applied as box constraints.
2. **Several starts** around it (mass and stiffness scaled), each refined by
   bounded least squares on the free-run simulation error (``trf``), the
   initial position and velocity of every experiment alongside. A
   simulation that goes non-finite returns NaN residuals: the trust-region
   step is rejected and shrunk (never scored as a number).
3. The cheapest fit over starts and structures wins; its parameter
   covariance ``s² (JᵀJ)⁻¹`` at the optimum is stored (it assumes white
   residuals, as MATLAB's ``getcov`` says of its own).

A springless stage (mass, viscous and Coulomb friction, offset) is the same
family with the springs fixed at 0 (:func:`springless`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel

FloatArray = NDArray[np.float64]

PARAM_NAMES = ("m", "c", "k1", "k2", "k3", "ks", "gs", "fc", "f0")
"""The physical parameters, in the order the fit and the model file list them."""
SLOTS = {"m": 0, "c": 1, "k1": 2, "k2": 3, "k3": 4, "ks": 8, "gs": 9, "fc": 10, "f0": 12}
"""Each parameter's slot in the kernel's layout (:mod:`msd_bench.core.physics.kernels`)."""
STRUCTURES = {"hold": (0, 0), "ramp": (1, 1)}
"""Input structure -> (kernel ``interp`` flag, input lead in samples on a record)."""


@dataclass(frozen=True)
class ParamSpec:
    """One parameter's ``idnlgrey`` settings: its range, whether it is estimated, its value."""

    minimum: float = -math.inf
    """Smallest value the fit may give it (``Minimum``)."""
    maximum: float = math.inf
    """Largest value (``Maximum``)."""
    fixed: bool = False
    """Held at ``value`` instead of estimated (``Fixed``)."""
    value: float | None = None
    """The held value (fixed) or a start overriding the linear fit's (free); None = the fitter's."""


def _default_specs() -> dict[str, ParamSpec]:
    return {
        "m": ParamSpec(0.0, math.inf), "c": ParamSpec(), "k1": ParamSpec(), "k2": ParamSpec(),
        "k3": ParamSpec(), "ks": ParamSpec(fixed=True, value=0.0), "gs": ParamSpec(0.0, math.inf,
                                                                                   fixed=True, value=0.0),
        "fc": ParamSpec(0.0, math.inf, fixed=True, value=0.0), "f0": ParamSpec(),
    }


@dataclass(frozen=True)
class Rk4Config:
    """Settings of the rk4 grey-box fit; L and F are known (they only clip)."""

    stroke: float = 5.0
    """Stroke L (record units): the model's output is projected on ±L/2."""
    force: float = 10.0
    """Force saturation F (record units)."""
    params: dict[str, ParamSpec] = field(default_factory=_default_specs)
    """Bounds, fixed flags and values of :data:`PARAM_NAMES` (defaults: Duffing with offset)."""
    structures: tuple[str, ...] = ("hold", "ramp")
    """Input structures compared by training cost (:data:`STRUCTURES`)."""
    substeps: int = 1
    """RK4 substeps per sample."""
    starts: tuple[float, ...] = (1.0, 0.8, 1.25)
    """Multipliers of the linear start's mass and stiffness: one refinement each."""
    max_nfev: int = 60
    """Residual evaluations per refinement (the Jacobian's columns not counted)."""

    def __post_init__(self) -> None:
        unknown = sorted(set(self.params) - set(PARAM_NAMES))
        if unknown:
            raise ConfigError(f"greybox-rk4: unknown parameter(s) {unknown}; known: {', '.join(PARAM_NAMES)}")
        for name, spec in self.params.items():
            _check_spec(name, spec)
        bad = [s for s in self.structures if s not in STRUCTURES]
        if bad or not self.structures:
            raise ConfigError(f"greybox-rk4: structures must be some of {', '.join(STRUCTURES)}, "
                              f"got {list(self.structures)}")
        if not (isinstance(self.substeps, int) and 1 <= self.substeps <= kernels.RK4_SUBSTEPS_MAX):
            raise ConfigError(f"greybox-rk4: substeps must be an integer in [1, {kernels.RK4_SUBSTEPS_MAX}], "
                              f"got {self.substeps!r}")
        if not self.starts or not all(math.isfinite(s) and s > 0 for s in self.starts):
            raise ConfigError(f"greybox-rk4: starts must be positive multipliers, got {list(self.starts)}")
        for name in ("stroke", "force"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"greybox-rk4: {name} must be finite and > 0, got {value}")

    def spec(self, name: str) -> ParamSpec:
        """The settings of ``name`` (the default for a parameter the config does not list)."""
        return self.params.get(name, _default_specs()[name])


def springless(cfg: Rk4Config | None = None, coulomb: bool = True) -> Rk4Config:
    """``cfg`` with every spring fixed at 0: a stage of mass, viscous (and Coulomb) friction, offset."""
    base = cfg or Rk4Config()
    zero = ParamSpec(fixed=True, value=0.0)
    specs = {**base.params, "k1": zero, "k2": zero, "k3": zero, "ks": zero}
    if coulomb:
        specs["fc"] = ParamSpec(0.0, math.inf)
    return replace(base, params=specs)


def _check_spec(name: str, s: ParamSpec) -> None:
    """One-line ConfigError for inverted bounds, a fixed parameter without value, a value outside."""
    if math.isnan(s.minimum) or math.isnan(s.maximum) or s.minimum > s.maximum:
        raise ConfigError(f"greybox-rk4: {name} bounds are invalid: [{s.minimum}, {s.maximum}]")
    if name in ("m", "gs", "fc") and s.minimum < 0:
        raise ConfigError(f"greybox-rk4: {name} minimum must be >= 0, got {s.minimum}")
    if s.fixed and s.value is None:
        raise ConfigError(f"greybox-rk4: {name} is fixed but has no value")
    if s.value is not None and not (math.isfinite(s.value) and s.minimum <= s.value <= s.maximum):
        raise ConfigError(f"greybox-rk4: {name} value {s.value} is outside its bounds "
                          f"[{s.minimum}, {s.maximum}]")
    if name == "m" and s.fixed and not (s.value is not None and s.value > 0):
        raise ConfigError(f"greybox-rk4: a fixed mass must be > 0, got {s.value}")


@dataclass(frozen=True)
class LinearStart:
    """Mass, damping and stiffness from a second-order ARX fit (the fit's start)."""

    m: float
    c: float
    k: float
    wn: float
    """Undamped natural frequency, rad/s (the scale of the velocity)."""


def linear_start(train: IOData) -> LinearStart:
    """``(m, c, k)`` from the poles and static gain of a least-squares ARX(2, 2) on ``train``."""
    rows, rhs = [], []
    for e in train.experiments:
        rows.append(np.column_stack([-e.y[1:-1], -e.y[:-2], e.u[1:-1], e.u[:-2]]))
        rhs.append(e.y[2:])
    a1, a2, b1, b2 = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    poles = np.log(np.roots([1.0, a1, a2]).astype(complex)) / train.dt
    prod, total = float((poles[0] * poles[1]).real), float((poles[0] + poles[1]).real)
    gain_num, gain_den = float(b1 + b2), float(1.0 + a1 + a2)
    if gain_num == 0.0:
        raise IdentificationError("greybox-rk4: the record shows no response to the input")
    m = gain_den / (gain_num * prod) if abs(prod) * train.dt**2 > 1e-6 else train.dt**2 / gain_num
    m = abs(m) if math.isfinite(m) and m != 0.0 else train.dt**2 / abs(gain_num)
    wn = math.sqrt(abs(prod)) if abs(prod) > 0 else 1.0 / train.dt
    return LinearStart(m=m, c=-m * total, k=m * prod, wn=max(wn, 1e-3 / train.dt))


def fed_input(u: FloatArray, lead: int) -> FloatArray:
    """The commands as the kernel takes them on a record: ``u`` advanced by ``lead`` samples
    (the last repeated), so step k ramps the force from ``u[k]`` to ``u[k+1]`` when lead is 1."""
    if lead == 0:
        return u
    return np.concatenate([u[lead:], np.repeat(u[-1:], lead)])


@dataclass(frozen=True)
class _Problem:
    """What a refinement needs: the record, the structure, which parameters are free, their scales."""

    train: IOData
    cfg: Rk4Config
    structure: str
    free: tuple[str, ...]
    scale: FloatArray
    """Per free number (parameters, then x0, v0 per experiment): its unit in the normalised fit."""
    base: FloatArray
    """The kernel vector with fixed parameters in place (free slots overwritten per evaluation)."""

    def params(self, theta: FloatArray) -> FloatArray:
        p = self.base.copy()
        for i, name in enumerate(self.free):
            p[SLOTS[name]] = theta[i] * self.scale[i]
        return p

    def simulate(self, theta: FloatArray) -> list[FloatArray]:
        p = self.params(theta)
        lead = STRUCTURES[self.structure][1]
        out, at = [], len(self.free)
        for e in self.train.experiments:
            x0, v0 = theta[at] * self.scale[at], theta[at + 1] * self.scale[at + 1]
            fed = np.clip(fed_input(e.u, lead), -self.cfg.force, self.cfg.force)
            # x[0] = x0; step k under fed[k], ramping from fed[k-1] (ramp) - from u[0] at the first
            first = float(np.clip(e.u[0], -self.cfg.force, self.cfg.force))
            out.append(kernels.rk4_simulate(p, fed, x0, v0, first))
            at += 2
        return out

    def residuals(self, theta: FloatArray) -> FloatArray:
        return np.concatenate([x - e.y for x, e in zip(self.simulate(theta), self.train.experiments,
                                                          strict=True)])


def _kernel_base(cfg: Rk4Config, dt: float, structure: str, vc: float) -> FloatArray:
    p = np.zeros(kernels.RK4_SIZE)
    p[5], p[6], p[7], p[11] = cfg.stroke, cfg.force, dt, vc
    p[13], p[14] = cfg.substeps, STRUCTURES[structure][0]
    for name in PARAM_NAMES:
        spec = cfg.spec(name)
        if spec.fixed:
            p[SLOTS[name]] = float(spec.value if spec.value is not None else 0.0)
    p[0] = p[0] if p[0] > 0 else 1.0  # a free mass is overwritten before any evaluation
    return p


def _scales(lin: LinearStart, ystd: float) -> dict[str, float]:
    """Each parameter's natural unit: what its term contributes at one standard deviation of y."""
    k = max(abs(lin.k), lin.m * lin.wn**2, 1e-300)
    return {"m": lin.m, "c": max(abs(lin.c), 1e-3 * lin.m * lin.wn), "k1": k, "k2": k / ystd,
            "k3": k / ystd**2, "ks": k * ystd, "gs": 1.0 / ystd, "fc": k * ystd, "f0": k * ystd}


@dataclass(frozen=True)
class _Fit:
    structure: str
    theta: FloatArray
    cost: float
    nfev: int
    jac: FloatArray
    problem: _Problem


def identify_greybox_rk4(train: IOData, cfg: Rk4Config | None = None) -> StepModel:
    """The rk4 grey-box of ``train``; see the module docstring."""
    cfg = cfg or Rk4Config()
    t0 = time.perf_counter()
    lin = linear_start(train)
    ystd = max(float(np.std(np.concatenate([e.y for e in train.experiments]))), 1e-12)
    fits = [_refine(train, cfg, lin, ystd, structure, mult)
            for structure in cfg.structures for mult in cfg.starts]
    good = [f for f in fits if math.isfinite(f.cost)]
    if not good:
        raise IdentificationError("greybox-rk4: every start diverged (non-finite simulation)")
    best = min(good, key=lambda f: f.cost)
    p = best.problem.params(best.theta)
    info = _info(train, cfg, lin, best, fits)
    info["fit_seconds"] = time.perf_counter() - t0
    return StepModel(kernels.KIND_RK4, p, name="greybox-rk4", info=info, dt=train.dt, force_limit=cfg.force)


def _refine(train: IOData, cfg: Rk4Config, lin: LinearStart, ystd: float, structure: str,
            mult: float) -> _Fit:
    """One start's bounded simulation-error least squares in normalised coordinates."""
    free = tuple(n for n in PARAM_NAMES if not cfg.spec(n).fixed)
    units = _scales(lin, ystd)
    start = {"m": lin.m * mult, "c": lin.c, "k1": lin.k * mult}
    theta0, lo, hi, scale = [], [], [], []
    for name in free:
        spec = cfg.spec(name)
        value = spec.value if spec.value is not None else start.get(name, 0.0)
        value = min(max(value, spec.minimum), spec.maximum)
        scale.append(units[name])
        theta0.append(value / units[name])
        lo.append(spec.minimum / units[name])
        hi.append(spec.maximum / units[name])
    vel = ystd * lin.wn
    for e in train.experiments:
        scale += [ystd, vel]
        theta0 += [e.y[0] / ystd, (e.y[1] - e.y[0]) / train.dt / vel]
        lo += [-np.inf, -np.inf]
        hi += [np.inf, np.inf]
    if "m" in free:  # the mass divides: keep it off zero
        lo[free.index("m")] = max(lo[free.index("m")], 1e-6 * lin.m / units["m"])
    vc = 1e-2 * vel
    problem = _Problem(train, cfg, structure, free, np.array(scale),
                       _kernel_base(cfg, train.dt, structure, vc))
    th0 = np.clip(np.array(theta0), np.array(lo), np.array(hi))
    r0 = problem.residuals(th0)
    if not np.all(np.isfinite(r0)):
        return _Fit(structure, th0, math.inf, 1, np.zeros((0, th0.size)), problem)
    sol = least_squares(problem.residuals, th0, jac=_jacobian(problem), bounds=(np.array(lo), np.array(hi)),
                        method="trf", x_scale="jac", max_nfev=cfg.max_nfev)
    return _Fit(structure, sol.x, float(sol.cost), int(sol.nfev), sol.jac, problem)


def _jacobian(problem: _Problem) -> Any:
    """Forward differences in normalised coordinates; a column whose step goes non-finite is 0
    (that direction is not taken rather than poisoning the step)."""

    def jac(theta: FloatArray) -> FloatArray:
        r = problem.residuals(theta)
        out = np.empty((r.size, theta.size))
        for j in range(theta.size):
            h = 1e-6 * max(abs(theta[j]), 1.0)
            t = theta.copy()
            t[j] += h
            col = (problem.residuals(t) - r) / h
            out[:, j] = col if np.all(np.isfinite(col)) else 0.0
        return out

    return jac


def _info(train: IOData, cfg: Rk4Config, lin: LinearStart, best: _Fit,
          fits: Sequence[_Fit]) -> dict[str, Any]:
    """The model file's record: parameters, structure, starts, costs and the covariance."""
    p = best.problem.params(best.theta)
    n = train.n_samples
    cov = covariance(best, n)
    free = best.problem.free
    stderr = {name: float(math.sqrt(max(cov[i, i], 0.0))) if cov.size else math.nan
              for i, name in enumerate(free)}
    return {
        "parameters": {name: float(p[SLOTS[name]]) for name in PARAM_NAMES},
        "structure": best.structure,
        "interp": int(STRUCTURES[best.structure][0]),
        "input_lead": int(STRUCTURES[best.structure][1]),
        "integrator": f"RK4, {cfg.substeps} substep(s) per sample",
        "coulomb_smoothing": float(p[11]),
        "fixed": [name for name in PARAM_NAMES if cfg.spec(name).fixed],
        "free": list(free),
        "bounds": {name: [cfg.spec(name).minimum, cfg.spec(name).maximum] for name in PARAM_NAMES},
        "linear_start": {"m": lin.m, "c": lin.c, "k": lin.k, "f_n_hz": lin.wn / (2 * math.pi)},
        "starts": list(cfg.starts),
        "costs": {f"{f.structure}@{cfg.starts[i % len(cfg.starts)]:g}": f.cost for i, f in enumerate(fits)},
        "cost": best.cost,
        "train_rms": float(math.sqrt(2.0 * best.cost / n)),
        "nfev": sum(f.nfev for f in fits),
        "covariance": cov.tolist(),
        "stderr": stderr,
        "covariance_note": "s^2 (J'J)^-1 at the optimum: assumes white residuals (as getcov)",
        "method": "simulation-error least squares (trf, bounds) from the linear fit, several starts",
        "known": {"L": cfg.stroke, "F": cfg.force, "dt": train.dt},
        "n_samples": n,
        "dt": train.dt,
    }


def covariance(fit: _Fit, n: int) -> FloatArray:
    """Covariance of the free physical parameters: ``s² (JᵀJ)⁻¹`` with ``s² = 2 cost / (n - p)``.

    The Jacobian is the fit's (normalised coordinates, initial states included), mapped back to
    physical units; the initial states' block is dropped. White residuals are assumed.
    """
    jac = fit.jac
    if jac.size == 0:
        return np.zeros((0, 0))
    dof = max(n - jac.shape[1], 1)
    s2 = 2.0 * fit.cost / dof
    info = jac.T @ jac
    cov = s2 * np.linalg.pinv(info)
    scale = fit.problem.scale
    cov = cov * np.outer(scale, scale)
    k = len(fit.problem.free)
    out: FloatArray = cov[:k, :k]
    return out


def one_step(model: StepModel, exp: Experiment) -> FloatArray:
    """One-step-ahead prediction of an rk4 model: ``yhat[k]`` from the measured ``y[k-1]``, the
    backward-difference velocity and the commands (fed with the model's lead); ``yhat[:2] = y[:2]``."""
    lead = int(model.info.get("input_lead", 0))
    u = np.clip(fed_input(exp.u, lead), -model.force_limit, model.force_limit)
    y = exp.y
    yhat = y.copy()
    s = np.zeros(kernels.ARX_STATE_SIZE)
    for k in range(2, y.size):
        s[0], s[1] = y[k - 1], (y[k - 1] - y[k - 2]) / model.dt
        s[2] = u[k - 2]
        yhat[k] = kernels.advance(model.kernel, s, float(u[k - 1]))
    return yhat
