"""The whole method per rig, in-process: records played through the rig, every model kind identified
from them only, each agent kind trained on its surrogate and validated through the rig itself.

One rig is one task (:func:`rig_task`: its inputs in its arguments, its result a
JSON-able dict), so a population runs on the sweep executor
(``app/executor.py``) and a killed sweep resumes rig by rig. What one task does:

1. draw the rig from its seed; play the paper's plan through it
   (:mod:`msd_bench.core.rigs.rig_play`: rest without reset before every
   experiment, the records its bags would hold);
2. identify every model kind the agents need from those records only, and
   score each on the rig's broad validation record;
3. train each agent kind on its surrogate (one batch of learning seeds);
4. validate every table on the same rig through its actuator and sensor,
   each run from where the rig came to rest after the previous one
   (:mod:`msd_bench.core.rigs.rig_loop`): the nominal set-point first (success is
   judged on the true position there), then the scenarios a rig can be given —
   other set-points, a load.

:func:`document` pools the tasks into ``rigs.json``: per kind the success rate
over (rig, seed) runs with its Wilson interval and a bootstrap-over-rigs
interval (:mod:`msd_bench.core.rigs.rig_stats`), the per-rig results and the ten
worst rigs.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from msd_bench import designs
from msd_bench.app import rig_refine, rig_routes
from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.plan import paper_plan
from msd_bench.app.rig_cost import spent
from msd_bench.app.rig_scores import paper_risk, rig_limits, rig_scenario, rig_settings, run_member, scores
from msd_bench.core.errors import ConfigError
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.risk import trace_risk
from msd_bench.core.evaluation.risk_table import summarise
from msd_bench.core.evaluation.scenarios import Scenario, noise_seed
from msd_bench.core.identification.excitation import PrbsConfig
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.identification.model_kinds import model_kind
from msd_bench.core.physics.model import StepModel
from msd_bench.core.rigs import families, population, scaled_family
from msd_bench.core.rigs.hold import Operation
from msd_bench.core.rigs.rest import RestConfig
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_loop import RigRun
from msd_bench.core.rigs.rig_play import PlayedExperiment, measured_actuator, play_plan, records_of
from msd_bench.core.rigs.rig_stats import DEFAULT_RESAMPLES, rate_summary
from msd_bench.core.rigs.scales import Scales
from msd_bench.core.rigs.units import RigUnits
from msd_bench.designs import Drive, Policy, kinds
from msd_bench.designs.kinds import split_by_model

RIG_SCENARIOS = ("setpoint=-1.5", "setpoint=-0.5", "setpoint=0.5", "setpoint=1.5",
                 "disturbance=2@15", "disturbance=-2@15")
"""What a rig can be given besides the nominal set-point: the standard suite's set-points and loads (its
noise, delay and parameter drifts are the rig's own here)."""
DEFAULT_AGENTS = kinds.RIGS
WORST = 10
ACTUATOR_CHOICES = ("measured", "none")
CEILING = tuple(rig_routes.ROUTES)
"""The ceiling's rows (``--ceiling``): every route of :data:`msd_bench.app.rig_routes.ROUTES`."""
"""What the robust agent is told of a rig's drive: the delay its records show, or nothing (the agent as
chosen on the ideal plant's surrogates): :func:`msd_bench.designs.qlearning.for_actuator`."""
"""Rigs listed with their parameters as the worst."""
MAX_REFINE = 10
"""The most refinement rounds a run may ask for."""
MAX_REFINE_WEIGHT = 10
"""The heaviest weight a closed-loop record may get in a refit."""


@dataclass(frozen=True)
class RigsConfig:
    """What a population run does."""

    run: RunConfig
    """Agents, learning seeds, budgets, record and validation lengths (one identification seed), stated
    on the paper's plant: each rig runs them in its own scales (:meth:`RunConfig.scaled`)."""
    rigs: int = 20
    """Rigs in the run."""
    first_rig: int = population.HELD_OUT_RIGS.start
    """Seed of the first rig; the rigs are first_rig, first_rig + 1, ..."""
    design: bool = False
    """Run design rigs (choose anything on them); False: held-out rigs only (what is reported)."""
    scenarios: tuple[str, ...] = RIG_SCENARIOS
    """Scenario ids run on every rig after the nominal validation (set-points and loads only)."""
    resamples: int = DEFAULT_RESAMPLES
    """Bootstrap resamples of the over-rigs interval."""
    settle: int = PrbsConfig.settle
    """Samples at the bias force before each PRBS record (the paper's 1,000; the data-efficiency
    sweep on rigs shortens them with the records, :func:`msd_bench.app.efficiency.settle_for`)."""
    actuator: str = "measured"
    """``measured``: the robust agent's observer assumes the actuator delay fitted between the broad
    record's commands and effort; ``none``: it assumes none (:data:`ACTUATOR_CHOICES`)."""
    ceiling: bool = False
    """Also run the ceiling (:data:`CEILING`): the robust agent trained on each rig's own simulator,
    validated after every agent kind (so theirs are the runs they would be without it)."""
    refine: int = 0
    """Refinement rounds on the rig per refinable kind (``app/rig_refine.py``), after every agent kind
    and the ceiling were validated; 0: none (every other row is the run it would be without it)."""
    refine_weight: int = 1
    """How many times each closed-loop record enters a refit beside the open-loop broad record."""
    family: str = families.DEFAULT_FAMILY
    """The rig family the rigs are drawn from (:mod:`msd_bench.core.rigs.families`)."""
    units: RigUnits | None = None
    """``--rig FILE``: every rig carried into the described rig's units (:func:`units_between`);
    None: each rig in its family's own units."""
    scales: Scales = Scales.DEFAULT
    """The scales of the one rig this config is on (:meth:`on_rig` sets them; the paper's before):
    scenarios, supervisor limits and the designs' constants are scaled by them."""

    def __post_init__(self) -> None:
        # an unknown family, or what a held one cannot do yet: one line
        families.in_process(self.family, self.ceiling, self.refine, self.run.supervisor)
        if self.rigs < 1 or self.first_rig < 0:
            raise ConfigError(f"--rigs must be >= 1 and --first-rig >= 0, got {self.rigs} and "
                              f"{self.first_rig}")
        if self.actuator not in ACTUATOR_CHOICES:
            raise ConfigError(f"--robust-actuator must be one of {', '.join(ACTUATOR_CHOICES)}, "
                              f"got {self.actuator!r}")
        if not 0 <= self.refine <= MAX_REFINE or not 1 <= self.refine_weight <= MAX_REFINE_WEIGHT:
            raise ConfigError(f"--refine must be in 0..{MAX_REFINE} and --refine-weight in "
                              f"1..{MAX_REFINE_WEIGHT}, got {self.refine} and {self.refine_weight}")
        if self.refine and not rig_refine.refined_kinds(self.run.agents):
            raise ConfigError("--refine refits the identified model an agent was made on: none of "
                              f"{', '.join(self.run.agents)} is made on one (on-plant kinds learn on "
                              "the rig)")
        if self.resamples < 100:
            raise ConfigError(f"--bootstrap must be >= 100 resamples, got {self.resamples}")
        if self.run.id_seeds != 1:
            raise ConfigError("rigs identifies once per rig from its own records: --id-seeds must be 1")
        if self.run.record_noise or self.run.record_quant or self.run.scenarios:
            raise ConfigError("--record-noise, --record-quant and --scenario do not apply: a rig measures "
                              "through its own sensor (use --rig-scenario for set-points and loads)")
        plant_kinds = split_by_model(self.run.agents)[1]
        if plant_kinds:
            raise ConfigError(f"rigs trains on identified surrogates only, not {', '.join(plant_kinds)}")
        for sid in self.scenarios:
            rig_scenario(sid)
        self.check_rig_set()

    def draw(self, seed: int) -> population.RigSpec:
        """Rig ``seed`` of the run's family, in the described rig's units when ``--rig`` gave them."""
        drawn = families.draw(self.family, seed)
        return drawn if self.units is None else scaled_family.in_units(drawn, self.units)

    def kinds(self) -> tuple[str, ...]:
        """Every row the run reports: the agent kinds, then the ceiling when asked for."""
        refined = rig_refine.refined_kinds(self.run.agents) if self.refine else []
        return (*self.run.agents, *(CEILING if self.ceiling else ()), *refined)

    @property
    def rest(self) -> RestConfig:
        """When the rig counts as at rest before each record and run, in its scales."""
        return RestConfig().scaled(self.scales)

    def rig_seeds(self) -> list[int]:
        """The rigs of the run."""
        return list(range(self.first_rig, self.first_rig + self.rigs))

    def check_rig_set(self) -> None:
        """Design and held-out rigs never mix, and a design rig is never reported as held out."""
        held = families.family(self.family).held_out
        span = f"0-{held.start - 1}"
        last = self.first_rig + self.rigs - 1
        if self.design and last >= held.start:
            raise ConfigError(f"rig {max(self.first_rig, held.start)} is held out: --design runs only "
                              f"design rigs {span}")
        if not self.design and self.first_rig < held.start:
            raise ConfigError(f"rig {self.first_rig} is a design rig (seeds {span}): held-out rigs start at "
                              f"{held.start}; pass --design to run design rigs")
        if last >= held.stop:
            named = "" if self.family == families.DEFAULT_FAMILY else f" (family {self.family})"
            raise ConfigError(f"rig {last} is beyond the population's held-out seeds "
                              f"{held.start}-{held.stop - 1}{named}")

    def on_rig(self, spec: population.RigSpec) -> RigsConfig:
        """This run on one rig: its budgets, set-point and window in the rig's scales (itself on a rig of
        the paper's scales, so the default family runs as it always did)."""
        scales = spec.scales()
        if scales.is_default:
            return self
        return replace(self, run=self.run.scaled(scales), settle=scales.samples(self.settle), scales=scales)


def rig_task(cfg: RigsConfig, seed: int) -> dict[str, Any]:
    """Everything one rig gives: its parameters, fits, every (kind, seed) outcome and the times taken."""
    t0 = time.perf_counter()
    drawn = cfg.draw(seed)
    rig = Rig(drawn.params, drawn.imperfections, seed=seed)  # the sensor's noise stream is the rig's own
    cfg = cfg.on_rig(drawn)
    run = cfg.run
    scales = drawn.scales()
    played = play_plan(rig, paper_plan(run.id_first_seed, run.samples, run.val_samples, cfg.settle,
                                       scales=scales), cfg.rest, drawn.hold)
    records = records_of(played, drawn.params.dt, drawn.hold)  # a held rig's: the held system's
    drive = measured_actuator(played, drawn.params.dt)
    told = Drive(drive.delay_samples, drive.time_constant_s, hold=drawn.hold) \
        if cfg.actuator == "measured" else None
    t_play = time.perf_counter()
    models, fits, failed = _identify(records, run, drawn.params, seed, scales)
    t_id = time.perf_counter()
    outcomes, t_train, not_made, made = [], 0.0, {}, {}
    for kind in run.agents:
        surrogate = models.get(agent_kind(kind).surrogate)
        t = time.perf_counter()
        policy, why = _make(surrogate, run, drawn, kind, told) if surrogate is not None else (None, "")
        t_train += time.perf_counter() - t
        if why:
            not_made[kind] = f"rig {seed}: {why}"
            outcomes += _not_designed(run, kind, not_made[kind])
            continue
        made[kind] = policy
        outcomes += validate_on_rig(cfg, rig, kind, policy, seed)
    for name in CEILING if cfg.ceiling else ():
        t = time.perf_counter()
        ceiling = rig_routes.route(name).make(drawn, rig_settings(run, rig.params, cfg.scales),
                                              run.learning_seeds(0))
        t_train += time.perf_counter() - t
        outcomes += validate_on_rig(cfg, rig, name, ceiling, seed)
    t_refine = time.perf_counter()
    if cfg.refine:
        outcomes += _refine_all(cfg, rig, seed, made, records, told, played)
    done = time.perf_counter()
    return {
        "rig": seed, "design": seed not in families.family(cfg.family).held_out,
        "parameters": rig_parameters(drawn),
        "rests": {"before_experiments": [p.rest.samples for p in played],
                  "not_still": sum(not p.rest.still for p in played)},
        "charged": _bills(run.agents, played),
        "fits": {name: fits[name].as_row() for name in fits}, "identification_failed": failed,
        "design_failed": not_made,
        "actuator": {"delay_samples": drive.delay_samples, "lag_s": drive.time_constant_s,
                     "fit_percent": drive.fit_percent,
                     "told_robust_agent": told.delay_samples if told is not None else 0},
        "outcomes": outcomes,
        "seconds": {"play": t_play - t0, "identify": t_id - t_play, "train": t_train,
                    "validate": t_refine - t_id - t_train,
                    **({"refine": done - t_refine} if cfg.refine else {}), "total": done - t0},
    }


def _bills(agents: Sequence[str], played: Sequence[PlayedExperiment]) -> dict[str, dict[str, int | str]]:
    """What each open-loop route spent on the rig (:func:`msd_bench.app.rig_cost.spent`): its kind's
    records and the validation record, with their rests; the validation runs that score it are not."""
    return {kind: spent(played, model_kind(agent_kind(kind).surrogate).records) for kind in agents}


def _refine_all(cfg: RigsConfig, rig: Rig, seed: int, made: Mapping[str, Policy | None], records: Any,
                told: Drive | None, played: Sequence[PlayedExperiment]) -> list[dict[str, Any]]:
    """Every refinable kind refined on the rig (one whose open-loop policy could not be made fails
    on every learning seed, as its open-loop row does)."""
    out: list[dict[str, Any]] = []
    for row in rig_refine.refined_kinds(cfg.run.agents):
        kind = rig_refine.base_kind(row) or row
        policy = made.get(kind)
        if policy is None:
            out += [{"kind": row, "seed": s, "success": False, "identified": False}
                    for s in designs.members(kind, cfg.run.learning_seeds(0))]
            continue
        out += rig_refine.refine_kind(cfg, rig, seed, kind, policy, records, told, played)
    return out


def rig_parameters(spec: population.RigSpec) -> dict[str, Any]:
    """Every drawn parameter by the report's names: the plant's multipliers, then the imperfections, in
    the units of the rig's default-family twin (so every family's figure reads alike), then (a rig in
    other units) its unit factors. A rig that is a plant of its own (its family states its pace: a
    stage) in physical units instead, with its stroke, force limit, rate and offset force
    (:data:`~msd_bench.io.rigs.rigs_report.OWN_PLANT`)."""
    imp, u = spec.imperfections, spec.units
    if spec.pace is not None:  # a plant of its own (a stage): physical units, its stroke, force and rate
        p = spec.params
        return {"mass": p.m, "damping": p.c, "spring": p.k, "hardening": p.h, "friction": imp.friction,
                "delay": imp.delay_samples, "lag": imp.actuator_tau, "noise": imp.sensor_noise,
                "quant": imp.sensor_quant, "stroke": p.L, "force_limit": p.F, "rate": 1.0 / p.dt,
                "offset": imp.offset}
    mult = spec.multipliers()
    doc = {"mass": mult["m"], "damping": mult["c"], "spring": mult["k"], "hardening": mult["h"],
           "friction": imp.friction, "delay": imp.delay_samples, "lag": imp.actuator_tau,
           "noise": imp.sensor_noise, "quant": imp.sensor_quant}
    if u.is_identity:
        return doc
    return {**doc, "friction": imp.friction / u.force, "lag": imp.actuator_tau / u.time,
            "noise": imp.sensor_noise / u.length, "quant": imp.sensor_quant / u.length,
            "length_unit": u.length, "mass_unit": u.mass, "time_unit": u.time}


def _identify(records: Any, run: RunConfig, params: Any, seed: int,
              scales: Scales) -> tuple[dict[str, StepModel], dict[str, FitReport], dict[str, str]]:
    """Every model kind the agents need, from the rig's records, fitted in the rig's scales; a kind that
    cannot be identified says why."""
    from msd_bench.app.pipeline import identify_each

    models, fits, failed = identify_each(records, run.surrogates_needed(), run.id_first_seed, params,
                                         run.nlarx_scale, scales=None if scales.is_default else scales)
    # its agents then count as failures on this rig, with the reason
    return models, fits, {name: f"rig {seed}: {why}" for name, why in failed.items()}


def _make(surrogate: StepModel, run: RunConfig, spec: population.RigSpec, kind: str,
          drive: Drive | None) -> tuple[Policy | None, str]:
    """The kind's policy made by its design on its surrogate only, one member per learning seed (a
    deterministic design: one), in the rig's scales, told the rig's ``drive`` (None: nothing); or why
    its design could not be made on this rig's surrogate (a baseline's tuning rule may find no gains
    for it: a result)."""
    try:
        settings = rig_settings(run, spec.params, spec.scales(), spec.decision_samples())
        return designs.make(kind, surrogate, settings, run.learning_seeds(0), drive), ""
    except ConfigError as exc:
        return None, str(exc)


def _not_designed(run: RunConfig, kind: str, why: str) -> list[dict[str, Any]]:
    """A kind whose design failed on the rig's surrogate: a failed run per member it would have had."""
    return [{"kind": kind, "seed": seed, "success": False, "identified": True, "design_failed": why}
            for seed in designs.members(kind, run.learning_seeds(0))]


def validate_on_rig(cfg: RigsConfig, rig: Rig, kind: str, policy: Policy | None,
              rig_seed: int) -> list[dict[str, Any]]:
    """Every member on the rig: nominal first, then each rig scenario, in that order (a kind whose
    surrogate could not be identified fails on every learning seed)."""
    run = cfg.run
    if policy is None:
        return [{"kind": kind, "seed": seed, "success": False, "identified": False}
                for seed in run.learning_seeds(0)]
    out = []
    op = cfg.draw(rig_seed).operation()  # its hold loop and decision period, once per kind
    for j, seed in enumerate(policy.members):
        nominal = _one_run(cfg, rig, kind, policy, j, seed, rig_seed, Scenario(setpoint=run.target), op)
        row = {"kind": kind, "seed": seed, "identified": True,
               **scores(nominal, run.target, run, dt=rig.params.dt),
               "start_x": float(nominal.x[0]), "risk": _risk(cfg, rig, nominal),
               "scenarios": {}}
        for sid in cfg.scenarios:
            sc = rig_scenario(sid).scaled(cfg.scales)
            got = _one_run(cfg, rig, kind, policy, j, seed, rig_seed, sc, op)
            row["scenarios"][sid] = scores(got, sc.setpoint, run, brief=True, dt=rig.params.dt)
        out.append(row)
    return out


def _one_run(cfg: RigsConfig, rig: Rig, kind: str, policy: Policy, member: int, seed: int, rig_seed: int,
             sc: Scenario, op: Operation) -> RigRun:
    """One validation run of member ``member`` on the rig under ``sc`` (its noise stream named by rig,
    kind, seed): :func:`msd_bench.app.rig_scores.run_member`."""
    rng = np.random.default_rng(noise_seed(seed, f"rig{rig_seed}/{kind}/{sc.id}"))
    limits = rig_limits(cfg.run, cfg.scales)
    return run_member(rig, policy, member, sc, cfg.run.validation_steps, rng, limits, cfg.rest, op)


def _risk(cfg: RigsConfig, rig: Rig, r: RigRun) -> dict[str, Any]:
    """A run's risk record: its true positions on the rig's stroke, and the supervisor's reasons and
    abort when it guarded the run (its limits are the nominal plant's: all a rig's supervisor is told),
    in the paper's units (:func:`~msd_bench.app.rig_scores.paper_risk`)."""
    risk = trace_risk(r.x, rig.params, rig_limits(cfg.run, cfg.scales), r.reason, r.abort).as_dict()
    return paper_risk(risk, cfg.scales)


def rig_success(part: Mapping[str, Any], kind: str) -> tuple[int, int]:
    """(successes, runs) of ``kind`` on one rig's result."""
    rows = [o for o in part["outcomes"] if o["kind"] == kind]
    return sum(bool(o["success"]) for o in rows), len(rows)


def kind_label(kind: str) -> str:
    """A row's label: a rig route's (the ceiling) or the agent kind's."""
    base = rig_refine.base_kind(kind)
    if base is not None:
        return f"{agent_kind(base).label}, refined on the rig"
    return rig_routes.ROUTES[kind].label if kind in rig_routes.ROUTES else agent_kind(kind).label


def kind_summary(cfg: RigsConfig, parts: Sequence[Mapping[str, Any]], kind: str,
                 seed: int) -> dict[str, Any]:
    """One kind's rate over (rig, seed) runs with both intervals, and its scenario cells."""
    per_rig = [rig_success(p, kind) for p in parts]
    rate = rate_summary([k for k, _ in per_rig], [n for _, n in per_rig], cfg.resamples, seed)
    row: dict[str, Any] = {"kind": kind, "label": kind_label(kind), **rate}
    measured = [o for p in parts for o in p["outcomes"] if o["kind"] == kind and o.get("identified")
                and "design_failed" not in o]
    row["measured_successes"] = sum(bool(o["success_measured"]) for o in measured)
    row["risk"] = summarise(o.get("risk") for o in measured)
    if rig_refine.base_kind(kind) is not None:
        row["refine"] = rig_refine.summary([o for p in parts for o in p["outcomes"] if o["kind"] == kind])
    row["scenarios"] = {}
    for sid in cfg.scenarios:
        cells = [[o for o in p["outcomes"] if o["kind"] == kind] for p in parts]
        ks = [sum(bool(o.get("scenarios", {}).get(sid, {}).get("success")) for o in c) for c in cells]
        row["scenarios"][sid] = rate_summary(ks, [len(c) for c in cells], cfg.resamples, seed)
    return row


def worst_rigs(cfg: RigsConfig, parts: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The rigs with the lowest success over every kind's runs (ties: lower seed first), with parameters."""
    scored = []
    for p in parts:
        k = sum(rig_success(p, kind)[0] for kind in cfg.kinds())
        n = sum(rig_success(p, kind)[1] for kind in cfg.kinds())
        scored.append((k / n, p["rig"], k, n, p))
    scored.sort(key=lambda s: (s[0], s[1]))
    return [{"rig": rig, "successes": k, "runs": n, "parameters": p["parameters"],
             "identification_failed": sorted(p["identification_failed"])}
            for _, rig, k, n, p in scored[:WORST]]


def population_doc(name: str) -> dict[str, Any]:
    """What ``rigs.json`` says of the family its rigs were drawn from (the default family's record is
    as it was before families existed, the family's name added)."""
    fam = families.family(name)
    return {"module": fam.module, "design_seeds": [0, fam.held_out.start - 1],
            "held_out_first": fam.held_out.start, "family": fam.name}


def document(cfg: RigsConfig, parts: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """``rigs.json`` from every rig's task result (in rig order)."""
    parts = sorted(parts, key=lambda p: int(p["rig"]))
    seed = cfg.first_rig
    totals = [float(p["seconds"]["total"]) for p in parts]
    return {
        "schema": "msd-bench/rigs", "schema_version": 1,
        "rig_set": "design" if cfg.design else "held-out",
        "population": population_doc(cfg.family),
        **({} if cfg.units is None else {"units": {"length": cfg.units.length, "mass": cfg.units.mass,
                                                   "time": cfg.units.time}}),
        "rigs_run": [int(p["rig"]) for p in parts],
        "learning_seeds": cfg.run.learning_seeds(0), "agents": list(cfg.run.agents),
        "success_sse_percent": SUCCESS_SSE,
        "validation": {"target": cfg.run.target, "steps": cfg.run.validation_steps,
                       "window": cfg.run.window, "scenarios": list(cfg.scenarios),
                       "judged_on": "true position at the nominal set-point",
                       "supervisor": cfg.run.supervisor},
        "bootstrap": {"resamples": cfg.resamples, "seed": seed, "level": 0.95, "over": "rigs"},
        "kinds": [kind_summary(cfg, parts, kind, seed) for kind in cfg.kinds()],
        "worst": worst_rigs(cfg, parts),
        "rigs": list(parts),
        "seconds": {"per_rig_median": float(np.median(totals)), "per_rig_max": max(totals),
                    "total": sum(totals)},
        **({"ceiling": [rig_routes.route(name).facts() for name in CEILING]} if cfg.ceiling else {}),
    }
