"""``supervisor_check.py good-kinds``: the good kinds validated with the supervisor off and on, paired.

Issue 23's done-when: the good kinds (the robust agent, the classical
baselines) lose at most one run of n with the supervisor on the default tables,
and at least 99 % of their good nominal runs see no override. Each kind is made
exactly as ``msd-bench paper`` makes it (the same records, identification,
settings and learning seeds), then every policy is validated twice on the same
noise streams: as the tables do (its own rollout) and behind the supervisor
(``robustness.validate_policy`` with the limits, through its stepwise
controller: the node's path). A run is *lost* when it succeeds without the
supervisor and fails with it.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import Any

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, make_records, settings
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.risk import RunRisk
from msd_bench.core.evaluation.risk_table import summarise
from msd_bench.core.evaluation.scenarios import Scenario
from msd_bench.core.safety.supervisor import Limits, SupervisorOptions
from msd_bench.designs import Policy

GOOD_KINDS = ("plm+robust", "glm+pid", "greybox+lqr")
"""The good kinds of the done-when: the robust agent and the classical baselines."""


def _side(policy: Policy, cfg: RunConfig, sc: Scenario, seeds: Sequence[int],
          lim: Limits | None) -> tuple[list[bool], list[RunRisk]]:
    """Each run's success and risk under ``sc`` (behind the supervisor when ``lim`` is given)."""
    xs, risks = robustness.validate_policy(policy, cfg.plant, sc, seeds, cfg.validation_steps, lim)
    wins = [compute(x, sc.setpoint, cfg.plant.dt, cfg.window).sse < SUCCESS_SSE for x in xs]
    return wins, risks


def paired(policy: Policy, cfg: RunConfig, sc: Scenario, seeds: Sequence[int], lim: Limits) -> dict[str, Any]:
    """One cell: successes off and on, the runs lost and gained, and each side's risk summary."""
    off, r_off = _side(policy, cfg, sc, seeds, None)
    on, r_on = _side(policy, cfg, sc, seeds, lim)
    good = [r for w, r in zip(off, r_on, strict=True) if w]
    return {"n": len(off), "success_off": sum(off), "success_on": sum(on),
            "lost": sum(a and not b for a, b in zip(off, on, strict=True)),
            "gained": sum(b and not a for a, b in zip(off, on, strict=True)),
            "good_runs": len(good), "good_runs_overridden": sum(r.override_share > 0 for r in good),
            "risks_off": [r.as_dict() for r in r_off], "risks_on": [r.as_dict() for r in r_on]}


def _add(total: dict[str, Any], c: dict[str, Any]) -> None:
    for key in ("n", "success_off", "success_on", "lost", "gained", "good_runs", "good_runs_overridden"):
        total[key] = total.get(key, 0) + c[key]


def good_kinds_check(args: argparse.Namespace, opts: SupervisorOptions, kinds: Sequence[str],
                     start: float, prov: dict[str, Any]) -> dict[str, Any]:
    """The document (``prov``: its provenance): per kind, per scenario (nominal = Table 1's run) the
    paired cell, and totals."""
    cfg = RunConfig(seeds=args.seeds, id_seeds=args.id_seeds, agents=tuple(kinds))
    lim = opts.limits(cfg.plant)
    suite = cfg.scenario_suite()
    cells: dict[str, dict[str, dict[str, Any]]] = {k: {} for k in kinds}
    for i, id_seed in enumerate(cfg.id_seed_values()):
        records = make_records(cfg, id_seed)
        models, _ = identify_surrogates(records, cfg.surrogates_needed(), id_seed, cfg.plant, cfg.nlarx_scale)
        seeds = cfg.learning_seeds(i)
        for kind in kinds:
            policy = designs.make(kind, models[agent_kind(kind).surrogate], settings(cfg), seeds)
            for sc in suite:
                c = paired(policy, cfg, sc, seeds, lim)
                _merge(cells[kind], sc.id, c)
            print(f"id seed {id_seed} {kind:14s} nominal: {_said(cells[kind]['nominal'])}", flush=True)
    totals = {}
    for kind in kinds:
        cells[kind] = {sid: _finish(c) for sid, c in cells[kind].items()}
        t: dict[str, Any] = {}
        for c in cells[kind].values():
            _add(t, c)
        totals[kind] = {"all_scenarios": t, "nominal": {k: v for k, v in cells[kind]["nominal"].items()
                                                        if not k.startswith("risk")}}
        print(f"{kind:14s} all scenarios: {_said(t)}")
    return {**prov, "seconds": round(time.monotonic() - start, 1), "run": {
        "seeds": cfg.seeds, "id_seeds": cfg.id_seeds, "validation_steps": cfg.validation_steps,
        "window": cfg.window, "episodes": cfg.episodes, "preset": cfg.preset},
        "limits": lim._asdict(), "options": dict(vars(opts)), "scenarios": [s.id for s in suite],
        "kinds": list(kinds), "totals": totals, "cells": cells}


def _merge(by_id: dict[str, dict[str, Any]], sid: str, c: dict[str, Any]) -> None:
    """Pool an identification seed's cell into the kind's: counts add, per-run risks concatenate
    (summed up by :func:`_finish`)."""
    if sid not in by_id:
        by_id[sid] = c
        return
    _add(by_id[sid], c)
    for side in ("risks_off", "risks_on"):
        by_id[sid][side] += c[side]


def _finish(c: dict[str, Any]) -> dict[str, Any]:
    """A pooled cell with each side's per-run risks summed up (``core.evaluation.risk_table.summarise``)."""
    out = {k: v for k, v in c.items() if not k.startswith("risks_")}
    return {**out, "risk_off": summarise(c["risks_off"]), "risk_on": summarise(c["risks_on"])}


def _said(c: dict[str, Any]) -> str:
    return (f"off {c['success_off']}/{c['n']}, on {c['success_on']}/{c['n']}, lost {c['lost']}, "
            f"good runs overridden {c['good_runs_overridden']}/{c['good_runs']}")
