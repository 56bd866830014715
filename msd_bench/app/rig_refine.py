"""``msd-bench rigs --refine R``: each agent kind refined on the rig from its own closed-loop tries.

Why apart from ``app/rigs.py``: the rig task validates every kind as it was
(``--refine 0`` changes nothing there), then hands each refinable kind here.
The loop itself is :func:`msd_bench.core.rigs.refine.refine`; this module
gives it the rig's supervised try, the registered fitter of the kind's model
(the open-loop records plus the closed-loop ones) and the kind's design.

Per learning seed, as a rig owner with one agent would: try the open-loop
policy on the rig behind the supervisor, refit, retrain (that seed only), try
again, up to R rounds; keep the policy whose *measured* try was best; then a
fresh supervised validation of it — the nominal run (success judged on the true
position, as for every row) and the rig scenarios. The row is charged what the
route played on the rig, with the rest before each (:func:`msd_bench.app.rig_cost.spent`,
the bill the data-efficiency curve on rigs uses too): the kind's records and the
validation record, each try, the fresh nominal run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.rig_cost import ACCOUNTING, spent
from msd_bench.app.rig_scores import paper_risk, rig_limits, rig_scenario, rig_settings, run_member, scores
from msd_bench.app.scoring import metric_row
from msd_bench.core.errors import ConfigError, IdentificationError
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.risk import trace_risk
from msd_bench.core.evaluation.scenarios import Scenario, noise_seed
from msd_bench.core.identification.data import Experiment, IOData
from msd_bench.core.identification.model_kinds import model_kind
from msd_bench.core.rigs.refine import Refined, Try, refine
from msd_bench.core.rigs.rig_loop import RigRun
from msd_bench.designs import kinds

if TYPE_CHECKING:
    from msd_bench.app.config import RunConfig
    from msd_bench.core.identification.records import Records
    from msd_bench.core.physics.model import StepModel
    from msd_bench.core.physics.plant import PlantParams
    from msd_bench.core.rigs.rest import RestConfig
    from msd_bench.core.rigs.rig import Rig
    from msd_bench.core.rigs.rig_play import PlayedExperiment
    from msd_bench.core.rigs.scales import Scales
    from msd_bench.core.safety.supervisor import Limits
    from msd_bench.designs import Drive, Policy

SUFFIX = "+refined"
"""A refined row is its agent kind's name with this suffix."""

class RigsConfig(Protocol):
    """What refinement reads of a ``rigs`` run (``app/rigs.RigsConfig`` has it; that module imports this
    one, so it is named by what it offers)."""

    @property
    def run(self) -> RunConfig: ...
    @property
    def refine(self) -> int: ...
    @property
    def refine_weight(self) -> int: ...
    @property
    def scenarios(self) -> tuple[str, ...]: ...
    @property
    def scales(self) -> Scales: ...
    @property
    def rest(self) -> RestConfig: ...


Member = tuple["Policy", int]
"""A policy and the index of the member a learning seed owns in it."""


def refinable(kind: str) -> bool:
    """It is made on an identified model, which a refit can fit again with the closed-loop tries: the
    broad kinds from their broad record with the tries joined, the PLM by its blend's refinement over
    its bias records and the tries (its local models stay its bias records')."""
    return not kinds.made_on_plant(kind)


def refined_kinds(agents: Sequence[str]) -> list[str]:
    """The refined rows of a run of ``agents``."""
    return [f"{k}{SUFFIX}" for k in agents if refinable(k)]


def base_kind(row: str) -> str | None:
    """The agent kind a refined row refines (None: not a refined row)."""
    return row[:-len(SUFFIX)] if row.endswith(SUFFIX) else None


def limits_of(cfg: RigsConfig) -> Limits:
    """Every on-rig try and the fresh validation run behind the supervisor (the run's limits, or its
    default limits on the nominal plant: all a rig's supervisor is told), in the rig's scales."""
    from msd_bench.core.safety.supervisor import SupervisorOptions

    limits = rig_limits(cfg.run, cfg.scales)
    return limits or SupervisorOptions().scaled(cfg.scales).limits(cfg.scales.plant(cfg.run.plant))


def with_closed_loop(records: Records, tries: Sequence[Experiment], weight: int) -> Records:
    """The open-loop records with the closed-loop ones, each ``weight`` times (a heavier say in the fit;
    the validation record stays the open-loop one): joined to the broad training record, where the broad
    kinds fit, and as ``closed_loop``, where the PLM's refinement takes them."""
    broad = records.broad_train
    extra = tuple(e for e in tries for _ in range(weight))
    meta: dict[str, object] = {"closed_loop_records": len(tries), "closed_loop_weight": weight}
    return replace(records, broad_train=IOData(broad.experiments + extra, broad.dt, {**broad.meta, **meta}),
                   closed_loop=(IOData(extra, broad.dt, meta),) if extra else ())


def refit(records: Records, tries: Sequence[Experiment], weight: int, surrogate: str,
          run: RunConfig, plant: PlantParams | None = None,
          scales: Scales | None = None) -> tuple[StepModel, dict[str, Any]]:
    """Model ``surrogate`` fitted by its registered fitter from the open-loop ``records`` plus the
    closed-loop ``tries`` (each ``weight`` times), and its fit on the open-loop validation record; an
    IdentificationError naming the kind when it cannot be. The one refit of ``rigs --refine`` and of
    ``bench.py --refine`` (which reads ``records`` and the tries from bags). ``plant``: the rig's stroke,
    force limit and sample time (None: the run's plant's); ``scales``: the rig's (None: the paper's
    constants as they are)."""
    from msd_bench.app.pipeline import identify_each

    data = with_closed_loop(records, tries, weight)
    models, fits, failed = identify_each(data, [surrogate], run.id_first_seed,
                                         run.plant if plant is None else plant, run.nlarx_scale,
                                         scales=scales)
    if surrogate in failed:
        raise IdentificationError(f"refit of {surrogate}: {failed[surrogate]}")
    return models[surrogate], fits[surrogate].as_row()


def _run(cfg: RigsConfig, rig: Rig, member: Member, sc: Scenario, stream: str) -> RigRun:
    """One supervised run of a member on the rig under ``sc`` (noise stream named by ``stream``)."""
    policy, j = member
    rng = np.random.default_rng(noise_seed(policy.members[j], stream))
    return run_member(rig, policy, j, sc, cfg.run.validation_steps, rng, limits_of(cfg), cfg.rest)


def _risk(cfg: RigsConfig, rig: Rig, r: RigRun) -> dict[str, Any]:
    return paper_risk(trace_risk(r.x, rig.params, limits_of(cfg), r.reason, r.abort).as_dict(), cfg.scales)


def _as_try(cfg: RigsConfig, rig: Rig, r: RigRun, name: str) -> Try:
    """A try as the choice may read it (the measured record) and the report shows it (risk, truth)."""
    run = cfg.run
    seen = metric_row(r.y, run.target, rig.params.dt, run.window)["sse"]
    true = metric_row(r.x, run.target, rig.params.dt, run.window)["sse"]
    report = {"sse": true, "success": bool(true < SUCCESS_SSE), "risk": _risk(cfg, rig, r)}
    return Try(Experiment(r.effort, r.y, name=name, truth=r.x), float(seen), r.abort != 0, int(r.x.size),
               r.rest.samples, report)


def refine_kind(cfg: RigsConfig, rig: Rig, rig_seed: int, kind: str, policy: Policy, records: Records,
                told: Drive | None, played: Sequence[PlayedExperiment]) -> list[dict[str, Any]]:
    """Every member of ``kind``'s open-loop ``policy`` refined on the rig, then freshly validated
    (``played``: the rig's plan as played, what the row is charged of it and its rests)."""
    run = cfg.run
    surrogate = agent_kind(kind).surrogate
    settings = rig_settings(run, rig.params, cfg.scales)
    rows = []
    for j, seed in enumerate(policy.members):
        def try_(member: Member, r: int, seed: int = seed) -> Try:
            stream = f"rig{rig_seed}/{kind}/refine/try{r}"
            return _as_try(cfg, rig, _run(cfg, rig, member, Scenario(setpoint=run.target), stream),
                           f"closed-loop try {r}, seed {seed}")

        def refit_(tries: Sequence[Experiment]) -> tuple[StepModel, dict[str, Any]]:
            return refit(records, tries, cfg.refine_weight, surrogate, run, rig.params,
                         None if cfg.scales.is_default else cfg.scales)

        def retrain(model: StepModel, seed: int = seed) -> Member:
            return designs.make(kind, model, settings, [seed], told), 0

        got = refine((policy, j), cfg.refine, try_, refit_, retrain, (ConfigError, IdentificationError))
        rows.append(_fresh(cfg, rig, rig_seed, kind, seed, got, played))
    return rows


def _fresh(cfg: RigsConfig, rig: Rig, rig_seed: int, kind: str, seed: int, got: Refined[Member],
           played: Sequence[PlayedExperiment]) -> dict[str, Any]:
    """The kept policy's fresh validation (nominal, then every rig scenario), with its rounds and the
    real samples charged (the rig scenarios are not: they describe the row, a rig owner need not run
    them)."""
    run = cfg.run
    row_kind = f"{kind}{SUFFIX}"
    nominal = _run(cfg, rig, got.policy, Scenario(setpoint=run.target), f"rig{rig_seed}/{row_kind}/nominal")
    row: dict[str, Any] = {"kind": row_kind, "seed": seed, "identified": True,
                           **scores(nominal, run.target, run, dt=rig.params.dt),
                           "start_x": float(nominal.x[0]), "risk": _risk(cfg, rig, nominal), "scenarios": {}}
    for sid in cfg.scenarios:
        sc = rig_scenario(sid).scaled(cfg.scales)
        got_sc = _run(cfg, rig, got.policy, sc, f"rig{rig_seed}/{row_kind}/{sc.id}")
        row["scenarios"][sid] = scores(got_sc, sc.setpoint, run, brief=True, dt=rig.params.dt)
    fresh = int(nominal.x.size)
    bill = spent(played, model_kind(agent_kind(kind).surrogate).records,
                 [*got.try_runs, (fresh, nominal.rest.samples)])
    row["refine"] = {
        "chosen_round": got.chosen,
        "rounds": [{"round": d.index, "failed": d.failed, "fit": d.fit,
                    **({"sse_measured": d.tried.sse_measured, "aborted": d.tried.aborted,
                        "samples": d.tried.samples, **d.tried.report} if d.tried is not None else {})}
                   for d in got.rounds],
        "real_samples": {**bill, "tries": got.try_samples, "fresh_validation": fresh},
    }
    return row


def summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """A refined kind's rounds over its runs: per round the tries made, their true successes, supervisor
    aborts, overridden samples and stop contacts (summed); how often each round was kept; the real
    samples a run used (:func:`msd_bench.app.rig_cost.spent`: its records, tries and fresh run, each
    with its rest; ``accounting`` names that bill)."""
    runs = [o["refine"] for o in rows if "refine" in o]
    most = max((len(r["rounds"]) for r in runs), default=0)
    per_round = []
    for i in range(most):
        tried = [r["rounds"][i] for r in runs if len(r["rounds"]) > i and "samples" in r["rounds"][i]]
        per_round.append({
            "round": i, "tries": len(tried),
            "failed": sum(1 for r in runs if len(r["rounds"]) > i and r["rounds"][i]["failed"]),
            "successes": sum(bool(t["success"]) for t in tried),
            "aborts": sum(bool(t["aborted"]) for t in tried),
            "overridden_samples": sum(sum(t["risk"]["overrides"].values()) for t in tried),
            "contacts": sum(int(t["risk"]["contacts"]) for t in tried),
            "kept": sum(1 for r in runs if r["chosen_round"] == i)})
    totals = [int(r["real_samples"]["total"]) for r in runs]
    return {"runs": len(runs), "rounds": per_round,
            "real_samples_per_run": {"median": float(np.median(totals)) if totals else None,
                                     "max": max(totals, default=None), "accounting": ACCOUNTING}}
