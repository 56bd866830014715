"""Robustness of trained agents: the same fixed tables on perturbed plants and other set-points.

The paper validates once, on the nominal plant at a unit step, and lists
"robustness to unmodeled friction changes" as future work. A demanding user
wants to know how a policy trained on a surrogate fares when the rig is not
the plant it was identified from. Each scenario scales plant parameters
and/or changes the set-point; the greedy tables are held fixed (no retraining)
and scored exactly like the nominal validation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.errors import ConfigError
from msd_bench.core.metrics import compute
from msd_bench.core.model import plant_model
from msd_bench.core.plant import PlantParams
from msd_bench.core.qconfig import QConfig
from msd_bench.core.qtrain import greedy_rollouts
from msd_bench.core.results import SUCCESS_SSE

FloatArray = NDArray[np.float64]
_SCALABLE = {f.name for f in fields(PlantParams)} - {"dt", "L", "F"}


@dataclass(frozen=True)
class Scenario:
    """One validation condition."""

    name: str
    """Label in the report."""
    scale: Mapping[str, float] = field(default_factory=dict)
    """Plant parameter multipliers, e.g. ``{"m": 1.2}`` for 20 % more mass."""
    target: float = 1.0
    """Set-point, m."""

    def __post_init__(self) -> None:
        bad = [k for k in self.scale if k not in _SCALABLE]
        if bad:
            raise ConfigError(
                f"scenario {self.name!r}: cannot scale {bad[0]!r}; choose from {sorted(_SCALABLE)}")
        if not all(np.isfinite(v) and v > 0 for v in self.scale.values()):
            raise ConfigError(f"scenario {self.name!r}: multipliers must be finite and > 0")
        if not (np.isfinite(self.target) and self.target != 0.0):
            raise ConfigError(f"scenario {self.name!r}: set-point must be finite and non-zero")

    def plant(self, nominal: PlantParams) -> PlantParams:
        """The perturbed plant."""
        return replace(nominal, **{k: getattr(nominal, k) * v for k, v in self.scale.items()})


SCENARIOS = (
    Scenario("nominal"),
    Scenario("mass +20 %", {"m": 1.2}),
    Scenario("damping -50 %", {"c": 0.5}),
    Scenario("damping +50 %", {"c": 1.5}),
    Scenario("springs +15 %", {"k": 1.15, "h": 1.15}),
    Scenario("set-point 0.5 m", target=0.5),
    Scenario("set-point 1.5 m", target=1.5),
)
"""Default conditions: model-plant mismatch the paper's §6 names, and set-points off the trained one."""


def evaluate(q_tables: FloatArray, cfg: QConfig, nominal: PlantParams,
             scenarios: Sequence[Scenario] = SCENARIOS, steps: int = 3000,
             window: int = 500) -> dict[str, dict[str, Any]]:
    """Per scenario: n, successes, success rate, median and per-table SSE (%)."""
    out: dict[str, dict[str, Any]] = {}
    for sc in scenarios:
        plant = sc.plant(nominal)
        xs, _ = greedy_rollouts(plant_model(plant), q_tables, cfg, sc.target, steps)
        sse = [compute(x, sc.target, plant.dt, window).sse for x in xs]
        wins = int(sum(s < SUCCESS_SSE for s in sse))
        out[sc.name] = {"n": len(sse), "n_success": wins, "success_rate": wins / len(sse),
                        "median_sse": float(np.median(sse)), "sse": sse,
                        "scale": dict(sc.scale), "target": sc.target}
    return out
