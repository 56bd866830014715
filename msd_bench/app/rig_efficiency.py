"""The data-efficiency curve on a population of rigs: success against the real samples each route used.

:mod:`msd_bench.app.efficiency` draws the curve on the ideal plant. Here every
point is the whole method on each rig of a population (:func:`msd_bench.app.rigs.rig_task`):
the paper's plan at one record length played through the rig (rest without
reset before every experiment), every model kind identified from those records
only, each agent made on its surrogate (the robust agent told the drive the
broad record shows) and validated through the rig at the nominal set-point.

What a point charges, per rig, is what a rig owner would spend
(:func:`msd_bench.app.rig_cost.spent`, the bill ``msd-bench rigs --refine`` uses
too): the kind's training records with their settle segments, the broad
validation record every kind is scored on, a refined route's tries and fresh
run, and the samples the rig took to come to rest before each of those (a rig
without reset waits for its mass; the ideal plant's curve has no such cost).
The x of a point is the mean over its rigs (rests
differ from rig to rig; the JSON keeps the spread), its rate pools every
(rig, learning seed) run, and its interval is the bootstrap over rigs
(:mod:`msd_bench.core.rigs.rig_stats`: runs on one rig share its records), the
Wilson interval beside it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from msd_bench.app.agents import agent_kind
from msd_bench.app.efficiency import EPISODES, RECORD_SAMPLES, settle_for, validation_samples
from msd_bench.app.executor import task_name
from msd_bench.app.rig_cost import ACCOUNTING
from msd_bench.app.rig_refine import base_kind
from msd_bench.app.rig_scores import rig_settings
from msd_bench.app.rigs import RigsConfig, kind_label, rig_success, rig_task, validate_on_rig
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.rigs import families
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_stats import rate_summary
from msd_bench.designs import kinds

FAMILIES = tuple(families.FAMILIES)
"""Rig families a curve can be drawn on: every family of :mod:`msd_bench.core.rigs.families`."""


@dataclass(frozen=True)
class RigEfficiencyConfig:
    """What the curve on rigs sweeps: every record length on every rig of ``rigs``."""

    rigs: RigsConfig
    """The population run each point repeats (agents, learning seeds, rig set, refinement rounds); its
    record lengths, settle segments and scenarios are the sweep's: each point validates at the nominal
    set-point."""
    record_samples: tuple[int, ...] = RECORD_SAMPLES
    """Samples per identification record at each point."""
    family: str = "default"
    """The rig family (:data:`FAMILIES`)."""
    plant_agents: tuple[str, ...] = ()
    """On-plant learners trained on each rig itself (``plant``, ``dyna-q``, ...), one line each."""
    episodes: tuple[int, ...] = EPISODES
    """Their training budgets, in episodes: every training step is a real sample of the rig."""

    def __post_init__(self) -> None:
        if self.rigs.ceiling:
            raise ConfigError("--ceiling is not a route of the curve (it spends no real samples to learn)")
        families.in_process(self.family, curve=True)  # an unknown or held family: one line
        if self.rigs.family != self.family:
            raise ConfigError(f"the population run draws family {self.rigs.family!r}, the curve "
                              f"{self.family!r}: give the same to both")
        on_model = kinds.split_by_model(self.plant_agents)[0]
        if on_model:
            raise ConfigError(f"on-plant learners must learn on the plant, not {', '.join(on_model)}")
        if not self.episodes or min(self.episodes) < 1:
            raise ConfigError("budgets must be >= 1 episode")
        if not self.record_samples or min(self.record_samples) < 100:
            raise ConfigError("record samples must be >= 100")
        if len(set(self.record_samples)) != len(self.record_samples):
            raise ConfigError(f"record samples repeat: {list(self.record_samples)}")

    def at_length(self, n: int) -> RigsConfig:
        """The population run of the point at record length ``n`` (nominal validation only)."""
        run = replace(self.rigs.run, samples=n, val_samples=validation_samples(n))
        return replace(self.rigs, run=run, settle=settle_for(n), scenarios=())


def tasks(cfg: RigEfficiencyConfig) -> list[tuple[str, int, int]]:
    """``(task id, record length, rig seed)``: every rig at every length, shortest records first (none
    without a surrogate kind: a sweep of on-plant learners alone plays no records)."""
    if not cfg.rigs.run.agents:
        return []
    return [(f"n{n}-rig{seed}", n, seed) for n in cfg.record_samples for seed in cfg.rigs.rig_seeds()]


def plant_tasks(cfg: RigEfficiencyConfig) -> list[tuple[str, int, str, int]]:
    """``(task id, episodes, kind, rig seed)``: every on-plant learner at every budget on every rig."""
    return [(f"plant-e{e}-{task_name(kind)}-rig{seed}", e, kind, seed)
            for e in cfg.episodes for kind in cfg.plant_agents for seed in cfg.rigs.rig_seeds()]


def rig_plant_point(cfg: RigEfficiencyConfig, episodes: int, kind: str, seed: int) -> dict[str, Any]:
    """An on-plant learner trained on rig ``seed`` itself for ``episodes``, then validated there.

    What it learns on is the rig's own simulator (:mod:`msd_bench.core.rigs.truth`: its plant,
    friction, actuator lag and dead time, which reproduce the rig's true positions exactly), the
    sensor left out as no model has it: a learner on a real rig would see its noise too, so this
    is the route's best case. Every training step is charged as a real sample.
    """
    from msd_bench import designs
    from msd_bench.core.rigs.truth import rig_model

    drawn = cfg.rigs.draw(seed)
    rig = Rig(drawn.params, drawn.imperfections, seed=seed)
    run = replace(cfg.rigs.run, episodes=episodes, dyna_episodes=episodes)
    pcfg = replace(cfg.rigs, run=run, scenarios=()).on_rig(drawn)
    run = pcfg.run
    simulator = rig_model(drawn.params, drawn.imperfections)
    settings = rig_settings(run, drawn.params, pcfg.scales)
    policy = designs.make(kind, simulator, settings, run.learning_seeds(0), None)
    rows = validate_on_rig(pcfg, rig, kind, policy, seed)
    outcomes = [{k: o[k] for k in ("kind", "seed", "success", "sse", "identified") if k in o} for o in rows]
    real = policy.facts.real_interactions // max(len(policy.members), 1)
    return {"rig": seed, "episodes": episodes, "charged": {kind: real}, "outcomes": outcomes,
            "identification_failed": {}, "seconds": 0.0}


def rig_point(cfg: RigEfficiencyConfig, n: int, seed: int) -> dict[str, Any]:
    """One rig at record length ``n``: each row's runs, and the real samples each row was charged by
    the rig's run (a refined row: the mean of its learning seeds' bills; one whose open-loop policy
    could not be made tried nothing, and is charged its kind's records)."""
    pcfg = cfg.at_length(n)
    part = rig_task(pcfg, seed)
    charged: dict[str, float] = {kind: float(bill["total"]) for kind, bill in part["charged"].items()}
    for row in pcfg.kinds():
        base = base_kind(row)
        if base is not None:
            bills = [o["refine"]["real_samples"]["total"] for o in part["outcomes"]
                     if o["kind"] == row and "refine" in o]
            charged[row] = float(np.mean(bills)) if bills else charged[base]
    outcomes = [{k: o[k] for k in ("kind", "seed", "success", "sse", "identified") if k in o}
                for o in part["outcomes"]]
    return {"rig": seed, "record_samples": n, "charged": charged, "outcomes": outcomes,
            "identification_failed": part["identification_failed"], "design_failed": part["design_failed"],
            "actuator": part["actuator"], "seconds": part["seconds"]["total"]}


Parts = Mapping[str, Mapping[str, Any]]
"""Task results keyed by task id."""


def lines(cfg: RigEfficiencyConfig, parts: Parts) -> list[dict[str, Any]]:
    """Each kind's points: pooled success with both intervals against its mean charged samples."""
    methods = []
    for row in cfg.rigs.kinds():
        points = []
        for n in cfg.record_samples:
            got = [parts[tid] for tid, m, _ in tasks(cfg) if m == n]
            points.append(_point(row, n, got, cfg))
        methods.append({"name": row, "label": kind_label(row), "points": points})
    for kind in cfg.plant_agents:
        points = []
        for e in cfg.episodes:
            got = [parts[tid] for tid, b, k, _ in plant_tasks(cfg) if b == e and k == kind]
            points.append({**_point(kind, None, got, cfg), "episodes": e})
        methods.append({"name": kind, "label": f"{agent_kind(kind).label}, trained on each rig",
                        "points": points})
    return methods


def _point(kind: str, n: int | None, got: Sequence[Mapping[str, Any]],
           cfg: RigEfficiencyConfig) -> dict[str, Any]:
    """A row's point over its rigs (``n``: the record length; None for an on-plant learner)."""
    per_rig = [rig_success(g, kind) for g in got]
    rate = rate_summary([k for k, _ in per_rig], [m for _, m in per_rig], cfg.rigs.resamples,
                        cfg.rigs.first_rig)
    charged = np.array([g["charged"][kind] for g in got], dtype=float)
    surrogate = agent_kind(base_kind(kind) or kind).surrogate
    failed = sorted({g["rig"] for g in got if surrogate in g["identification_failed"]})
    return {"record_samples": n, "real_samples": round(float(charged.mean())),
            "real_samples_range": [int(charged.min()), int(charged.max())],
            "n": rate["n"], "n_success": rate["successes"], "ci95": rate["bootstrap95"],
            "wilson95": rate["wilson95"], "bootstrap95": rate["bootstrap95"], "rigs": rate["rigs"],
            "identification_failed_rigs": failed}


def document(cfg: RigEfficiencyConfig, parts: Parts) -> dict[str, Any]:
    """``efficiency.json`` of a rig population (``methods`` as the ideal plant's curve has them)."""
    rigs = cfg.rigs
    seconds = [float(p["seconds"]) for p in parts.values()]
    return {
        "schema": "msd-bench/efficiency", "schema_version": 1, "on": "rigs", "family": cfg.family,
        "rig_set": "design" if rigs.design else "held-out", "rigs_run": rigs.rig_seeds(),
        "learning_seeds": rigs.run.learning_seeds(0), "success_sse_percent": SUCCESS_SSE,
        "judged_on": "true position at the nominal set-point",
        "robust_told": rigs.actuator, "refine_rounds": rigs.refine, "accounting": ACCOUNTING,
        "interval": "ci95 is the bootstrap over rigs; wilson95 treats every run as independent",
        "bootstrap": {"resamples": rigs.resamples, "seed": rigs.first_rig, "level": 0.95, "over": "rigs"},
        "methods": lines(cfg, parts),
        "seconds": {"total": sum(seconds), "per_task_max": max(seconds, default=0.0)},
    }


def rig_efficiency(cfg: RigEfficiencyConfig) -> dict[str, Any]:
    """The document computed in this process, task after task (the command spreads the tasks)."""
    parts = {tid: rig_point(cfg, n, seed) for tid, n, seed in tasks(cfg)}
    parts.update({tid: rig_plant_point(cfg, e, kind, seed) for tid, e, kind, seed in plant_tasks(cfg)})
    return document(cfg, parts)


__all__ = ["FAMILIES", "RigEfficiencyConfig", "document", "lines", "plant_tasks", "rig_efficiency",
           "rig_plant_point", "rig_point", "tasks"]
