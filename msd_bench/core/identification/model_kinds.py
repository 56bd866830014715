"""The model registry: every surrogate kind is one entry, looked up by name.

Why a table: a surrogate kind used to be spelt out in six places (pipeline,
identifier node, agent kinds, figures, kernels, artifacts), and an unknown
name fell through to the NLARX maths or got no figure without a word. Here a
kind is one :class:`ModelKind` — name, label, compiled kernel kind, fitter,
which record it trains on, which figure shows it — and :func:`model_kind`
raises a one-line :class:`ConfigError` naming the choices for anything else.

Adding a kind: write its fitter (a module of its own in ``core``), add one
entry to :data:`MODEL_KINDS` below, and (only if it needs new compiled maths)
a kernel in :mod:`msd_bench.core.physics.kernels` with its parameter layout in
:data:`KERNEL_LAYOUTS` (:mod:`msd_bench.core.physics.layouts`; the count rule and every slot's bounds,
which every model is checked against before its kernel runs). The agent kinds ``<name>``
and ``<name>+improved`` follow from the entry (:mod:`msd_bench.app.agents`).

Fitters import their science lazily: listing or checking kinds must not pull
in torch (the NLARX) or python-control.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.physics.layouts import (  # re-exported: the layouts were defined here
    COEF_MAX,
    KERNEL_LAYOUTS,
    KERNELS,
    NLARX_MAX_UNITS,
    RIG_DELAY_MAX,
    STROKE_MAX,
    KernelLayout,
    Slot,
    check_params,
)

if TYPE_CHECKING:  # the compiled kernels load numba: not needed to list or check kinds
    from msd_bench.core.identification.records import Records
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.rigs.scales import Scales

__all__ = ["COEF_MAX", "KERNELS", "KERNEL_LAYOUTS", "MODEL_KINDS", "NLARX_MAX_UNITS", "RIG_DELAY_MAX",
           "STROKE_MAX", "FitRequest", "Fitter", "KernelLayout", "ModelKind", "Slot", "check_models",
           "check_params", "fit_model", "model_kind", "needs_bias_records"]


@dataclass(frozen=True)
class FitRequest:
    """What every fitter is given: the records of one identification seed and the run's knobs."""

    records: Records
    """Training and validation records of the identification seed."""
    seed: int
    """Seed of any randomness in the fit (NLARX weight init, window sampling)."""
    stroke: float
    """Stroke L, m: model outputs are projected on [-L/2, L/2] like the plant's."""
    force: float = 10.0
    """Actuator limit F, N: commands saturate at ±F (the grey-box model's saturation)."""
    nlarx_scale: float = 1.0
    """Multiplies the NLARX training iterations (< 1 only for smoke runs)."""
    dt: float = 0.01
    """Sample time, s, of the records (default: the plant's ``DT``, not imported because the plant
    loads numba, which listing kinds must not): every model steps at it and its file records it
    (:func:`fit_model` refuses a fit whose model steps at another)."""
    units: tuple[str, str] = ("N", "m")
    """Units of the input and output as the records give them (``("V", "V")`` for a circuit):
    recorded in the model file, never converted."""
    scales: Scales | None = None
    """The scales of the rig the records come from (docs/decisions.md §Scales): the fitters' paper
    constants (filter cut-offs, search ranges, bounds) are scaled by them. None: the paper's constants
    as they are (every path but ``msd-bench rigs``, which knows each rig's)."""


Fitter = Callable[[FitRequest], "StepModel"]


@dataclass(frozen=True)
class ModelKind:
    """One surrogate kind: everything the bench needs to fit, step, report and draw it."""

    name: str
    """Machine name on the command line, in artifacts and reports (``plm``)."""
    label: str
    """Human label in Table 1 (``PLM``)."""
    kernel: str
    """Compiled kernel kind that steps it, one of :data:`KERNELS`."""
    records: str
    """Training data: ``"broad"`` (the multilevel record) or ``"bias"`` (the five PRBS records)."""
    figure: str
    """Fit figure: ``"broad"`` (free run on the broad validation record) or ``"bias"`` (a panel per bias)."""
    fit: Fitter
    """Fits the model from a :class:`FitRequest`."""

    def __post_init__(self) -> None:
        if self.records not in ("broad", "bias") or self.figure not in ("broad", "bias"):
            raise ConfigError(f"model kind {self.name}: records and figure must be 'broad' or 'bias'")
        if self.kernel not in KERNELS:
            raise ConfigError(f"model kind {self.name}: unknown kernel kind {self.kernel}")


def _fit_glm(req: FitRequest) -> StepModel:
    from msd_bench.core.identification import identify

    return identify.identify_glm(req.records.broad_train, identify.GlmConfig(stroke=req.stroke),
                                 force_limit=req.force)


def _fit_plm(req: FitRequest) -> StepModel:
    from msd_bench.core.identification import identify

    sc = req.scales
    units = (1.0, 1.0, 1.0) if sc is None else (sc.length, sc.force, sc.pace)
    return identify.identify_plm(req.records.bias_train, identify.PlmConfig(stroke=req.stroke),
                                 force_limit=req.force, units=units, closed_loop=req.records.closed_loop)


def _nlarx_fitter(form: str) -> Fitter:
    def fit(req: FitRequest) -> StepModel:
        from dataclasses import replace

        from msd_bench.core.identification import identify
        from msd_bench.core.identification.nlarx import NlarxConfig

        base = NlarxConfig(form=form, seed=req.seed)
        base = base if req.scales is None else base.scaled(req.scales)
        cfg = replace(base, one_step_iters=max(1, round(base.one_step_iters * req.nlarx_scale)),
                      sim_iters=round(base.sim_iters * req.nlarx_scale))
        return identify.identify_nlarx(req.records.broad_train, cfg, req.stroke, force_limit=req.force)

    return fit


def _fit_greybox(req: FitRequest) -> StepModel:
    from msd_bench.core.identification import identify
    from msd_bench.core.identification.greybox import GreyboxConfig
    from msd_bench.core.identification.integrator_choice import with_integrator_choice

    cfg = GreyboxConfig(stroke=req.stroke, force=req.force)
    cfg = cfg if req.scales is None else cfg.scaled(req.scales)
    train = req.records.broad_train
    return with_integrator_choice(train, lambda: identify.identify_greybox(train, cfg),
                                  req.stroke, req.force)


def _fit_greybox_rig(req: FitRequest) -> StepModel:
    from msd_bench.core.identification import greybox_rig
    from msd_bench.core.identification.integrator_choice import with_integrator_choice

    cfg = greybox_rig.GreyboxRigConfig(stroke=req.stroke, force=req.force)
    cfg = cfg if req.scales is None else cfg.scaled(req.scales)
    train = req.records.broad_train
    return with_integrator_choice(train, lambda: greybox_rig.identify_greybox_rig(train, cfg),
                                  req.stroke, req.force)


def _fit_greybox_rk4(req: FitRequest) -> StepModel:
    from msd_bench.core.identification import greybox_rk4

    cfg = greybox_rk4.Rk4Config(stroke=req.stroke, force=req.force)
    return greybox_rk4.identify_greybox_rk4(req.records.broad_train, cfg)


MODEL_KINDS: dict[str, ModelKind] = {
    k.name: k
    for k in (
        ModelKind("glm", "GLM", "linear", "broad", "broad", _fit_glm),
        ModelKind("plm", "PLM", "plm", "bias", "bias", _fit_plm),
        ModelKind("nlarx-paper", "NLARX paper form", "nlarx", "broad", "broad",
                  _nlarx_fitter("paper")),
        ModelKind("nlarx-improved", "NLARX improved form", "nlarx", "broad", "broad",
                  _nlarx_fitter("improved")),
        ModelKind("greybox", "Grey-box", "plant", "broad", "broad", _fit_greybox),
        ModelKind("greybox-rig", "Grey-box rig", "greybox-rig", "broad", "broad", _fit_greybox_rig),
        ModelKind("greybox-rk4", "Grey-box RK4", "rk4", "broad", "broad", _fit_greybox_rk4),
    )
}
"""Every surrogate kind, in report order."""


def model_kind(name: str) -> ModelKind:
    """The registry entry of ``name``; a one-line ConfigError listing the kinds otherwise."""
    try:
        return MODEL_KINDS[name]
    except KeyError:
        raise ConfigError(f"unknown model kind {name!r}; choose from {', '.join(MODEL_KINDS)}") from None


def check_models(names: tuple[str, ...] | list[str]) -> None:
    """One-line ConfigError unless every name is a registered kind, each given once."""
    for name in names:
        model_kind(name)
    if not names or len(set(names)) != len(names):
        raise ConfigError(f"model kinds must be given once each, got {list(names)}")


def needs_bias_records(names: Iterable[str]) -> bool:
    """Whether any of the kinds trains on the five bias records (which a run must then provide)."""
    return any(model_kind(n).records == "bias" for n in names)


def fit_model(name: str, req: FitRequest) -> StepModel:
    """Fit the kind ``name``; the model carries the registry name whatever its fitter called it,
    the request's stroke and units in its ``info`` (which its file records), and steps at the
    request's ``dt`` and ``force`` (an IdentificationError otherwise: a fitter that dropped them
    would write a model that runs at the wrong rate or saturates at the wrong force)."""
    entry = model_kind(name)
    model = entry.fit(req)
    if not (math.isclose(model.dt, req.dt, rel_tol=1e-9) and math.isclose(model.force_limit, req.force)):
        raise IdentificationError(f"model kind {name}: fitted at dt {model.dt:g} s, force limit "
                                  f"{model.force_limit:g}, but the request gave dt {req.dt:g} s, "
                                  f"force {req.force:g}")
    info = {**model.info, "model_kind": name, "stroke": req.stroke,
            "units": {"input": req.units[0], "output": req.units[1]}}
    return replace(model, name=name, info=info)
