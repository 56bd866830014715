"""Table-1 rows: one agent kind validated over many seeds, summarised honestly.

The paper reports one deterministic run per agent; we report, for each agent
kind, every seed's metrics plus their distribution and the success rate.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from msd_bench.core.evaluation.risk_table import summarise
from msd_bench.core.evaluation.stats import Summary, summarize

METRIC_KEYS = ("mae", "std", "po", "ts", "ts5", "sse")
"""Per-seed metrics summarised in the table, in column order."""

SUCCESS_SSE = 5.0
"""An agent succeeds when its steady-state error is below this many percent."""


@dataclass(frozen=True)
class AgentResult:
    """One row of Table 1: an agent kind (surrogate × state design) over seeds."""

    kind: str
    """Machine name, e.g. ``plm`` or ``plm+improved`` (see the README's agent kinds)."""
    label: str
    """Human label for the table, e.g. ``PLM (paper agent)``."""
    surrogate: str
    """What the agent trained on: ``glm``, ``plm``, ``nlarx-paper``, ``nlarx-improved``, ``plant``."""
    agent: str
    """State design: ``paper`` (§4 as printed) or ``improved`` (our extension)."""
    identification_samples: int
    """Samples used to identify the surrogate (0 for agents that learn on the plant)."""
    fit_sim: float | None
    """Free-run simulation fit % of the surrogate on a validation record (None for the plant)."""
    fit_one_step: float | None
    """One-step prediction fit % on the same record (None for the plant)."""
    per_seed: tuple[Mapping[str, Any], ...]
    """One mapping per seed: ``seed``, ``id_seed``, the :data:`METRIC_KEYS`, ``success`` and, where
    the run recorded it, ``risk`` (:meth:`msd_bench.core.evaluation.risk.RunRisk.as_dict`)."""
    real_interactions: int = 0
    """Steps taken on the true plant during training (Dyna-Q and on-plant baselines)."""
    notes: str = ""
    """Anything a reader must know to interpret the row (reduced budgets, ...)."""
    fit_by_id_seed: tuple[Mapping[str, Any], ...] = field(default=())
    """Fits of every identification seed when several were run."""

    @property
    def n(self) -> int:
        """Number of seeds validated."""
        return len(self.per_seed)

    @property
    def n_success(self) -> int:
        """Seeds whose SSE is below :data:`SUCCESS_SSE`."""
        return sum(bool(s["success"]) for s in self.per_seed)

    @property
    def success_rate(self) -> float:
        """Fraction of seeds that succeeded."""
        return self.n_success / self.n if self.n else float("nan")

    def risk(self) -> dict[str, Any] | None:
        """The runs' risk summed up (:func:`msd_bench.core.evaluation.risk_table.summarise`); None
        without records."""
        return summarise(s.get("risk") for s in self.per_seed)

    def summary(self) -> dict[str, Summary]:
        """Distribution of each metric over the seeds."""
        return {key: summarize(_number(s[key]) for s in self.per_seed) for key in METRIC_KEYS}


def _number(value: Any) -> float:
    """A metric value; None (N/A as stored in JSON) becomes NaN."""
    return float("nan") if value is None else float(value)


def per_seed_row(seed: int, id_seed: int, metrics: Mapping[str, Any]) -> dict[str, Any]:
    """A per-seed record with the success flag derived from the SSE."""
    row: dict[str, Any] = {"seed": int(seed), "id_seed": int(id_seed)}
    row.update({k: _number(metrics[k]) for k in METRIC_KEYS})
    row["success"] = bool(row["sse"] < SUCCESS_SSE)
    if metrics.get("risk") is not None:
        row["risk"] = dict(metrics["risk"])
    return row


def by_kind(results: Sequence[AgentResult]) -> dict[str, AgentResult]:
    """Index rows by their kind (kinds are unique within a table)."""
    return {r.kind: r for r in results}
