"""High-level identification API: records in, :class:`StepModel` surrogates and fit reports out.

The pipeline and the ROS identifier node call only this module:

* :func:`bias_record` / :func:`broad_record` drive the plant with the paper's
  excitations (PRBS around a bias; multilevel switching over the alphabet),
  optionally measured through a :class:`~msd_bench.core.physics.sensor.SensorModel`
  (the record's ``y`` is then the measured position; the noise-free position
  rides along as ``Experiment.truth`` for scoring only);
* :func:`identify_glm`, :func:`identify_plm`, :func:`identify_nlarx` fit the
  three surrogate families (paper §3.2, §3.3, §3.4.1), :func:`identify_greybox`
  the plant's own structure (:mod:`msd_bench.core.identification.greybox`);
* :func:`evaluate` scores a model on a *separate* validation record, in free-run
  simulation and in one-step prediction (report both: they differ wildly for
  the paper-form NLARX, and one-step fit says little on its own — repeating
  the last sample already scores about 98 %, see :func:`naive_one_step_fits`).

Evaluation convention. The simulation fit (``sim_fit``) starts each validation
experiment from an *estimated* initial state, as MATLAB's ``compare`` does:
the state (the two past outputs of an ARX-type model, ``(x0, v0)`` of a
plant-structure model) that best reproduces the first
:data:`INIT_HORIZON` measured samples in free run, by least squares
(:func:`estimate_initial_state`). Starting from the first two raw samples
instead (``sim_fit_raw_start``, ``initial="measured"``) turns sensor noise into
a velocity error of ``sqrt(2) σ / dt`` — 0.28 m/s for 2 mm — that costs even
the exact plant 3.4 points. With several experiments, their predictions are
concatenated and one Best-Fit is computed over the concatenation (not a mean
of per-experiment fits), so a long experiment weighs more than a short one.
Where the record carries its noise-free truth, ``sim_fit_truth`` scores the
same simulation against the truth instead of the noisy measurement.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from msd_bench.core.errors import ConfigError, IdentificationError, InvalidInputError
from msd_bench.core.identification import greybox, greybox_rk4
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.excitation import MultilevelConfig, PrbsConfig, multilevel, prbs
from msd_bench.core.identification.fit import fit_percent
from msd_bench.core.identification.greybox import GreyboxConfig
from msd_bench.core.identification.linear import LinearFit, oe_fit
from msd_bench.core.identification.operating_points import PLM_BIASES
from msd_bench.core.identification.plm import (
    Jacobian,
    blend,
    fit_local,
    local_from_params,
    operating_centres,
    refine_global,
)
from msd_bench.core.physics import kernels, plant
from msd_bench.core.physics.model import NOMINAL_FORCE, PLANT_LIKE, StepModel
from msd_bench.core.physics.sensor import SensorModel, sensor_rng

if TYPE_CHECKING:  # the NLARX trains with torch: imported only when one is fitted
    from msd_bench.core.identification.nlarx import NlarxConfig

FloatArray = NDArray[np.float64]
InitialState = Literal["estimate", "measured"]

INIT_HORIZON = 300
"""Samples (3 s at 10 ms) over which a validation experiment's initial state is estimated."""

__all__ = [
    "INIT_HORIZON",
    "FitReport",
    "GlmConfig",
    "GreyboxConfig",
    "PlmConfig",
    "bias_record",
    "broad_record",
    "estimate_initial_state",
    "evaluate",
    "free_run",
    "identify_glm",
    "identify_greybox",
    "identify_nlarx",
    "identify_plm",
    "naive_one_step_fits",
    "one_step",
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
    """Piecewise linear model (paper §3.2): five local models, blended (docs/decisions.md §PLM)."""

    scheduling: Literal["operating-points", "paper"] = "operating-points"
    """``operating-points`` (ours): interpolate between the two local models whose identified
    operating positions bracket the position; ``paper``: the printed memberships f1..f5."""
    refine: bool = True
    """Refine all local models together on the blend's free-run error over the five records
    (:func:`msd_bench.core.identification.plm.refine_global`); False keeps the separate local fits."""
    jacobian: Jacobian = "exact"
    """How the refinement differentiates the blend's free run: ``exact`` (compiled sensitivities,
    the default) or ``finite-difference`` (the earlier path, kept for the speed benchmark)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.jacobian not in ("exact", "finite-difference"):
            raise ConfigError(
                f"PLM jacobian must be 'exact' or 'finite-difference', got {self.jacobian!r}"
            )
        if self.scheduling not in ("operating-points", "paper"):
            raise ConfigError(
                f"PLM scheduling must be 'operating-points' or 'paper', got {self.scheduling!r}"
            )


@dataclass(frozen=True)
class FitReport:
    """How well a model reproduces a validation record it was not fitted on."""

    model: str
    """Model name (``glm``, ``plm``, ``nlarx-paper``, ``nlarx-improved``, ``greybox``)."""
    sim_fit: float
    """Best-Fit % of the free-run simulation against the measured record, from estimated initial states."""
    one_step_fit: float
    """Best-Fit % of the one-step-ahead prediction from measured history."""
    n_identification: int
    """Samples the model was identified from (0 if unknown)."""
    n_validation: int
    """Samples of the validation record."""
    fit_seconds: float
    """Wall time of the identification, s (NaN if unknown)."""
    sim_fit_raw_start: float | None = None
    """Best-Fit % of the free run started from the first two raw measured samples (the old convention)."""
    sim_fit_truth: float | None = None
    """Best-Fit % of the (estimated-start) free run against the noise-free truth; None without truth."""
    initial_state: str = "estimate"
    """How ``sim_fit`` started each experiment: ``estimate`` (least squares) or ``measured``."""

    def as_row(self) -> dict[str, Any]:
        """The fit columns of a results row (``fit_*_percent`` keys, as in table1)."""
        return {
            "fit_sim_percent": self.sim_fit,
            "fit_one_step_percent": self.one_step_fit,
            "fit_sim_truth_percent": self.sim_fit_truth,
            "fit_sim_raw_start_percent": self.sim_fit_raw_start,
        }


def bias_record(
    params: plant.PlantParams,
    bias: float,
    seed: int,
    cfg: PrbsConfig | None = None,
    sensor: SensorModel | None = None,
    sensor_seed: int | None = None,
) -> IOData:
    """Drive the plant from rest with PRBS around ``bias``; the settle segment is dropped.

    With a ``sensor``, ``y`` is the measured position (noise drawn from
    :func:`~msd_bench.core.physics.sensor.sensor_rng` of ``sensor_seed``, default
    ``seed``, over the whole run including the dropped settle segment, as a
    sensor that was on all along); ``truth`` is always the noise-free position.
    """
    cfg = replace(cfg or PrbsConfig(), bias=float(bias))
    u = prbs(cfg, seed)
    x, _, u_applied = plant.simulate(u, params)
    y = _measure(x, sensor, seed if sensor_seed is None else sensor_seed)
    s = cfg.settle
    meta = {"excitation": "prbs", "bias": float(bias), "seed": seed, "settle_dropped": s,
            **_sensor_meta(sensor, seed if sensor_seed is None else sensor_seed)}
    exp = Experiment(u_applied[s:], y[s:], name=f"bias={bias:+g}", truth=x[s:])
    return IOData((exp,), params.dt, meta)


def broad_record(
    params: plant.PlantParams,
    seed: int,
    cfg: MultilevelConfig | None = None,
    sensor: SensorModel | None = None,
    sensor_seed: int | None = None,
) -> IOData:
    """Drive the plant from rest with the multilevel switching record (GLM / NLARX / grey-box data).

    ``sensor`` and ``sensor_seed`` as in :func:`bias_record`.
    """
    u = multilevel(cfg or MultilevelConfig(), seed)
    x, _, u_applied = plant.simulate(u, params)
    y = _measure(x, sensor, seed if sensor_seed is None else sensor_seed)
    meta = {"excitation": "multilevel", "seed": seed,
            **_sensor_meta(sensor, seed if sensor_seed is None else sensor_seed)}
    exp = Experiment(u_applied, y, name=f"multilevel seed={seed}", truth=x)
    return IOData((exp,), params.dt, meta)


def _measure(x: FloatArray, sensor: SensorModel | None, seed: int) -> FloatArray:
    if sensor is None or sensor.is_ideal:
        return x
    return sensor.measure(x, sensor_rng(seed))


def _sensor_meta(sensor: SensorModel | None, seed: int) -> dict[str, object]:
    if sensor is None or sensor.is_ideal:
        return {}
    return {"sensor": {"noise_std": sensor.noise_std, "quant": sensor.quant, "seed": seed}}


def identify_glm(train: IOData, cfg: GlmConfig | None = None,
                 force_limit: float = NOMINAL_FORCE) -> StepModel:
    """One global linear model in absolute coordinates (the odd spring rests at 0 under 0 N).

    The model steps at the record's sample time and saturates at ``force_limit``.
    """
    cfg = cfg or GlmConfig()
    t0 = time.perf_counter()
    fit = oe_fit(train.experiments, 0.0, 0.0, train.dt, max_nfev=cfg.max_nfev)
    info = {**_linear_info(fit), "n_samples": train.n_samples}
    info["fit_seconds"] = time.perf_counter() - t0
    return StepModel(kernels.KIND_LINEAR, fit.to_params(cfg.stroke), name="glm", info=info,
                     dt=train.dt, force_limit=force_limit)


def identify_plm(
    records: Mapping[float, IOData] | Sequence[tuple[float, IOData]], cfg: PlmConfig | None = None,
    force_limit: float = NOMINAL_FORCE, units: tuple[float, float, float] = (1.0, 1.0, 1.0),
    closed_loop: Sequence[IOData] = (),
) -> StepModel:
    """Five local models, one per bias record, blended (see :mod:`msd_bench.core.identification.plm`);
    ``units`` are a rig's length, force and time unit (:func:`~msd_bench.core.identification.plm.fit_local`),
    all 1.0 on the paper's plant.

    ``closed_loop``: records of tries on the rig under a controller (a refit on the rig). Each local
    model stays fitted on its own bias record (a try holds one set-point, not a bias's operating
    point), and the tries join the bias records in the refinement of the blend, which minimises the
    blend's free-run error driven by the applied force: the simulation-error fit that stays
    consistent under feedback (docs/rigs.md §Refinement on the rig)."""
    cfg = cfg or PlmConfig()
    if closed_loop and not cfg.refine:
        raise InvalidInputError("closed-loop records join the PLM's global refinement; "
                                "this PlmConfig does not refine")
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
    local = [fit_local(b, r, max_nfev=cfg.max_nfev, units=units) for b, r in pairs]
    centres = operating_centres(local) if cfg.scheduling == "operating-points" else None
    model = blend(local, cfg.stroke, centres=centres, force_limit=force_limit)
    if cfg.refine:
        model, ref = refine_global(
            model, [*(r for _, r in pairs), *closed_loop], max_nfev=cfg.max_nfev, jacobian=cfg.jacobian,
            units=units,
        )
        final = local_from_params(model.params, local[0].dt)
        model.info.update(blend(final, cfg.stroke, centres=centres, force_limit=force_limit).info)
        for entry in model.info["local_models"] if ref.kept else []:
            entry["method"] = "oe, refined on the blend"
        model.info["local_fits"] = [  # the separate local fits the refinement started from
            {"u0": f.u0, "y0": f.y0, "coefficients": list(f.coefficients), "method": f.method} for f in local
        ]
        model.info["refinement"] = {
            "method": "global simulation-error least squares of the blend over the five records"
            + (f" and {sum(len(r.experiments) for r in closed_loop)} closed-loop records"
               if closed_loop else ""),
            **asdict(ref),
        }
    model.info.update(
        biases=biases,
        n_samples=sum(r.n_samples for _, r in pairs) + sum(r.n_samples for r in closed_loop),
        fit_seconds=time.perf_counter() - t0,
    )
    return model


def identify_nlarx(train: IOData, cfg: NlarxConfig | None = None, stroke: float = 5.0,
                   force_limit: float = NOMINAL_FORCE) -> StepModel:
    """NLARX sigmoid network, ``paper`` or ``improved`` form (see
    :mod:`msd_bench.core.identification.nlarx`), stepping at the record's sample time and
    saturating at ``force_limit``."""
    from msd_bench.core.identification.nlarx import NlarxConfig, fit_nlarx

    cfg = cfg or NlarxConfig()
    _positive(stroke, "stroke")
    t0 = time.perf_counter()
    params, info = fit_nlarx(train.experiments, stroke, cfg, train.dt)
    info.update(n_samples=train.n_samples, dt=train.dt, fit_seconds=time.perf_counter() - t0)
    return StepModel(kernels.KIND_NLARX, params, name=f"nlarx-{cfg.form}", info=info,
                     dt=train.dt, force_limit=force_limit)


def identify_greybox(train: IOData, cfg: GreyboxConfig | None = None) -> StepModel:
    """The plant's structure, parameters fitted by simulation-error least squares.

    Returns a ``KIND_PLANT`` model (:func:`msd_bench.core.physics.model.plant_model`'s
    kind) with the known stroke and saturation of ``cfg`` and the record's
    sample time; see :mod:`msd_bench.core.identification.greybox` for the method.
    """
    cfg = cfg or GreyboxConfig()
    t0 = time.perf_counter()
    fit = greybox.fit_greybox(train.experiments, train.dt, cfg)
    p = fit.params
    info: dict[str, Any] = {
        "parameters": {name: float(getattr(p, name)) for name in greybox.PARAM_NAMES},
        "known": {"L": p.L, "F": p.F, "dt": p.dt},
        "start": dict(zip(greybox.PARAM_NAMES, fit.start, strict=True)),
        "initial_states": [list(s) for s in fit.initial_states],
        "cost": fit.cost,
        "train_rms": fit.rms,
        "nfev": fit.nfev,
        "method": "simulation-error least squares from an equation-error start",
        "n_samples": train.n_samples,
        "dt": train.dt,
    }
    info["fit_seconds"] = time.perf_counter() - t0
    return StepModel(kernels.KIND_PLANT, p.as_array(), name="greybox", info=info, dt=p.dt, force_limit=p.F)


def free_run(model: StepModel, exp: Experiment, initial: InitialState = "estimate",
             horizon: int = INIT_HORIZON) -> FloatArray:
    """Free-run simulation of ``exp.u``, one output per sample (``yhat[0]`` is the initial position).

    ``initial="estimate"`` (the default, MATLAB ``compare``'s choice) starts from
    :func:`estimate_initial_state`; ``"measured"`` from the first two raw
    samples: ``(y[1], y[0], u[0])`` for an ARX-type model, ``(y[1], (y[1] - y[0]) / dt)``
    for a plant-structure model, with ``yhat[:2] = y[:2]``. ``horizon``: the samples the
    estimate may use (a benchmark protocol states its own, the Silverbox's is 50).
    """
    if initial == "estimate":
        return _simulate_from(model, exp, estimate_initial_state(model, exp, horizon))
    if initial == "measured":
        return _simulate_from(model, exp, _measured_start(model, exp))
    raise ConfigError(f"initial state must be 'estimate' or 'measured', got {initial!r}")


def estimate_initial_state(model: StepModel, exp: Experiment, horizon: int = INIT_HORIZON) -> FloatArray:
    """The two initial-state values that best reproduce the first ``horizon`` samples in free run.

    ARX-type models: the positions at samples 1 and 0 (``u[0]`` is known);
    plant-structure models: ``(x0, v0)``. Least squares started from the
    measured start, so on noise-free data consistent with the model it
    returns the measured start itself.
    """
    n = min(int(horizon), len(exp))
    head = Experiment(exp.u[:n], exp.y[:n], exp.name)
    start = _measured_start(model, head)
    scale = max(float(np.std(head.y)), 1e-6)

    def state(z: FloatArray) -> FloatArray:
        return np.concatenate([z[:2], start[2:]])

    def residuals(z: FloatArray) -> FloatArray:
        return (_simulate_from(model, head, state(z)) - head.y) / scale

    z0 = np.array(start[:2])
    if not np.all(np.isfinite(residuals(z0))):
        return start
    sol = least_squares(residuals, z0, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12, max_nfev=200)
    return state(sol.x) if np.all(np.isfinite(sol.x)) else start


def _measured_start(model: StepModel, exp: Experiment) -> FloatArray:
    """The state after the first sample, from the first two raw measurements (the old convention)."""
    s = model.initial_state()
    if model.kind in PLANT_LIKE:
        s[:2] = exp.y[1], (exp.y[1] - exp.y[0]) / float(model.params[7])
        if model.kind == kernels.KIND_GREYBOX_RIG:  # its actuator, idle before the record, took u[0]
            kernels.rig_actuator(model.params, s, kernels.saturate(float(exp.u[0]), model.force_limit))
        if model.kind == kernels.KIND_RK4:  # the command that acted last (the ramp's next start)
            s[kernels.ARX_INPUT] = kernels.saturate(float(_fed(model, exp.u)[0]), model.force_limit)
    else:
        s[:3] = exp.y[1], exp.y[0], exp.u[0]
    return s


def _simulate_from(model: StepModel, exp: Experiment, state: FloatArray) -> FloatArray:
    """Free run over ``exp`` from ``state``: the state after sample 0 for ARX (``yhat[0] = state[1]``).

    For the plant kind ``state`` is ``(x, v)`` *after* sample 0 as well, with
    ``yhat[0] = x - dt v`` (one Euler step back), so both kinds have two
    free numbers that fix samples 0 and 1.
    """
    s = np.array(state, dtype=float)
    y0 = s[0] - float(model.params[7]) * s[1] if model.kind in PLANT_LIKE else s[1]
    return np.concatenate([[y0], kernels.rollout(model.kernel, _fed(model, exp.u)[1:], s)])


def _fed(model: StepModel, u: FloatArray) -> FloatArray:
    """The record's commands as the model's kernel takes them: advanced by an rk4 model's input lead
    (its ``ramp`` structure, :func:`greybox_rk4.fed_input`), unchanged for every other kind."""
    if model.kind != kernels.KIND_RK4:
        return u
    return greybox_rk4.fed_input(u, int(model.info.get("input_lead", 0)))


def one_step(model: StepModel, exp: Experiment) -> FloatArray:
    """One-step-ahead prediction of ``exp`` from its measured history (every model kind)."""
    if model.kind == kernels.KIND_PLANT:
        return greybox.one_step(model.params, exp.y, exp.u)
    if model.kind == kernels.KIND_GREYBOX_RIG:
        return kernels.rig_one_step(model.kernel, exp.y, exp.u)
    if model.kind == kernels.KIND_RK4:
        return greybox_rk4.one_step(model, exp)
    return model.predict_one_step(exp.y, exp.u)


def evaluate(model: StepModel, validation: IOData, initial: InitialState = "estimate",
             horizon: int = INIT_HORIZON, skip: int = 0) -> FitReport:
    """Simulation and one-step Best-Fit on ``validation`` (concatenated over its experiments).

    ``horizon``: the initial-state window (samples); ``skip``: the first samples of each
    experiment left out of every score (a protocol that initialises on its window scores after it).

    ``sim_fit`` uses ``initial`` (default: estimated initial states, see the
    module docstring); ``sim_fit_raw_start`` always the first two raw samples;
    ``sim_fit_truth`` the same simulation as ``sim_fit`` scored against the
    noise-free truth when every experiment carries it.
    """
    exps = validation.experiments
    if not (isinstance(skip, int) and 0 <= skip < min(len(e) for e in exps)):
        raise ConfigError(f"skip must be an integer in [0, shortest experiment), got {skip!r}")
    y = np.concatenate([e.y[skip:] for e in exps])
    sim = np.concatenate([free_run(model, e, initial, horizon)[skip:] for e in exps])
    raw = sim if initial == "measured" else np.concatenate([free_run(model, e, "measured")[skip:]
                                                            for e in exps])
    one = np.concatenate([one_step(model, e)[skip:] for e in exps])
    truth = None
    if validation.has_truth:
        truth = fit_percent(np.concatenate([e.y_true[skip:] for e in exps]), sim)
    seconds = model.info.get("fit_seconds", float("nan"))
    return FitReport(
        model=model.name,
        sim_fit=fit_percent(y, sim),
        one_step_fit=fit_percent(y, one),
        n_identification=int(model.info.get("n_samples", 0)),
        n_validation=y.size,
        fit_seconds=float(seconds),
        sim_fit_raw_start=fit_percent(y, raw),
        sim_fit_truth=truth,
        initial_state=initial,
    )


def naive_one_step_fits(validation: IOData) -> dict[str, float]:
    """One-step Best-Fit of two predictors that know nothing about the plant.

    ``last_sample`` predicts ``y[k] = y[k-1]``, ``constant_velocity``
    ``y[k] = 2 y[k-1] - y[k-2]``; at 10 ms they score about 98 % and 99.9 %, so
    a one-step fit means something only above them. The first two samples are
    copied, as in every one-step predictor here.
    """
    ys, last, cv = [], [], []
    for e in validation.experiments:
        y = e.y
        ys.append(y)
        last.append(np.concatenate([y[:2], y[1:-1]]))
        cv.append(np.concatenate([y[:2], 2 * y[1:-1] - y[:-2]]))
    y_all = np.concatenate(ys)
    return {
        "last_sample": fit_percent(y_all, np.concatenate(last)),
        "constant_velocity": fit_percent(y_all, np.concatenate(cv)),
    }


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
