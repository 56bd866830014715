"""Scoring: a closed-loop run becomes a metric row, rows and fits become a Table-1 row.

One definition for the in-process run, the agent node (which scores each
validation run it drives on the plant topics) and bench.py's report; and one
function, :func:`assemble`, that makes a kind's Table-1 row and robustness
cells from its trained-policy records, whichever engine produced them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import AgentResult
from msd_bench.core.evaluation.scenarios import Scenario
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.safety.supervisor import Limits
from msd_bench.designs import Policy, Settings
from msd_bench.designs.kinds import made_on_plant

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
    if not made_on_plant(kind) and fits:
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


@dataclass(frozen=True)
class PolicyRecord:
    """A trained policy and its nominal validation: what both engines produce per kind and model."""

    policy: Policy
    """The policy (in memory, or loaded from its artifact)."""
    id_seed: int
    """Identification seed of the model it was made on."""
    seeds: Sequence[int]
    """The learning seeds the run gave it (a deterministic policy's noise draws)."""
    per_seed: Sequence[Mapping[str, Any]]
    """One row per validated member (:func:`msd_bench.core.evaluation.results.per_seed_row`)."""
    fit: FitReport | None
    """Its surrogate's validation fit (None on the plant)."""


@dataclass(frozen=True)
class Validation:
    """How robustness is measured: the nominal plant, the scenarios (None: none), run length, window."""

    plant: PlantParams
    scenarios: Sequence[Scenario] | None
    steps: int
    window: int
    limits: Limits | None = None
    """The supervisor's limits when runs are validated behind it (None: unsupervised)."""

    @classmethod
    def of(cls, cfg: RunConfig, scenarios: bool = True) -> Validation:
        """The run's validation (``scenarios=False``: Table 1 only)."""
        return cls(cfg.plant, cfg.scenario_suite() if scenarios else None, cfg.validation_steps, cfg.window,
                   cfg.supervisor_limits)


Cells = dict[str, dict[str, Any]]
"""Robustness cells of one kind: scenario id → its cell (:mod:`msd_bench.core.evaluation.robustness`)."""


def record_cells(policy: Policy, seeds: Sequence[int], val: Validation) -> Cells:
    """The robustness cells of one trained policy under the run's scenarios (none without a suite).

    Why apart from :func:`assemble`: a task of ``msd-bench paper`` evaluates its own policies where
    they were made (in a worker) and hands the cells over; they are merged by :func:`assemble` all
    the same, so robustness is evaluated and merged in one place whoever computed it.
    """
    if val.scenarios is None:
        return {}
    return robustness.evaluate_policy(policy, val.plant, seeds, val.scenarios, val.steps, val.window,
                                      val.limits)


def assemble(kind: str, records: Sequence[PolicyRecord], settings: Settings, val: Validation,
             notes: Sequence[str] = (), cells: Sequence[Cells] | None = None) -> tuple[AgentResult, Cells]:
    """Table-1 row and robustness cells of ``kind`` from its records (one per identified model).

    Why one function: the in-process run and bench.py's report used to build
    these twice; both now hand over the same records (a policy and its nominal
    validation), so a row means the same whichever engine ran it. ``cells``: each
    record's :func:`record_cells`, if already evaluated (paper's tasks); else evaluated here.
    """
    rows = [row for r in records for row in r.per_seed]
    fits = {r.id_seed: r.fit for r in records if r.fit is not None}
    facts = [r.policy.facts for r in records]
    said = [designs.budget_note(kind, settings), *notes]
    said += [facts[0].table_note()] if facts else []
    result = agent_result(kind, rows, fits, sum(f.real_interactions for f in facts), said)
    if val.scenarios is None or not records:
        return result, {}
    if cells is None:
        cells = [record_cells(r.policy, r.seeds, val) for r in records]
    return result, robustness.merge(list(cells))
