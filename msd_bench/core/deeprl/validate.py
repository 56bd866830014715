"""Score trained networks on the plant: nominal rows and the scenario suite, as the Q-learners are.

The same scenarios, noise streams (:func:`msd_bench.core.evaluation.robustness.sensor_noise`)
and cells (:func:`msd_bench.core.evaluation.robustness.cell`) as the tabular agents, so a
deep-RL row sits beside them in Table 1 and the robustness table.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.deeprl.mlp import Net
from msd_bench.core.deeprl.rollout import greedy_under, y_bound
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.robustness import cell, conditions, sensor_noise
from msd_bench.core.evaluation.scenarios import Scenario, suite
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams

FloatArray = NDArray[np.float64]


def rollouts(net: Net, nominal: PlantParams, sc: Scenario, seeds: Sequence[int],
             steps: int) -> tuple[FloatArray, FloatArray]:
    """True positions and commands of every policy's greedy run under ``sc`` (one seed per policy)."""
    if len(seeds) != net.w1.shape[0]:
        raise InvalidInputError(f"need one learning seed per policy, got {len(seeds)} for {net.w1.shape[0]}")
    plant = sc.plant(nominal)
    bound = y_bound(0.5 * plant.L, sc.noise, sc.quant)
    return greedy_under(plant_model(plant).kernel, net, QConfig().actions(), conditions(sc, plant.dt),
                        sensor_noise(sc, seeds, steps), bound)


def evaluate(net: Net, nominal: PlantParams, seeds: Sequence[int],
             scenarios: Sequence[Scenario] | None = None, steps: int = 3000,
             window: int = 500) -> dict[str, dict[str, Any]]:
    """Per scenario id: n, successes, the Wilson interval, median SSE and MAE, every SSE and MAE."""
    out: dict[str, dict[str, Any]] = {}
    for sc in scenarios if scenarios is not None else suite():
        xs, _ = rollouts(net, nominal, sc, seeds, steps)
        m = [compute(x, sc.setpoint, nominal.dt, window) for x in xs]
        out[sc.id] = cell([r.sse for r in m], [r.mae for r in m])
    return out


SETPOINT_IDS = ("nominal", "setpoint=-1.5", "setpoint=-0.5", "setpoint=0.5", "setpoint=1.5")
"""The set-point cells of the standard suite: what 'held k of 5 set-points' counts."""


def setpoints_held(cells: dict[str, dict[str, Any]]) -> int:
    """Set-point cells (of :data:`SETPOINT_IDS`) where every policy succeeded."""
    return sum(int(cells[s]["n_success"] == cells[s]["n"]) for s in SETPOINT_IDS if s in cells)
