"""Robustness of trained agents: the same fixed tables under every scenario of the suite.

The paper validates once, on the nominal plant at a unit step, and lists
robustness as future work. A demanding user wants to know how a policy trained
on a surrogate fares on a rig: other set-points, a load, drifted parameters, a
noisy and quantised sensor, a late actuator (:mod:`msd_bench.core.evaluation.scenarios`).
The greedy tables are held fixed (no retraining) and scored exactly like the
nominal validation, on the *true* position.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from msd_bench.core.evaluation.closed_loop import (
    Acts,
    Conditions,
    SupervisedRuns,
    nominal,
    supervised_runs,
)
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.risk import RunRisk, trace_risk
from msd_bench.core.evaluation.risk_table import summarise
from msd_bench.core.evaluation.scenarios import Scenario, noise_seed, suite
from msd_bench.core.evaluation.stats import wilson
from msd_bench.core.physics.kernels import Kernel
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.rig import lag_samples
from msd_bench.core.safety.supervisor import Limits

FloatArray = NDArray[np.float64]


def conditions(sc: Scenario, dt: float) -> Conditions:
    """The compiled loop's view of a scenario."""
    return Conditions(float(sc.setpoint), float(sc.quant), int(sc.delay), float(sc.disturbance),
                      round(sc.disturbance_time / dt), float(sc.friction), lag_samples(sc.lag, dt))


def sensor_noise(sc: Scenario, seeds: Sequence[int], steps: int) -> FloatArray:
    """Each run's measurement noise: a stream per (learning seed, scenario id), so every cell reproduces."""
    noise = np.zeros((len(seeds), steps))
    if sc.noise > 0.0:
        for j, seed in enumerate(seeds):
            noise[j] = sc.noise * np.random.default_rng(noise_seed(int(seed), sc.id)).standard_normal(steps)
    return noise


class Facts(Protocol):
    """What robustness asks of a policy's facts (:class:`msd_bench.designs.protocol.Facts`)."""

    def nominal_rows(self, members: Sequence[int]) -> int:
        """Runs of a nominal validation."""

    def noise_draws(self, members: Sequence[int], seeds: Sequence[int], noisy: bool) -> list[int]:
        """The noise streams it runs under a scenario."""

    def member_of_runs(self, runs: int) -> list[int]:
        """The member that makes each run."""


class RollsOut(Protocol):
    """What robustness needs of a policy (:class:`msd_bench.designs.protocol.Policy` is one)."""

    @property
    def members(self) -> tuple[int, ...]:
        """Learning seeds of its members, in rollout order."""

    @property
    def facts(self) -> Facts:
        """Its facts."""

    def rollout(self, plant: Kernel, cond: Conditions, noise: FloatArray) -> tuple[FloatArray, FloatArray]:
        """True positions and commands, one run per row of ``noise``."""

    def controller(self, member: int, target: float) -> Acts:
        """Member ``member``'s stepwise controller tracking ``target`` (the node's form)."""


def draws(policy: RollsOut, sc: Scenario, seeds: Sequence[int]) -> list[int]:
    """The noise streams a policy runs under ``sc``: one per member; a deterministic policy one per
    seed where the scenario draws sensor noise and a single run otherwise (copies are not n)."""
    return policy.facts.noise_draws(policy.members, seeds, sc.noise > 0.0)


def policy_rollouts(policy: RollsOut, nominal: PlantParams, sc: Scenario, seeds: Sequence[int],
                    steps: int) -> tuple[FloatArray, FloatArray]:
    """True positions and commands of a policy under ``sc`` (runs as :func:`draws` says)."""
    plant = sc.plant(nominal)
    noise = sensor_noise(sc, draws(policy, sc, seeds), steps)
    return policy.rollout(plant_model(plant).kernel, conditions(sc, plant.dt), noise)


def supervised_rollouts(policy: RollsOut, nominal: PlantParams, sc: Scenario, seeds: Sequence[int],
                        steps: int, lim: Limits) -> SupervisedRuns:
    """The runs of :func:`policy_rollouts` behind the supervisor (``lim``: its limits on the nominal
    plant, which is all a supervisor on a rig is told), through each member's stepwise controller."""
    plant = sc.plant(nominal)
    runs = draws(policy, sc, seeds)
    noise = sensor_noise(sc, runs, steps)
    ctls = [policy.controller(m, float(sc.setpoint)) for m in policy.facts.member_of_runs(len(runs))]
    return supervised_runs(ctls, plant_model(plant).kernel, conditions(sc, plant.dt), noise, lim)


def validate_policy(policy: RollsOut, nominal: PlantParams, sc: Scenario, seeds: Sequence[int], steps: int,
                    lim: Limits | None = None) -> tuple[FloatArray, list[RunRisk]]:
    """True positions of every run under ``sc`` and each run's risk; behind the supervisor when
    ``lim`` is given (risk then counts its overrides and aborts), as the policy rolls out otherwise."""
    if lim is None:
        xs, _ = policy_rollouts(policy, nominal, sc, seeds, steps)
        return xs, [trace_risk(x, nominal) for x in xs]
    r = supervised_rollouts(policy, nominal, sc, seeds, steps, lim)
    return r.x, [trace_risk(r.x[j], nominal, lim, r.reason[j], int(r.aborts[j])) for j in range(r.x.shape[0])]


def nominal_validation(policy: RollsOut, plant: PlantParams, target: float, steps: int,
                       lim: Limits | None = None) -> tuple[FloatArray, list[RunRisk]]:
    """Table 1's validation: each member (a deterministic policy: its one) from rest at ``target``,
    with each run's risk; behind the supervisor when ``lim`` is given."""
    rows = policy.facts.nominal_rows(policy.members)
    if lim is None:
        xs, _ = policy.rollout(plant_model(plant).kernel, nominal(target), np.zeros((rows, int(steps))))
        return xs, [trace_risk(x, plant) for x in xs]
    r = supervised_runs([policy.controller(m, float(target)) for m in policy.facts.member_of_runs(rows)],
                        plant_model(plant).kernel,
                        nominal(target), np.zeros((rows, int(steps))), lim)
    return r.x, [trace_risk(r.x[j], plant, lim, r.reason[j], int(r.aborts[j])) for j in range(rows)]


def evaluate_policy(policy: RollsOut, nominal: PlantParams, seeds: Sequence[int],
                    scenarios: Sequence[Scenario] | None = None, steps: int = 3000,
                    window: int = 500, lim: Limits | None = None) -> dict[str, dict[str, Any]]:
    """Per scenario id, the cell of :func:`cell` for any policy; ``seeds`` name a deterministic
    policy's noise draws (a stochastic one draws per member); ``lim``: behind the supervisor."""
    out: dict[str, dict[str, Any]] = {}
    for sc in scenarios if scenarios is not None else suite():
        xs, risks = validate_policy(policy, nominal, sc, seeds, steps, lim)
        m = [compute(x, sc.setpoint, nominal.dt, window) for x in xs]
        out[sc.id] = cell([r.sse for r in m], [r.mae for r in m], [r.as_dict() for r in risks])
    return out


def cell(sse: Sequence[float], mae: Sequence[float],
         risks: Sequence[Mapping[str, Any]] | None = None) -> dict[str, Any]:
    """One scenario cell from every run's SSE (%) and MAE (m) and, where recorded, risk
    (:meth:`RunRisk.as_dict` per run, kept whole, and their :func:`summarise` beside them)."""
    wins = int(sum(s < SUCCESS_SSE for s in sse))
    out: dict[str, Any] = {"n": len(sse), "n_success": wins, "ci95": list(wilson(wins, len(sse))),
                           "median_sse": float(np.median(sse)), "median_mae": float(np.median(mae)),
                           "sse": list(sse), "mae": list(mae)}
    if risks is not None and len(risks) == len(sse):
        out["risk"] = summarise(risks)
        out["risks"] = [dict(r) for r in risks]
    return out


def merge(parts: Sequence[dict[str, dict[str, Any]]]) -> dict[str, dict[str, Any]]:
    """Cells of several groups of tables (e.g. one per identification seed) pooled per scenario."""
    return {sid: cell([s for p in parts for s in p[sid]["sse"]], [a for p in parts for a in p[sid]["mae"]],
                      _pooled_risks([p[sid] for p in parts]))
            for sid in parts[0]}


def _pooled_risks(cells: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]] | None:
    """Every part's per-run risk records, or None unless every part carries them."""
    if not all("risks" in c for c in cells):
        return None
    return [r for c in cells for r in c["risks"]]
