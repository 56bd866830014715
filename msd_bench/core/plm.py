"""The piecewise linear model (PLM) of the paper (§3.2): five local models, blended.

Five second-order local models are identified from five bias experiments,
B ∈ {-10, -5, 0, 5, 10} N (PRBS of ±1 N around each bias, 12,000 samples after
the settling segment is dropped), and blended at run time by the paper's
triangular memberships f1..f5 of the current position.

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
by f1..f5 of the current position (:func:`msd_bench.core.kernels.membership`).
An earlier implementation measured about 98 % simulation fit this way against 80 % for
five parallel recursions each on its own outputs (we measured 97.4 % on the
mild preset and 92.5 % on the default one, broad-range validation record).
With f1..f5 as printed the weights always sum to > 0; the kernel still falls
back to the nearest centre as a guard.

Packed layout (``KIND_PLM``): ``[L, 5 × (n1, n2, d1, d2, u0, y0)]`` ordered by
bias -10, -5, 0, 5, 10, i.e. local model i is weighted by f_{i+1}.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from msd_bench.core import kernels
from msd_bench.core.data import IOData
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.linear import LinearFit, oe_fit
from msd_bench.core.model import StepModel

PLM_BIASES = (-10.0, -5.0, 0.0, 5.0, 10.0)
"""The paper's bias forces, N, in the order of the memberships f1..f5."""


def fit_local(bias: float, record: IOData, max_nfev: int = 200) -> LinearFit:
    """One local model around ``u0 = bias``, ``y0`` from the mean position refined jointly."""
    y0 = float(np.mean(np.concatenate([e.y for e in record.experiments])))
    return oe_fit(record.experiments, float(bias), y0, record.dt, max_nfev, fit_offset=True)


def blend(local: Sequence[LinearFit], stroke: float, name: str = "plm") -> StepModel:
    """Pack five local models (ordered f1..f5, i.e. bias -10..10) into one PLM StepModel."""
    if len(local) != len(PLM_BIASES):
        raise InvalidInputError(f"a PLM needs exactly {len(PLM_BIASES)} local models, got {len(local)}")
    dts = {round(f.dt, 12) for f in local}
    if len(dts) != 1:
        raise InvalidInputError(f"local models have different sample times: {sorted(dts)}")
    params = [float(stroke)]
    for f in local:
        params.extend([f.n1, f.n2, f.d1, f.d2, f.u0, f.y0])
    info = {
        "dt": local[0].dt,
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
    return StepModel(kernels.KIND_PLM, np.array(params), name=name, info=info)


def local_from_params(params: np.ndarray, dt: float) -> list[LinearFit]:
    """The five local models packed in ``KIND_PLM`` parameters (inverse of :func:`blend`)."""
    p = np.asarray(params, dtype=float)
    if p.size != kernels.PLM_SIZE:
        raise InvalidInputError(f"PLM parameters must have {kernels.PLM_SIZE} values, got {p.size}")
    out = []
    for i in range(len(PLM_BIASES)):
        o = 1 + kernels.PLM_LOCAL_SIZE * i
        n1, n2, d1, d2, u0, y0 = p[o : o + kernels.PLM_LOCAL_SIZE].tolist()
        out.append(LinearFit(n1, n2, d1, d2, u0, y0, dt))
    return out
