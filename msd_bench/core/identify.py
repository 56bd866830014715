"""High-level identification API: records in, :class:`StepModel` surrogates and fit reports out.

The pipeline and the ROS identifier node call only this module:

* :func:`bias_record` / :func:`broad_record` drive the plant with the paper's
  excitations (PRBS around a bias; multilevel switching over the alphabet);
* :func:`identify_glm`, :func:`identify_plm`, :func:`identify_nlarx` fit the
  three surrogate families (paper §3.2, §3.3, §3.4.1);
* :func:`evaluate` scores a model on a *separate* validation record, in free-run
  simulation and in one-step prediction (report both: they differ wildly for
  the paper-form NLARX).

Evaluation convention: each validation experiment is predicted from its own
first two measured samples (the initial state of an ARX-type model); with
several experiments, their predictions are concatenated and one Best-Fit is
computed over the concatenation (not a mean of per-experiment fits), so a
long experiment weighs more than a short one.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from msd_bench.core import kernels, plant
from msd_bench.core.data import Experiment, IOData
from msd_bench.core.errors import ConfigError, IdentificationError, InvalidInputError
from msd_bench.core.excitation import MultilevelConfig, PrbsConfig, multilevel, prbs
from msd_bench.core.fit import fit_percent
from msd_bench.core.linear import LinearFit, oe_fit
from msd_bench.core.model import StepModel
from msd_bench.core.plm import PLM_BIASES, blend, fit_local

if TYPE_CHECKING:  # the NLARX trains with torch: imported only when one is fitted
    from msd_bench.core.nlarx import NlarxConfig

FloatArray = np.ndarray

__all__ = [
    "FitReport",
    "GlmConfig",
    "PlmConfig",
    "bias_record",
    "broad_record",
    "evaluate",
    "free_run",
    "identify_glm",
    "identify_nlarx",
    "identify_plm",
]


@dataclass(frozen=True)
class LinearFitConfig:
    """Settings shared by every 2nd-order output-error fit."""

    stroke: float = 5.0
    """Stroke L in m; the model's output is projected on [-L/2, L/2] like the plant's."""
    max_nfev: int = 200
    """Maximum residual evaluations of each output-error refinement."""

    def __post_init__(self) -> None:
        _positive(self.stroke, "stroke")
        _positive(self.max_nfev, "max_nfev")


@dataclass(frozen=True)
class GlmConfig(LinearFitConfig):
    """Global linear model (paper §3.4.1): one 2nd-order model on the broad record."""


@dataclass(frozen=True)
class PlmConfig(LinearFitConfig):
    """Piecewise linear model (paper §3.2): five local models blended by f1..f5."""


@dataclass(frozen=True)
class FitReport:
    """How well a model reproduces a validation record it was not fitted on."""

    model: str
    """Model name (``glm``, ``plm``, ``nlarx-paper``, ``nlarx-improved``)."""
    sim_fit: float
    """Best-Fit % of the free-run simulation from measured initial states."""
    one_step_fit: float
    """Best-Fit % of the one-step-ahead prediction from measured history."""
    n_identification: int
    """Samples the model was identified from (0 if unknown)."""
    n_validation: int
    """Samples of the validation record."""
    fit_seconds: float
    """Wall time of the identification, s (NaN if unknown)."""


def bias_record(
    params: plant.PlantParams, bias: float, seed: int, cfg: PrbsConfig | None = None
) -> IOData:
    """Drive the plant from rest with PRBS around ``bias``; the settle segment is dropped."""
    cfg = replace(cfg or PrbsConfig(), bias=float(bias))
    u = prbs(cfg, seed)
    x, _, u_applied = plant.simulate(u, params)
    s = cfg.settle
    meta = {"excitation": "prbs", "bias": float(bias), "seed": seed, "settle_dropped": s}
    exp = Experiment(u_applied[s:], x[s:], name=f"bias={bias:+g}")
    return IOData((exp,), params.dt, meta)


def broad_record(params: plant.PlantParams, seed: int, cfg: MultilevelConfig | None = None) -> IOData:
    """Drive the plant from rest with the multilevel switching record (GLM / NLARX data)."""
    u = multilevel(cfg or MultilevelConfig(), seed)
    x, _, u_applied = plant.simulate(u, params)
    meta = {"excitation": "multilevel", "seed": seed}
    return IOData((Experiment(u_applied, x, name=f"multilevel seed={seed}"),), params.dt, meta)


def identify_glm(train: IOData, cfg: GlmConfig | None = None) -> StepModel:
    """One global linear model in absolute coordinates (the odd spring rests at 0 under 0 N)."""
    cfg = cfg or GlmConfig()
    t0 = time.perf_counter()
    fit = oe_fit(train.experiments, 0.0, 0.0, train.dt, max_nfev=cfg.max_nfev)
    info = {**_linear_info(fit), "n_samples": train.n_samples}
    info["fit_seconds"] = time.perf_counter() - t0
    return StepModel(kernels.KIND_LINEAR, fit.to_params(cfg.stroke), name="glm", info=info)


def identify_plm(
    records: Mapping[float, IOData] | Sequence[tuple[float, IOData]], cfg: PlmConfig | None = None
) -> StepModel:
    """Five local models, one per bias record, blended (see :mod:`msd_bench.core.plm`)."""
    cfg = cfg or PlmConfig()
    items = records.items() if isinstance(records, Mapping) else records
    pairs = sorted(((float(b), r) for b, r in items), key=lambda p: p[0])
    biases = [float(b) for b, _ in pairs]
    if len(set(biases)) != len(PLM_BIASES):
        raise InvalidInputError(
            f"PLM needs records at {len(PLM_BIASES)} distinct biases, got {len(set(biases))}: {biases}"
        )
    dts = {round(r.dt, 12) for _, r in pairs}
    if len(dts) != 1:
        raise InvalidInputError(f"PLM records have different sample times: {sorted(dts)}")
    t0 = time.perf_counter()
    local = [fit_local(b, r, max_nfev=cfg.max_nfev) for b, r in pairs]
    model = blend(local, cfg.stroke)
    model.info.update(
        biases=biases,
        n_samples=sum(r.n_samples for _, r in pairs),
        fit_seconds=time.perf_counter() - t0,
    )
    return model


def identify_nlarx(train: IOData, cfg: NlarxConfig | None = None, stroke: float = 5.0) -> StepModel:
    """NLARX sigmoid network, ``paper`` or ``improved`` form (see :mod:`msd_bench.core.nlarx`)."""
    from msd_bench.core.nlarx import NlarxConfig, fit_nlarx

    cfg = cfg or NlarxConfig()
    _positive(stroke, "stroke")
    t0 = time.perf_counter()
    params, info = fit_nlarx(train.experiments, stroke, cfg)
    info.update(n_samples=train.n_samples, dt=train.dt, fit_seconds=time.perf_counter() - t0)
    return StepModel(kernels.KIND_NLARX, params, name=f"nlarx-{cfg.form}", info=info)


def free_run(model: StepModel, exp: Experiment) -> FloatArray:
    """Free-run simulation of ``exp.u`` from the measured ``(y[1], y[0], u[0])``; ``yhat[:2] = y[:2]``."""
    if model.kind == kernels.KIND_PLANT:
        raise InvalidInputError("free_run evaluates ARX-type surrogates, not the plant")
    state = np.array([exp.y[1], exp.y[0], exp.u[0], 0.0])
    return np.concatenate([exp.y[:1], model.simulate(exp.u[1:], state)])


def evaluate(model: StepModel, validation: IOData) -> FitReport:
    """Simulation and one-step Best-Fit on ``validation`` (concatenated over its experiments)."""
    y = np.concatenate([e.y for e in validation.experiments])
    sim = np.concatenate([free_run(model, e) for e in validation.experiments])
    one = np.concatenate([model.predict_one_step(e.y, e.u) for e in validation.experiments])
    seconds = model.info.get("fit_seconds", float("nan"))
    return FitReport(
        model=model.name,
        sim_fit=fit_percent(y, sim),
        one_step_fit=fit_percent(y, one),
        n_identification=int(model.info.get("n_samples", 0)),
        n_validation=validation.n_samples,
        fit_seconds=float(seconds),
    )


def _linear_info(fit: LinearFit) -> dict[str, object]:
    info: dict[str, object] = {
        "coefficients": {"n1": fit.n1, "n2": fit.n2, "d1": fit.d1, "d2": fit.d2},
        "operating_point": {"u0": fit.u0, "y0": fit.y0},
        "method": fit.method,
        "dc_gain": fit.dc_gain,
        "poles": [[p.real, p.imag] for p in fit.poles],
        "dt": fit.dt,
    }
    try:
        ct = fit.to_continuous()
        info["continuous_tf"] = {
            "num": np.ravel(ct.num[0][0]).tolist(),
            "den": np.ravel(ct.den[0][0]).tolist(),
        }
    except IdentificationError:
        info["continuous_tf"] = None
    return info


def _positive(value: float, name: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be finite and > 0, got {value}")
