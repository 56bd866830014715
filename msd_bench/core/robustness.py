"""Robustness of trained agents: the same fixed tables under every scenario of the suite.

The paper validates once, on the nominal plant at a unit step, and lists
robustness as future work. A demanding user wants to know how a policy trained
on a surrogate fares on a rig: other set-points, a load, drifted parameters, a
noisy and quantised sensor, a late actuator (:mod:`msd_bench.core.scenarios`).
The greedy tables are held fixed (no retraining) and scored exactly like the
nominal validation, on the *true* position.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.closed_loop import Conditions, greedy_under
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.metrics import compute
from msd_bench.core.model import StepModel, plant_model
from msd_bench.core.plant import PlantParams
from msd_bench.core.qconfig import QConfig, packed
from msd_bench.core.results import SUCCESS_SSE
from msd_bench.core.scenarios import Scenario, noise_seed, suite
from msd_bench.core.stats import wilson

FloatArray = NDArray[np.float64]


def conditions(sc: Scenario, dt: float) -> Conditions:
    """The compiled loop's view of a scenario."""
    return Conditions(float(sc.setpoint), float(sc.quant), int(sc.delay), float(sc.disturbance),
                      round(sc.disturbance_time / dt), float(sc.friction))


def sensor_noise(sc: Scenario, seeds: Sequence[int], steps: int) -> FloatArray:
    """Each run's measurement noise: a stream per (learning seed, scenario id), so every cell reproduces."""
    noise = np.zeros((len(seeds), steps))
    if sc.noise > 0.0:
        for j, seed in enumerate(seeds):
            noise[j] = sc.noise * np.random.default_rng(noise_seed(int(seed), sc.id)).standard_normal(steps)
    return noise


def rollouts(q_tables: FloatArray, cfg: QConfig, nominal: PlantParams, sc: Scenario, seeds: Sequence[int],
             steps: int, observer: StepModel | None = None) -> tuple[FloatArray, FloatArray]:
    """True positions and commands of every table's greedy run under ``sc``.

    ``observer`` is the model the agent trained on (its ``model`` observer predicts with it);
    by default the nominal plant.
    """
    q = np.ascontiguousarray(q_tables, dtype=np.float64)
    if q.ndim != 3 or len(seeds) != q.shape[0]:
        raise InvalidInputError(f"need one learning seed per Q-table, got {len(seeds)} for {q.shape[0]}")
    plant = sc.plant(nominal)
    obs = (observer or plant_model(nominal)).kernel
    return greedy_under(plant_model(plant).kernel, packed(cfg), q, conditions(sc, plant.dt),
                        sensor_noise(sc, seeds, steps), obs)


def evaluate(q_tables: FloatArray, cfg: QConfig, nominal: PlantParams, seeds: Sequence[int],
             scenarios: Sequence[Scenario] | None = None, steps: int = 3000,
             window: int = 500, observer: StepModel | None = None) -> dict[str, dict[str, Any]]:
    """Per scenario id: n, successes, the Wilson interval, median SSE and MAE, and every SSE and MAE."""
    out: dict[str, dict[str, Any]] = {}
    for sc in scenarios if scenarios is not None else suite():
        xs, _ = rollouts(q_tables, cfg, nominal, sc, seeds, steps, observer)
        m = [compute(x, sc.setpoint, nominal.dt, window) for x in xs]
        out[sc.id] = cell([r.sse for r in m], [r.mae for r in m])
    return out


def cell(sse: Sequence[float], mae: Sequence[float]) -> dict[str, Any]:
    """One scenario cell from every run's SSE (%) and MAE (m)."""
    wins = int(sum(s < SUCCESS_SSE for s in sse))
    return {"n": len(sse), "n_success": wins, "ci95": list(wilson(wins, len(sse))),
            "median_sse": float(np.median(sse)), "median_mae": float(np.median(mae)),
            "sse": list(sse), "mae": list(mae)}


def merge(parts: Sequence[dict[str, dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """Cells of several groups of tables (e.g. one per identification seed) pooled per scenario."""
    return {sid: cell([s for p in parts for s in p[sid]["sse"]], [a for p in parts for a in p[sid]["mae"]])
            for sid in parts[0]}
