"""The piecewise linear model (PLM) of the paper (§3.2): five local models, blended.

Five second-order local models are identified from five bias experiments,
B ∈ {-10, -5, 0, 5, 10} N (PRBS of ±1 N around each bias, 12,000 samples after
the settling segment is dropped), and blended at run time by triangular
weights of the current position.

Decision on coordinates (docs/decisions.md §PLM): the paper prints
the local recursions in absolute coordinates without saying where a local
model's operating point goes. We fit each local model in *deviation
coordinates* around its own operating point, ``u0 = B`` and ``y0`` started at
the mean measured position of its record, so each model carries the static
offset of its region. ``y0`` is then refined jointly with the coefficients
(the position the model assigns to the force B): at |B| = F the plant
saturates the upper half of the PRBS, the mean applied force is B ∓ 0.5 N, and
a ``y0`` fixed at the mean position paired with ``u0 = B`` was inconsistent —
the fit bent the gain to absorb it (DC gain 0.04 instead of 0.09 m/N, local
fit 35 % instead of 96 % at B = 10 N on the default plant). At run time all
five are evaluated on the *shared blended* position history (the surrogate's
own past outputs, not five private recursions) and their predictions blended
by weights of the current position. An earlier implementation measured about
98 % simulation fit this way against 80 % for five parallel recursions each on
its own outputs.

Decision on scheduling and refinement (ours, the default; docs/decisions.md
§PLM): the paper's memberships f1..f5 peak at -2, -1, 0, 1, 2 m, but on the
default plant the biases hold the mass at about -1.98, -1.38, 0, 1.38, 1.98 m,
so at its own operating point the 5 N model weighs only 0.25 against the 10 N
model's 0.75. We schedule on where each local model was identified: hat
functions centred on the local fits' operating positions ``y0``, i.e. linear
interpolation between the two neighbouring local models, the outer ones alone
beyond the outer centres (:func:`operating_centres`). Then all local models are
refined together on the free-run error of the blend over the five records
(:func:`refine_global`), because every record also visits its neighbours'
regions, where the blend mixes in models fitted elsewhere. Together they raise
the broad-range simulation fit on the default plant from 92.9-94.4 % to
96.5-97.8 % (identification seeds 0-2 and 10-12); ``PlmConfig(scheduling="paper",
refine=False)`` is the paper's construction, unchanged.

Packed layouts (``KIND_PLM``): ``[L, 5 × (n1, n2, d1, d2, u0, y0)]`` ordered by
bias -10, -5, 0, 5, 10, i.e. local model i is weighted by f_{i+1}; with the
scheduling centres appended, ``[..., c1..c5]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from msd_bench.core.errors import IdentificationError, InvalidInputError
from msd_bench.core.identification import lm, plm_jac
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.linear import LinearFit, oe_fit
from msd_bench.core.identification.operating_points import PLM_BIASES
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import NOMINAL_FORCE, StepModel

FloatArray = NDArray[np.float64]


_REFINED = tuple(int(i) for i in plm_jac.REFINED)
"""Slots of a local ``(n1, n2, d1, d2, u0, y0)`` the global refinement moves (``u0`` stays the bias)."""

Jacobian = Literal["exact", "finite-difference"]
"""How :func:`refine_global` differentiates: ``exact`` (compiled forward sensitivities, scheduled
PLMs; docs/decisions.md §Identification speed) or ``finite-difference`` (scipy's, the earlier path)."""


@dataclass(frozen=True)
class Refinement:
    """What the global simulation-error refinement did (kept in the model's info)."""

    cost_before: float
    """Sum of squared free-run errors over the five records with the local fits, m²."""
    cost_after: float
    """The same after refinement (equal to ``cost_before`` when it was not kept)."""
    nfev: int
    """Residual evaluations spent."""
    kept: bool
    """False when the refinement ended with an unstable local model or no improvement."""


def fit_local(bias: float, record: IOData, max_nfev: int = 200,
              units: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> LinearFit:
    """One local model around ``u0 = bias``, ``y0`` from the mean position refined jointly (in paper
    units on a rig of ``units``: :func:`~msd_bench.core.identification.linear.oe_fit`)."""
    y0 = float(np.mean(np.concatenate([e.y for e in record.experiments])))
    return oe_fit(record.experiments, float(bias), y0, record.dt, max_nfev, fit_offset=True, units=units)


def blend(
    local: Sequence[LinearFit],
    stroke: float,
    name: str = "plm",
    centres: Sequence[float] | None = None,
    force_limit: float = NOMINAL_FORCE,
) -> StepModel:
    """Pack five local models (ordered f1..f5, i.e. bias -10..10) into one PLM StepModel.

    The model steps at the local models' sample time and saturates at ``force_limit``
    (the rig's actuator limit), both of which its file records.

    Without ``centres`` the model blends by the paper's memberships f1..f5;
    with ``centres`` (strictly increasing positions, one per local model) it
    interpolates between the two local models whose centres bracket the
    position (layout in :mod:`msd_bench.core.physics.kernels`).
    """
    if len(local) != len(PLM_BIASES):
        raise InvalidInputError(f"a PLM needs exactly {len(PLM_BIASES)} local models, got {len(local)}")
    dts = {round(f.dt, 12) for f in local}
    if len(dts) != 1:
        raise InvalidInputError(f"local models have different sample times: {sorted(dts)}")
    params = [float(stroke)]
    for f in local:
        params.extend([f.n1, f.n2, f.d1, f.d2, f.u0, f.y0])
    info: dict[str, object] = {
        "dt": local[0].dt,
        "scheduling": "paper" if centres is None else "operating-points",
        "local_models": [
            {
                "u0": f.u0,
                "y0": f.y0,
                "coefficients": list(f.coefficients),
                "method": f.method,
                "dc_gain": f.dc_gain,
            }
            for f in local
        ],
    }
    if centres is not None:
        c = _checked_centres(centres)
        params.extend(c)
        info["centres"] = c
    return StepModel(kernels.KIND_PLM, np.array(params), name=name, info=info, dt=local[0].dt,
                     force_limit=force_limit)


def _checked_centres(centres: Sequence[float]) -> list[float]:
    c = [float(v) for v in centres]
    if len(c) != len(PLM_BIASES) or not np.all(np.isfinite(c)) or not np.all(np.diff(c) > 0):
        raise InvalidInputError(
            f"PLM scheduling centres must be {len(PLM_BIASES)} finite, strictly increasing positions, got {c}"
        )
    return c


def operating_centres(local: Sequence[LinearFit]) -> list[float]:
    """Where each local model was identified: its fitted operating position ``y0``.

    This is the position the plant holds under the bias (tested against the
    plant's equilibrium), the natural centre of the local model's validity.
    """
    return _checked_centres([f.y0 for f in local])


def local_from_params(params: np.ndarray, dt: float) -> list[LinearFit]:
    """The five local models packed in ``KIND_PLM`` parameters (inverse of :func:`blend`)."""
    p = np.asarray(params, dtype=float)
    if p.size not in (kernels.PLM_SIZE, kernels.PLM_SCHEDULED_SIZE):
        raise InvalidInputError(
            f"PLM parameters must have {kernels.PLM_SIZE} or {kernels.PLM_SCHEDULED_SIZE} values, "
            f"got {p.size}"
        )
    out = []
    for i in range(len(PLM_BIASES)):
        o = 1 + kernels.PLM_LOCAL_SIZE * i
        n1, n2, d1, d2, u0, y0 = p[o : o + kernels.PLM_LOCAL_SIZE].tolist()
        out.append(LinearFit(n1, n2, d1, d2, u0, y0, dt))
    return out


def refine_global(
    model: StepModel, records: Sequence[IOData], max_nfev: int = 200, jacobian: Jacobian = "exact",
    units: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> tuple[StepModel, Refinement]:
    """Refine every local model's ``(n1, n2, d1, d2, y0)`` on the free-run error of the *blend*.

    Why: each local model is fitted alone on its own record, but the
    surrogate that is run is the blend, and on every record the position
    wanders into the neighbours' regions (at ±5 N it spans about 0.7 m, half
    way to the next centre), where the blend mixes in a model fitted
    elsewhere. Minimising the simulation error of the blended model itself
    over all five records at once (the global learning of local model
    networks) makes the neighbours agree where they overlap. Each record's two
    initial outputs are estimated too, as in the local output-error fits. The
    scheduling (the memberships or the centres) and every ``u0`` stay fixed.
    The refinement is kept only if it lowers the cost and every local model
    stays stable. ``jacobian="exact"`` (a scheduled PLM only; the paper's
    memberships always use finite differences) gives the optimiser the
    derivative of the same free run instead of approximating it, which is
    what makes the PLM fast enough for a population of rigs. ``units`` (a rig's length, force and
    time unit) state the floor of each parameter's scale in its own unit (1.0: the paper's).
    """
    exps = [e for r in records for e in r.experiments]
    base = np.array(model.params, dtype=float)
    idx = np.array([1 + kernels.PLM_LOCAL_SIZE * i + j for i in range(len(PLM_BIASES)) for j in _REFINED])
    length, force, _ = units
    slot_unit = {0: length / force, 1: length / force, 2: 1.0, 3: 1.0, 5: length}  # n1 n2 d1 d2 y0
    floor = np.array([slot_unit[int(j)] for _ in range(len(PLM_BIASES)) for j in _REFINED])
    scale = np.abs(base[idx]) + 1e-6 * floor

    def unpack(z: FloatArray) -> FloatArray:
        p = base.copy()
        p[idx] = z[: idx.size] * scale
        return p

    exact = jacobian == "exact" and base.size == kernels.PLM_SCHEDULED_SIZE
    problem = _ExactProblem(model, exps, unpack, scale) if exact else None

    def residuals(z: FloatArray) -> FloatArray:
        if problem is not None:
            return problem.residuals(z)
        m = replace(model, params=unpack(z))
        parts = []
        for i, e in enumerate(exps):
            y0, y1 = z[idx.size + 2 * i], z[idx.size + 2 * i + 1]
            parts.append(_free_run(m, e, y0, y1) - e.y)
        return np.concatenate(parts)

    z0 = np.concatenate([base[idx] / scale, [v for e in exps for v in (e.y[0], e.y[1])]])
    r0 = residuals(z0)
    before = float(r0 @ r0)
    if problem is not None:
        z, after, nfev = _exact_lm(problem, z0, min(max_nfev, EXACT_MAX_ITER))
    else:
        sol = least_squares(residuals, z0, jac="2-point", x_scale="jac", method="trf", max_nfev=max_nfev)
        z, after, nfev = sol.x, float(2.0 * sol.cost), int(sol.nfev)
    refined = replace(model, params=unpack(z))
    stable = all(f.is_stable for f in local_from_params(refined.params, model.dt))
    if not (np.all(np.isfinite(z)) and stable and after < before):
        return model, Refinement(before, before, nfev, kept=False)
    return refined, Refinement(before, after, nfev, kept=True)


EXACT_MAX_ITER = 40
"""Most iterations of the exact refinement. Why a cap below ``max_nfev``: on a frictional rig the
refinement crawls (200 iterations, 6 s, for 6 % less cost), and on design rigs 30-38 80 iterations
gave the same validation fits as 40 on seven of eight rigs at twice the time; on the ideal plant it
converges in far fewer (tests/core/test_plm_refine.py)."""
EXACT_REL_STOP = 1e-8
"""The exact refinement stops when an iteration gains less than this share of the cost (least_squares'
default ``ftol``, which the refinement used before)."""


def _exact_lm(problem: _ExactProblem, z0: FloatArray, max_iter: int) -> tuple[FloatArray, float, int]:
    """The refinement on the exact Jacobian by Levenberg–Marquardt on the normal equations
    (:mod:`msd_bench.core.identification.lm`): (z, sum of squares, free runs). Why not least_squares'
    trf: its SVD of the 12,000-row Jacobian was half of the PLM's identification time."""
    unbounded = np.full(z0.size, np.inf)

    def jacobian(z: FloatArray, _r: FloatArray) -> tuple[FloatArray, int]:
        return problem.jacobian(z), 1

    try:
        z, cost, nfev = lm.levenberg_marquardt(problem.residuals, jacobian, z0, -unbounded, unbounded,
                                               max_iter, rel_stop=EXACT_REL_STOP, what="PLM refinement")
    except IdentificationError:
        return z0, math.inf, 0
    return z, 2.0 * cost, nfev


class _ExactProblem:
    """Residuals and their exact Jacobian for :func:`refine_global` (compiled free runs)."""

    def __init__(
        self, model: StepModel, exps: Sequence[Experiment], unpack: Callable[[FloatArray], FloatArray],
        scale: FloatArray,
    ) -> None:
        self.exps = list(exps)
        self.unpack = unpack
        self.scale = scale
        self.limit = float(model.force_limit)
        self.n_free = scale.size

    def _runs(self, z: FloatArray, with_jac: bool) -> list[tuple[FloatArray, FloatArray]]:
        p = self.unpack(z)
        out = []
        for i, e in enumerate(self.exps):
            y0, y1 = float(z[self.n_free + 2 * i]), float(z[self.n_free + 2 * i + 1])
            out.append(plm_jac.free_run_jac(p, e.u, y0, y1, float(e.u[0]), self.limit, with_jac))
        return out

    def residuals(self, z: FloatArray) -> FloatArray:
        """The free-run errors of every record, concatenated (clamped like :func:`_free_run`)."""
        r = np.concatenate([y - e.y for (y, _), e in zip(self._runs(z, False), self.exps, strict=True)])
        clamped: FloatArray = np.clip(np.nan_to_num(r, nan=1e6), -1e6, 1e6)
        return clamped

    def jacobian(self, z: FloatArray) -> FloatArray:
        """d residuals / d z: model columns scaled like ``z``, each record's own two start columns."""
        runs = self._runs(z, True)
        n_rows = sum(len(e) for e in self.exps)
        jac = np.zeros((n_rows, z.size))
        row = 0
        for i, (_, j) in enumerate(runs):
            n = j.shape[0]
            jac[row : row + n, : self.n_free] = j[:, : self.n_free] * self.scale
            jac[row : row + n, self.n_free + 2 * i : self.n_free + 2 * i + 2] = j[:, self.n_free :]
            row += n
        return jac


def _free_run(model: StepModel, e: Experiment, y0: float, y1: float) -> FloatArray:
    """Free run of ``model`` over ``e`` from the outputs ``(y0, y1)`` at samples 0 and 1."""
    state = np.array([y1, y0, e.u[0], 0.0])
    out = np.concatenate([[y0], kernels.rollout(model.kernel, e.u[1:], state)])
    clamped: FloatArray = np.clip(np.nan_to_num(out, nan=1e6), -1e6, 1e6)
    return clamped
