"""The paper's whole method in-process (no ROS): records → models → agents → Table 1.

Stages, each a function the ROS graph reuses:

1. :func:`make_records` — simulate the plan's experiments on the true plant;
2. :func:`identify_surrogates` — fit the requested registered model kinds and
   score each on the broad validation record;
3. :func:`train_and_validate` — train a batch of seeds on one surrogate (or on
   the plant), run each greedy table on the true plant, score it (paper §5);
4. :func:`run_paper` — all of it over identification seeds × learning seeds.

The result is a distribution per agent kind, never a single number.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.app.agents import PLANT, agent_kind, budget_note
from msd_bench.app.config import RunConfig
from msd_bench.app.plan import TRAIN, PlannedExperiment, paper_plan
from msd_bench.app.scoring import agent_result, metric_row
from msd_bench.core import identify, robustness
from msd_bench.core.data import IOData
from msd_bench.core.dyna import DynaConfig, train_dyna
from msd_bench.core.excitation import MultilevelConfig
from msd_bench.core.identify import FitReport
from msd_bench.core.model import StepModel, plant_model
from msd_bench.core.plant import PlantParams
from msd_bench.core.qtrain import greedy_rollouts, train
from msd_bench.core.records import Records
from msd_bench.core.registry import FitRequest, fit_model
from msd_bench.core.results import AgentResult, per_seed_row
from msd_bench.core.sensor import SensorModel

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
    qtables: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Per agent kind: final tables, first/last snapshots, seeds, and the learner config."""
    robustness: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    """Per agent kind and scenario: the fixed tables on perturbed plants / other set-points."""
    records: dict[int, Records] = field(default_factory=dict)


def make_records(cfg: RunConfig, id_seed: int) -> Records:
    """Drive the true plant with the plan's excitations (in-process), measured through the run's sensor."""
    return records_from_plan(cfg.plant, paper_plan(id_seed, cfg.samples, cfg.val_samples), cfg.sensor)


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
    records: Records, names: Sequence[str], seed: int, plant: PlantParams, nlarx_scale: float = 1.0,
    on_model: Callable[[str, StepModel, FitReport], None] | None = None,
) -> tuple[dict[str, StepModel], dict[str, FitReport]]:
    """Fit the requested model kinds and score each on the broad validation record.

    Every surrogate is scored on the same broad-range record: scoring the PLM on
    its own five bias records would mostly measure the offsets between biases
    and flatter it. ``on_model`` hears of each model as soon as it is fitted and
    scored (the identifier node saves it then, so agents on it can start).
    """
    req = FitRequest(records, seed, plant.L, plant.F, nlarx_scale)
    models: dict[str, StepModel] = {}
    fits: dict[str, FitReport] = {}
    for name in names:
        models[name] = fit_model(name, req)
        fits[name] = identify.evaluate(models[name], records.broad_val)
        if on_model is not None:
            on_model(name, models[name], fits[name])
    return models, fits


@dataclass(frozen=True)
class Trained:
    """One agent kind trained over a batch of seeds and validated on the plant."""

    q: FloatArray
    first: FloatArray
    last: FloatArray
    x: FloatArray
    metrics: list[dict[str, float]]
    real_interactions: int
    robustness: dict[str, dict[str, Any]]
    """Per scenario id: the same tables under that scenario (:func:`robustness.evaluate`)."""


def train_and_validate(kind: str, surrogate: StepModel, cfg: RunConfig, seeds: Sequence[int],
                       scenarios: bool = True) -> Trained:
    """Train ``seeds`` on ``surrogate`` (or Dyna-Q on the plant), then run greedily on the plant.

    With ``scenarios`` the fixed tables are also run under the scenario suite
    (the robustness table); sweeps that only count nominal successes skip it.
    """
    k, qc = agent_kind(kind), cfg.qconfig(kind)
    plant = plant_model(cfg.plant)
    if k.dyna:
        dres = train_dyna(plant, DynaConfig(qc, planning_steps=cfg.planning_steps), seeds)
        q, snaps, real = dres.q, dres.snapshots, int(dres.real_steps.sum())
    else:
        tres = train(surrogate, qc, seeds)
        q, snaps = tres.q, tres.snapshots
        real = len(seeds) * qc.episodes * qc.steps if k.surrogate == PLANT else 0
    x, _ = greedy_rollouts(plant, q, qc, cfg.target, cfg.validation_steps, observer=surrogate)
    rows = [metric_row(xi, cfg.target, cfg.plant.dt, cfg.window) for xi in x]
    rob = robustness.evaluate(q, qc, cfg.plant, seeds, cfg.scenario_suite(), steps=cfg.validation_steps,
                              window=cfg.window, observer=surrogate) if scenarios else {}
    return Trained(q, snaps[:, 0], snaps[:, -1], x, rows, real, rob)


def run_paper(cfg: RunConfig, progress: Progress | None = None) -> PaperRun:
    """The whole method for every requested agent kind, over id seeds × learning seeds."""
    run = PaperRun(cfg)
    tell = progress or (lambda stage, done, total: None)
    parts: dict[str, list[tuple[Trained, list[int], int]]] = {a: [] for a in cfg.agents}
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
            parts[a].append((train_and_validate(a, surrogate, cfg, seeds), seeds, id_seed))
            done += 1
    for a in on_plant:
        tell(f"train {a}", done, total)
        seeds = cfg.learning_seeds(0)
        parts[a].append((train_and_validate(a, plant_model(cfg.plant), cfg, seeds), seeds, cfg.id_first_seed))
        done += 1
    tell("done", total, total)
    for a in cfg.agents:
        _collect(run, a, parts[a])
    return run


def _collect(run: PaperRun, kind: str, parts: list[tuple[Trained, list[int], int]]) -> None:
    """Table-1 row, responses, Q-tables (with the learner config) and robustness of one kind."""
    cfg = run.config
    k = agent_kind(kind)
    rows = [per_seed_row(s, id_seed, m) for t, seeds, id_seed in parts
            for s, m in zip(seeds, t.metrics, strict=True)]
    fits = {i: f[k.surrogate] for i, f in run.fits.items()} if k.surrogate != PLANT else {}
    notes = [budget_note(kind, cfg.dyna_episodes)]
    run.results.append(agent_result(kind, rows, fits, sum(t.real_interactions for t, _, _ in parts), notes))
    trained = [t for t, _, _ in parts]
    run.responses[kind] = np.concatenate([t.x for t in trained])
    qc = cfg.qconfig(kind)
    run.qtables[kind] = {
        "q": np.concatenate([t.q for t in trained]),
        "first": np.concatenate([t.first for t in trained]),
        "last": np.concatenate([t.last for t in trained]),
        "seeds": [s for _, seeds, _ in parts for s in seeds],
        "learner": qc,
    }
    run.robustness[kind] = robustness.merge([t.robustness for t in trained])
