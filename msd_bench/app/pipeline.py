"""The paper's whole method in-process (no ROS): records → models → agents → Table 1.

Stages, each a function the ROS graph reuses:

1. :func:`make_records` — simulate the plan's experiments on the true plant;
2. :func:`identify_surrogates` — fit the requested registered model kinds and
   score each on the broad validation record;
3. :func:`train_and_validate` — make a kind's policy through its design
   (:mod:`msd_bench.designs`: train a batch of seeds, or design a baseline) on
   one surrogate (or on the plant), run it on the true plant, score it (paper §5);
4. :func:`run_paper` — all of it over identification seeds × learning seeds.

The result is a distribution per agent kind, never a single number.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.job import agent_params, shared
from msd_bench.app.plan import TRAIN, PlannedExperiment, paper_plan
from msd_bench.app.scoring import PolicyRecord, Validation, assemble, metric_row
from msd_bench.core.errors import MsdBenchError
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.results import AgentResult, per_seed_row
from msd_bench.core.identification import identify
from msd_bench.core.identification.data import IOData
from msd_bench.core.identification.excitation import MultilevelConfig
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.identification.model_kinds import FitRequest, fit_model
from msd_bench.core.identification.records import Records
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.physics.sensor import SensorModel
from msd_bench.core.rigs.scales import Scales
from msd_bench.designs import Policy, Settings
from msd_bench.designs.protocol import settings_from

FloatArray = NDArray[np.float64]
Progress = Callable[[str, int, int], None]


@dataclass
class PaperRun:
    """Everything a run produced, for the report and the figures."""

    config: RunConfig
    results: list[AgentResult] = field(default_factory=list)
    models: dict[int, dict[str, StepModel]] = field(default_factory=dict)
    """Surrogates per identification seed."""
    fits: dict[int, dict[str, FitReport]] = field(default_factory=dict)
    """Validation fits per identification seed and surrogate."""
    responses: dict[str, FloatArray] = field(default_factory=dict)
    """Greedy closed-loop positions on the plant, per agent kind (seeds × steps)."""
    policies: dict[str, dict[int, Policy]] = field(default_factory=dict)
    """Per agent kind and identification seed: the policy (the artifact both engines write)."""
    robustness: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    """Per agent kind and scenario: the fixed policies on perturbed plants / other set-points."""
    records: dict[int, Records] = field(default_factory=dict)


def make_records(cfg: RunConfig, id_seed: int) -> Records:
    """Drive the true plant with the plan's excitations (in-process), measured through the run's sensor."""
    return records_from_plan(cfg.plant, paper_plan(id_seed, cfg.samples, cfg.val_samples, scales=cfg.scales),
                             cfg.sensor)


def records_from_plan(p: PlantParams, plan: Sequence[PlannedExperiment],
                      sensor: SensorModel | None = None) -> Records:
    """Simulate every planned experiment on the plant ``p``.

    With a ``sensor`` each record holds the measured position (noise seeded
    from the record's excitation seed) and keeps the noise-free truth beside it
    for ``fit_sim_truth_percent``.
    """
    bias: dict[str, dict[float, IOData]] = {"train": {}, "validation": {}}
    broad: dict[str, IOData] = {}
    for exp in plan:
        if isinstance(exp.signal, MultilevelConfig):
            broad[exp.role] = identify.broad_record(p, exp.seed, exp.signal, sensor)
        elif exp.bias is not None:
            bias[exp.role][exp.bias] = identify.bias_record(p, exp.bias, exp.seed, exp.signal, sensor)
    return Records(bias[TRAIN], bias["validation"], broad[TRAIN], broad["validation"])


def identify_surrogates(
    records: Records, names: Sequence[str], seed: int, plant: PlantParams,
    nlarx_scale: float = shared("nlarx_scale"),
    on_model: Callable[[str, StepModel, FitReport], None] | None = None,
    units: tuple[str, str] = ("N", "m"),
    scales: Scales | None = None,
) -> tuple[dict[str, StepModel], dict[str, FitReport]]:
    """Fit the requested model kinds and score each on the broad validation record.

    Every surrogate is scored on the same broad-range record: scoring the PLM on
    its own five bias records would mostly measure the offsets between biases
    and flatter it. ``on_model`` hears of each model as soon as it is fitted and
    scored (the identifier node saves it then, so agents on it can start).
    """
    req = FitRequest(records, seed, plant.L, plant.F, nlarx_scale, dt=plant.dt, units=units, scales=scales)
    models: dict[str, StepModel] = {}
    fits: dict[str, FitReport] = {}
    for name in names:
        models[name] = fit_model(name, req)
        fits[name] = identify.evaluate(models[name], records.broad_val)
        if on_model is not None:
            on_model(name, models[name], fits[name])
    return models, fits


FIT_FAILURES = (MsdBenchError, ArithmeticError, ValueError)
"""What a fit that cannot be made raises (a one-line bench error, or the numerics giving up on a
record unlike the model's structure): the kind fails alone, with that line as its reason."""


def identify_each(
    records: Records, names: Sequence[str], seed: int, plant: PlantParams,
    nlarx_scale: float = shared("nlarx_scale"),
    on_model: Callable[[str, StepModel, FitReport], None] | None = None,
    units: tuple[str, str] = ("N", "m"),
    scales: Scales | None = None,
) -> tuple[dict[str, StepModel], dict[str, FitReport], dict[str, str]]:
    """:func:`identify_surrogates` one kind at a time, so a kind that cannot be fitted fails alone.

    Returns the models and fits of the kinds that were fitted and, per kind that was not, the
    one-line reason (the identifier, ``msd-bench identify`` and ``msd-bench rigs`` write the
    others and name the failures instead of stopping at the first).
    """
    models: dict[str, StepModel] = {}
    fits: dict[str, FitReport] = {}
    failed: dict[str, str] = {}
    for name in names:
        try:
            got, scored = identify_surrogates(records, [name], seed, plant, nlarx_scale, on_model, units,
                                              scales)
        except FIT_FAILURES as err:
            failed[name] = one_line(err)
            continue
        models.update(got)
        fits.update(scored)
    return models, fits, failed


def one_line(err: BaseException) -> str:
    """A failure's reason on one line; a numerical error says its type (its text may be terse)."""
    text = " ".join(str(err).split()) or "no message"
    return text if isinstance(err, MsdBenchError) else f"{type(err).__name__}: {text}"


@dataclass(frozen=True)
class Trained:
    """One agent kind's policy made on one identified model (or the plant), validated on the plant."""

    policy: Policy
    """The trained or designed policy (:mod:`msd_bench.designs`)."""
    seeds: list[int]
    """The learning seeds it was given (a deterministic policy's noise draws under a noisy scenario)."""
    id_seed: int
    """The identification seed of its model."""
    x: FloatArray
    """Nominal closed-loop positions on the plant, one row per member."""
    metrics: list[dict[str, Any]]
    """Paper §5 metrics of each row and its ``risk`` record."""

    @property
    def real_interactions(self) -> int:
        """Samples the policy really spent on the plant while training."""
        return self.policy.facts.real_interactions

    def record(self, fit: FitReport | None) -> PolicyRecord:
        """What Table 1 and robustness are assembled from (:func:`msd_bench.app.scoring.assemble`)."""
        rows = [per_seed_row(s, self.id_seed, m)
                for s, m in zip(self.policy.members, self.metrics, strict=True)]
        return PolicyRecord(self.policy, self.id_seed, self.seeds, rows, fit)


def settings(cfg: RunConfig) -> Settings:
    """What every design takes from the run (built as the agent node builds its own)."""
    return settings_from(agent_params(cfg))


def train_and_validate(kind: str, surrogate: StepModel, cfg: RunConfig, seeds: Sequence[int],
                       id_seed: int | None = None) -> Trained:
    """Make ``kind`` on ``surrogate`` (the plant's own model for on-plant kinds), run it on the plant."""
    policy = designs.make(kind, surrogate, settings(cfg), seeds)
    return validate_policy(policy, cfg, seeds, cfg.id_first_seed if id_seed is None else id_seed)


def validate_policy(policy: Policy, cfg: RunConfig, seeds: Sequence[int], id_seed: int) -> Trained:
    """The nominal validation of a made (or loaded) ``policy`` on the plant, each member's metrics and
    risk: what Table 1 is assembled from, whoever made the policy."""
    x, risks = robustness.nominal_validation(policy, cfg.plant, cfg.target, cfg.validation_steps,
                                             cfg.supervisor_limits)
    rows: list[dict[str, Any]] = [
        {**metric_row(xi, cfg.target, cfg.plant.dt, cfg.window), "risk": r.as_dict()}
        for xi, r in zip(x, risks, strict=True)]
    return Trained(policy, list(seeds), id_seed, x, rows)


def run_paper(cfg: RunConfig, progress: Progress | None = None) -> PaperRun:
    """The whole method for every requested agent kind, over id seeds × learning seeds."""
    run = PaperRun(cfg)
    tell = progress or (lambda stage, done, total: None)
    parts: dict[str, list[Trained]] = {a: [] for a in cfg.agents}
    on_surrogates, on_plant = cfg.surrogate_agents(), cfg.plant_agents()
    total = cfg.id_seeds * (1 + len(on_surrogates)) + len(on_plant)
    done = 0
    for i, id_seed in enumerate(cfg.id_seed_values()):
        tell(f"identify (id seed {id_seed})", done, total)
        run.records[id_seed] = make_records(cfg, id_seed)
        run.models[id_seed], run.fits[id_seed] = identify_surrogates(
            run.records[id_seed], cfg.surrogates_needed(), id_seed, cfg.plant, cfg.nlarx_scale)
        done += 1
        seeds = cfg.learning_seeds(i)
        for a in on_surrogates:
            tell(f"train {a} (id seed {id_seed})", done, total)
            surrogate = run.models[id_seed][agent_kind(a).surrogate]
            parts[a].append(train_and_validate(a, surrogate, cfg, seeds, id_seed))
            done += 1
    for a in on_plant:
        tell(f"train {a}", done, total)
        parts[a].append(train_and_validate(a, plant_model(cfg.plant), cfg, cfg.learning_seeds(0)))
        done += 1
    for a in cfg.agents:  # Table 1 and robustness
        _collect(run, a, parts[a])
    tell("done", total, total)
    return run


def _collect(run: PaperRun, kind: str, parts: list[Trained]) -> None:
    """Table-1 row, robustness, responses and policies of one kind (the assembly bench.py's report
    makes from the same records)."""
    cfg = run.config
    surrogate = agent_kind(kind).surrogate
    records = [t.record(run.fits.get(t.id_seed, {}).get(surrogate)) for t in parts]
    result, rob = assemble(kind, records, settings(cfg), Validation.of(cfg))
    run.results.append(result)
    run.robustness[kind] = rob
    run.responses[kind] = np.concatenate([t.x for t in parts])
    run.policies[kind] = {t.id_seed: t.policy for t in parts}
