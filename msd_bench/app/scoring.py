"""Scoring: a closed-loop run becomes a metric row, rows and fits become a Table-1 row.

One definition for the in-process run, the agent node (which scores each
validation run it drives on the plant topics) and bench.py's report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.app.agents import PLANT, agent_kind
from msd_bench.core.identify import FitReport
from msd_bench.core.metrics import compute
from msd_bench.core.results import AgentResult

FloatArray = NDArray[np.float64]


def metric_row(x: FloatArray, target: float, dt: float, window: int) -> dict[str, float]:
    """Paper §5 metrics of one closed-loop position trace (``ts`` is the 2 % settling time)."""
    m = compute(np.asarray(x, dtype=np.float64), target, dt, window)
    return {"mae": m.mae, "std": m.std, "po": m.po, "ts": m.ts2, "ts5": m.ts5, "sse": m.sse}


def fit_entry(id_seed: int, report: FitReport) -> dict[str, Any]:
    """One identification seed's fits for ``fit_by_id_seed``: simulation (estimated start), one-step,
    against the noise-free truth where it is known, and from the two raw samples."""
    return {"id_seed": int(id_seed), **report.as_row()}


def agent_result(kind: str, per_seed: Sequence[Mapping[str, Any]], fits: Mapping[int, FitReport],
                 real_interactions: int, notes: Sequence[str] = ()) -> AgentResult:
    """The Table-1 row of an agent kind from its per-seed rows and its surrogate's fits per id seed."""
    k = agent_kind(kind)
    fit_sim = fit_one = None
    n_id = 0
    by_id: list[dict[str, Any]] = []
    if k.surrogate != PLANT and fits:
        by_id = [fit_entry(i, fits[i]) for i in sorted(fits)]
        fit_sim = float(np.mean([e["fit_sim_percent"] for e in by_id]))
        fit_one = float(np.mean([e["fit_one_step_percent"] for e in by_id]))
        n_id = int(fits[min(fits)].n_identification)
    return AgentResult(
        kind=kind, label=k.label, surrogate=k.surrogate, agent=k.agent, identification_samples=n_id,
        fit_sim=fit_sim, fit_one_step=fit_one, per_seed=tuple(per_seed),
        real_interactions=int(real_interactions), notes="; ".join(n for n in notes if n),
        fit_by_id_seed=tuple(by_id),
    )
