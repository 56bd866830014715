"""The checks a control engineer runs before trusting a model: ``compare``, ``resid``, ``simsd``.

As MATLAB's: :func:`compare` simulates each model in free run against a record (the fit in
percent and the RMSE in the record's units) and, for a model with a predictor, its k-step-ahead
prediction; :func:`resid` tests the residuals for whiteness and for independence of the input
with 99 % bands; :func:`sim_band` draws parameter sets from a grey-box model's stored covariance
and simulates each (the simulation's spread that the parameter uncertainty explains).

Which residuals :func:`resid` tests: an ARX-type model's one-step prediction errors (its
predictor is its definition), a plant-structure model's simulation errors (output-error
models: their predictor *is* the simulation, and MATLAB's ``resid`` says the same of an OE
model). The bands assume white residuals of a record long beside the lags (``±z/√N``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.identification import identify
from msd_bench.core.identification.data import Experiment
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import PLANT_LIKE, StepModel

FloatArray = NDArray[np.float64]

Z99 = 2.5758
"""Two-sided 99 % point of the standard normal: the bands of :func:`resid`."""


def output_error(model: StepModel) -> bool:
    """Whether the model's predictor is its simulation (plant-structure kinds: no ARX history)."""
    return model.kind in PLANT_LIKE


@dataclass(frozen=True)
class Comparison:
    """One model against one record."""

    model: str
    sim: FloatArray
    """Free-run simulation (initial state estimated over ``window`` samples)."""
    fit: float
    """Normalised-RMSE fit, % (MATLAB ``compare``'s), after the window."""
    rmse: float
    """RMSE after the window, in the record's units."""
    predicted: FloatArray | None
    """The k-step-ahead prediction (None: the model is output-error, where it equals ``sim``)."""
    predicted_fit: float | None
    """Its fit, %."""
    note: str
    """What the prediction column means for this model."""


def k_step(model: StepModel, exp: Experiment, k: int) -> FloatArray:
    """``yhat[t]`` from the measured history up to ``t-k`` and the inputs, for an ARX-type model.

    ``k = 1`` is the one-step predictor; the first ``k + 1`` samples are copied from the record.
    """
    if output_error(model):
        raise InvalidInputError(f"model {model.name!r} is output-error: its k-step prediction is its "
                                "simulation")
    if k < 1:
        raise InvalidInputError(f"prediction horizon k must be >= 1, got {k}")
    y, u = exp.y, exp.u
    yhat = y.copy()
    s = np.zeros(kernels.ARX_STATE_SIZE)
    for t in range(k + 1, y.size):
        start = t - k  # measured state at ``start``, then the k inputs u[start..t-1]
        s[0], s[1], s[2] = y[start], y[start - 1], u[start - 1]
        x = 0.0
        for j in range(start, t):
            x = kernels.advance(model.kernel, s, float(u[j]))
        yhat[t] = x
    return yhat


def compare(model: StepModel, exp: Experiment, window: int = identify.INIT_HORIZON, k: int = 1) -> Comparison:
    """Free run (and the k-step prediction where the model has a predictor) of ``model`` on ``exp``."""
    if not (isinstance(window, int) and 2 <= window < len(exp) - 2):
        raise InvalidInputError(f"initial-state window must be an integer in [2, {len(exp) - 3}], "
                                f"got {window!r}")
    sim = identify.free_run(model, exp, "estimate", horizon=window)
    y = exp.y[window:]
    rmse = float(np.sqrt(np.mean((sim[window:] - y) ** 2)))
    if output_error(model):
        return Comparison(model.name, sim, fit_percent(y, sim[window:]), rmse, None, None,
                          "output-error model: its k-step prediction equals its simulation")
    pred = k_step(model, exp, k)
    return Comparison(model.name, sim, fit_percent(y, sim[window:]), rmse, pred,
                      fit_percent(y, pred[window:]), f"{k}-step-ahead prediction from the measured history")


@dataclass(frozen=True)
class Residuals:
    """MATLAB ``resid``'s two tests on one model and record."""

    model: str
    source: str
    """``"simulation"`` (output-error model) or ``"one-step prediction"``."""
    lags: int
    auto: FloatArray
    """Normalised autocorrelation of the residuals at lags 1..lags."""
    cross: FloatArray
    """Normalised cross-correlation residual-input at lags -lags..lags (input leading for > 0)."""
    band: float
    """The 99 % band ``Z99/√N``."""
    whiteness_pass: bool
    """Every autocorrelation inside the band."""
    independence_pass: bool
    """Every cross-correlation inside the band."""

    def lines(self) -> list[str]:
        """One pass/fail line per test, as ``resid`` reads them."""
        out_auto = int(np.sum(np.abs(self.auto) > self.band))
        out_cross = int(np.sum(np.abs(self.cross) > self.band))
        return [
            f"{self.model}: whiteness of the {self.source} residuals, lags 1..{self.lags}: "
            f"{'pass' if self.whiteness_pass else 'FAIL'} ({out_auto} of {self.auto.size} outside "
            f"±{self.band:.4f})",
            f"{self.model}: residuals independent of the input, lags -{self.lags}..{self.lags}: "
            f"{'pass' if self.independence_pass else 'FAIL'} ({out_cross} of {self.cross.size} outside "
            f"±{self.band:.4f})",
        ]


def _xcorr(a: FloatArray, b: FloatArray, lag: int) -> float:
    """``Σ a[t] b[t-lag] / N`` (b leading a by ``lag`` when positive)."""
    n = a.size
    if lag >= 0:
        return float(a[lag:] @ b[:n - lag]) / n
    return float(a[:n + lag] @ b[-lag:]) / n


def resid(model: StepModel, exp: Experiment, lags: int = 25,
          window: int = identify.INIT_HORIZON) -> Residuals:
    """Residual whiteness and input independence with 99 % bands (samples after ``window``)."""
    if not (isinstance(lags, int) and 1 <= lags < (len(exp) - window) // 4):
        raise InvalidInputError(f"lags must be an integer in [1, {(len(exp) - window) // 4 - 1}] for this "
                                f"record, got {lags!r}")
    if output_error(model):
        yhat, source = identify.free_run(model, exp, "estimate", horizon=window), "simulation"
    else:
        yhat, source = identify.one_step(model, exp), "one-step prediction"
    e = exp.y[window:] - yhat[window:]
    u = exp.u[window:] - np.mean(exp.u[window:])
    e = e - np.mean(e)
    e0, u0 = _xcorr(e, e, 0), _xcorr(u, u, 0)
    if e0 <= 0 or u0 <= 0:
        raise InvalidInputError("resid: residuals or input are constant over the record")
    auto = np.array([_xcorr(e, e, k) / e0 for k in range(1, lags + 1)])
    cross = np.array([_xcorr(e, u, k) / math.sqrt(e0 * u0) for k in range(-lags, lags + 1)])
    band = Z99 / math.sqrt(e.size)
    return Residuals(model.name, source, lags, auto, cross, band, bool(np.all(np.abs(auto) <= band)),
                     bool(np.all(np.abs(cross) <= band)))


def parameter_lines(model: StepModel) -> list[str]:
    """Each estimated parameter with its standard error and 95 % interval (``±1.96`` standard
    errors), for a model that stores them (the rk4 grey-box); none otherwise."""
    stderr = model.info.get("stderr", {})
    values = model.info.get("parameters", {})
    if not isinstance(stderr, dict) or not isinstance(values, dict):
        return []
    out = []
    for name, se in stderr.items():
        v = float(values[name])
        out.append(f"  {name} = {v:.6g} ± {float(se):.2g} (95 %: [{v - 1.96 * se:.6g}, {v + 1.96 * se:.6g}])")
    if out:
        out.append("  (standard errors from s² (JᵀJ)⁻¹ at the optimum: they assume white residuals)")
    return out


def sim_band(model: StepModel, exp: Experiment, draws: int = 50, seed: int = 0,
             window: int = identify.INIT_HORIZON) -> tuple[FloatArray, FloatArray]:
    """The 2.5 % and 97.5 % points of the free run over ``draws`` parameter sets from the model's
    stored covariance (``info["covariance"]`` over ``info["free"]``: the rk4 grey-box's)."""
    cov = np.asarray(model.info.get("covariance", []), dtype=float)
    free = list(model.info.get("free", []))
    if cov.ndim != 2 or cov.shape != (len(free), len(free)) or not free:
        raise InvalidInputError(f"model {model.name!r} stores no parameter covariance (only the grey-box "
                                "for real rigs does)")
    from msd_bench.core.identification.greybox_rk4 import SLOTS

    rng = np.random.default_rng(seed)
    centre = np.array([model.params[SLOTS[n]] for n in free])
    runs = []
    for draw in rng.multivariate_normal(centre, cov, size=draws, method="eigh"):
        p = model.params.copy()
        for name, value in zip(free, draw, strict=True):
            p[SLOTS[name]] = value
        if p[0] <= 0:
            continue
        try:
            m = StepModel(model.kind, p, model.name, dict(model.info), model.dt, model.force_limit)
            runs.append(identify.free_run(m, exp, "estimate", horizon=window))
        except InvalidInputError:
            continue
    if not runs:
        raise InvalidInputError(f"model {model.name!r}: no parameter draw simulated finitely")
    stack = np.vstack(runs)
    return np.percentile(stack, 2.5, axis=0), np.percentile(stack, 97.5, axis=0)
