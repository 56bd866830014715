"""The paper's whole method in-process (no ROS): records → models → agents → Table 1.

Stages, each a function the ROS graph reuses:

1. :func:`make_records` — excite the plant (five PRBS bias experiments for the
   PLM, one multilevel record for GLM/NLARX, and separate validation records);
2. :func:`identify_surrogates` — fit GLM, PLM, NLARX (paper and improved);
3. :func:`train_and_validate` — train a batch of seeds on one surrogate, run
   each greedy table on the true plant, score it (paper §5);
4. :func:`run_paper` — all of it over identification seeds × learning seeds.

The result is a distribution per agent kind, never a single number.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from msd_bench.core import identify, robustness
from msd_bench.core.agents import AGENT_KINDS, SURROGATES, AgentKind, check_agents
from msd_bench.core.data import IOData
from msd_bench.core.dyna import DynaConfig, train_dyna
from msd_bench.core.errors import ConfigError
from msd_bench.core.excitation import MultilevelConfig, PrbsConfig
from msd_bench.core.identify import FitReport
from msd_bench.core.metrics import compute
from msd_bench.core.model import StepModel, plant_model
from msd_bench.core.nlarx import NlarxConfig
from msd_bench.core.plant import PlantParams, preset
from msd_bench.core.qconfig import QConfig, improved_config
from msd_bench.core.qtrain import greedy_rollouts, train
from msd_bench.core.results import AgentResult, per_seed_row
from msd_bench.core.sensor import SensorModel  # [h2, issue 11]

FloatArray = NDArray[np.float64]
Progress = Callable[[str, int, int], None]

PLM_BIASES = (-10.0, -5.0, 0.0, 5.0, 10.0)


@dataclass(frozen=True)
class PaperConfig:
    """A run of ``msd-bench paper`` / ``bench.py`` (defaults = the paper's budgets)."""

    preset: str = "default"
    """Plant preset (``default`` or ``mild``, DESIGN.md §2)."""
    seeds: int = 20
    """Learning seeds per identification seed and agent kind."""
    first_seed: int = 0
    """First learning seed; seeds are first_seed, first_seed + 1, ..."""
    id_seeds: int = 1
    """Identification seeds: each re-records and re-identifies every surrogate."""
    agents: tuple[str, ...] = tuple(AGENT_KINDS)
    """Agent kinds (rows) to run, from :data:`AGENT_KINDS`."""
    episodes: int = 300
    """Training episodes per agent (paper: 300)."""
    steps: int = 3000
    """Steps per training episode (paper: 3,000)."""
    dyna_episodes: int = 300
    """Dyna-Q episodes on the true plant (paper: 300; each is 3,000 real interactions)."""
    planning_steps: int = 100
    """Dyna-Q planning updates per real step (paper: 100)."""
    samples: int = 12_000
    """Samples per identification record (paper: 12,000)."""
    val_samples: int = 4_000
    """Samples per validation record (separate seeds from the training records)."""
    validation_steps: int = 3000
    """Closed-loop validation length on the true plant (paper: 3,000)."""
    target: float = 1.0
    """Validation set-point, m (paper: unit step)."""
    window: int = 500
    """Terminal window of the SSE, samples (paper: not given)."""
    nlarx_scale: float = 1.0
    """Multiplies the NLARX training iterations (< 1 for smoke runs)."""

    def __post_init__(self) -> None:
        check_agents(self.agents)
        preset(self.preset)  # an unknown preset fails here, naming the choices
        for name in ("seeds", "id_seeds", "episodes", "steps", "dyna_episodes", "samples",
                     "val_samples", "validation_steps", "window"):
            if int(getattr(self, name)) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.window > self.validation_steps:
            raise ConfigError("window must not exceed validation_steps")
        if not 0 < self.nlarx_scale <= 10:
            raise ConfigError(f"nlarx_scale must be in (0, 10], got {self.nlarx_scale}")

    @property
    def plant(self) -> PlantParams:
        """The true plant's parameters."""
        return preset(self.preset)

    def learning_seeds(self) -> list[int]:
        """The learning seeds of one identification seed."""
        return list(range(self.first_seed, self.first_seed + self.seeds))

    def qconfig(self, agent: str) -> QConfig:
        """Learner settings of the paper agent or of our improved agent."""
        base = improved_config() if agent == "improved" else QConfig()
        return replace(base, episodes=self.episodes, steps=self.steps, force=self.plant.F)

    def surrogates_needed(self) -> list[str]:
        """Surrogates that at least one requested agent kind trains on."""
        need = {AGENT_KINDS[a].surrogate for a in self.agents}
        return [s for s in SURROGATES if s in need]


@dataclass(frozen=True)
class Records:
    """Identification and validation data of one identification seed."""

    bias_train: dict[float, IOData]
    """PRBS record per bias (settling dropped)."""
    bias_val: dict[float, IOData]
    """Validation PRBS record per bias (other seeds; may be empty: only figures use it)."""
    broad_train: IOData
    """Multilevel record for GLM and NLARX."""
    broad_val: IOData
    """Validation multilevel record."""


@dataclass
class PaperRun:
    """Everything a run produced, for the report and the figures."""

    config: PaperConfig
    results: list[AgentResult] = field(default_factory=list)
    models: dict[int, dict[str, StepModel]] = field(default_factory=dict)
    """Surrogates per identification seed."""
    fits: dict[int, dict[str, FitReport]] = field(default_factory=dict)
    """Validation fits per identification seed and surrogate."""
    responses: dict[str, FloatArray] = field(default_factory=dict)
    """Greedy closed-loop positions on the plant, per agent kind (seeds × steps)."""
    qtables: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Per agent kind: final tables, first/last snapshots, seeds."""
    robustness: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)
    """Per agent kind and scenario: the fixed tables on perturbed plants / other set-points."""
    records: dict[int, Records] = field(default_factory=dict)


def record_seeds(id_seed: int) -> tuple[int, int]:
    """(training, validation) excitation seeds of an identification seed: never equal."""
    return 1000 + 10 * id_seed, 5000 + 10 * id_seed


def make_records(cfg: PaperConfig, id_seed: int, sensor: SensorModel | None = None) -> Records:
    """Drive the true plant with the paper's excitations (in-process).

    [h2, issue 11] ``sensor``: measure every record through this sensor model
    (noise seeded from each record's excitation seed); the noise-free position
    stays in ``Experiment.truth`` for ``fit_sim_truth_percent``.
    """
    p = cfg.plant
    train_seed, val_seed = record_seeds(id_seed)
    prbs_t, prbs_v = PrbsConfig(n_samples=cfg.samples), PrbsConfig(n_samples=cfg.val_samples)
    multi_t, multi_v = MultilevelConfig(n_samples=cfg.samples), MultilevelConfig(n_samples=cfg.val_samples)
    return Records(
        {b: identify.bias_record(p, b, train_seed + i, prbs_t, sensor) for i, b in enumerate(PLM_BIASES)},
        {b: identify.bias_record(p, b, val_seed + i, prbs_v, sensor) for i, b in enumerate(PLM_BIASES)},
        identify.broad_record(p, train_seed + 7, multi_t, sensor),
        identify.broad_record(p, val_seed + 7, multi_v, sensor),
    )


def nlarx_config(form: str, seed: int, scale: float = 1.0) -> NlarxConfig:
    """NLARX settings of a form, with training iterations scaled for smoke runs."""
    base = NlarxConfig(form=form, seed=seed)
    return replace(
        base,
        one_step_iters=max(1, round(base.one_step_iters * scale)),
        sim_iters=round(base.sim_iters * scale),
    )


def identify_surrogates(
    records: Records, names: Sequence[str], seed: int, stroke: float = 5.0, nlarx_scale: float = 1.0
) -> tuple[dict[str, StepModel], dict[str, FitReport]]:
    """Fit the requested surrogates and score each on the broad validation record."""
    models: dict[str, StepModel] = {}
    for name in names:
        if name == "glm":
            models[name] = identify.identify_glm(records.broad_train, identify.GlmConfig(stroke=stroke))
        elif name == "plm":
            models[name] = identify.identify_plm(records.bias_train, identify.PlmConfig(stroke=stroke))
        else:
            form = name.removeprefix("nlarx-")
            models[name] = identify.identify_nlarx(
                records.broad_train, nlarx_config(form, seed, nlarx_scale), stroke)
    fits = {name: identify.evaluate(m, _validation_for(name, records)) for name, m in models.items()}
    return models, fits


def _validation_for(name: str, records: Records) -> IOData:
    """Every surrogate is scored on the same broad-range validation record.

    Scoring the PLM on its own five bias records would mostly measure the
    offsets between biases (a concatenation of five levels) and flatter it.
    """
    return records.broad_val


@dataclass(frozen=True)
class Trained:
    """One agent kind trained over a batch of seeds and validated on the plant."""

    q: FloatArray
    first: FloatArray
    last: FloatArray
    x: FloatArray
    metrics: list[dict[str, float]]
    real_interactions: int


def train_and_validate(
    kind: AgentKind, surrogate: StepModel, cfg: PaperConfig, seeds: Sequence[int]
) -> Trained:
    """Train ``seeds`` on ``surrogate`` (or Dyna-Q on the plant), then run greedily on the plant."""
    qc = cfg.qconfig(kind.agent)
    plant = plant_model(cfg.plant)
    if kind.dyna:
        dcfg = DynaConfig(replace(qc, episodes=cfg.dyna_episodes), planning_steps=cfg.planning_steps)
        dres = train_dyna(plant, dcfg, seeds)
        q, snaps, real = dres.q, dres.snapshots, int(dres.real_steps.sum())
    else:
        tres = train(surrogate, qc, seeds)
        q, snaps = tres.q, tres.snapshots
        real = len(seeds) * qc.episodes * qc.steps if kind.surrogate == "plant" else 0
    x, _ = greedy_rollouts(plant, q, qc, cfg.target, cfg.validation_steps)
    rows = [_metric_row(compute(xi, cfg.target, cfg.plant.dt, cfg.window)) for xi in x]
    return Trained(q, snaps[:, 0], snaps[:, -1], x, rows, real)


def _metric_row(m: Any) -> dict[str, float]:
    return {"mae": m.mae, "std": m.std, "po": m.po, "ts": m.ts2, "ts5": m.ts5, "sse": m.sse}


def run_paper(cfg: PaperConfig, progress: Progress | None = None) -> PaperRun:
    """The whole method for every requested agent kind, over id seeds × learning seeds."""
    run = PaperRun(cfg)
    tell = progress or (lambda stage, done, total: None)
    seeds = cfg.learning_seeds()
    surrogate_kinds = [a for a in cfg.agents if AGENT_KINDS[a].surrogate != "plant"]
    per_seed: dict[str, list[dict[str, Any]]] = {a: [] for a in cfg.agents}
    parts: dict[str, list[Trained]] = {a: [] for a in cfg.agents}
    total = cfg.id_seeds * (1 + len(surrogate_kinds)) + (len(cfg.agents) - len(surrogate_kinds))
    done = 0
    for id_seed in range(cfg.id_seeds):
        tell(f"identify (id seed {id_seed})", done, total)
        records = make_records(cfg, id_seed)
        run.records[id_seed] = records
        run.models[id_seed], run.fits[id_seed] = identify_surrogates(
            records, cfg.surrogates_needed(), id_seed, cfg.plant.L, cfg.nlarx_scale)
        done += 1
        for a in surrogate_kinds:
            tell(f"train {a} (id seed {id_seed})", done, total)
            kind = AGENT_KINDS[a]
            trained = train_and_validate(kind, run.models[id_seed][kind.surrogate], cfg, seeds)
            _collect(per_seed[a], parts[a], trained, seeds, id_seed)
            done += 1
    for a in cfg.agents:
        if AGENT_KINDS[a].surrogate == "plant":
            tell(f"train {a}", done, total)
            trained = train_and_validate(AGENT_KINDS[a], plant_model(cfg.plant), cfg, seeds)
            _collect(per_seed[a], parts[a], trained, seeds, 0)
            done += 1
    tell("done", total, total)
    for a in cfg.agents:
        run.results.append(_agent_result(AGENT_KINDS[a], run, per_seed[a], parts[a]))
        run.responses[a] = np.concatenate([t.x for t in parts[a]])
        run.qtables[a] = {
            "q": np.concatenate([t.q for t in parts[a]]),
            "first": np.concatenate([t.first for t in parts[a]]),
            "last": np.concatenate([t.last for t in parts[a]]),
        }
        run.robustness[a] = robustness.evaluate(
            run.qtables[a]["q"], cfg.qconfig(AGENT_KINDS[a].agent), cfg.plant,
            steps=cfg.validation_steps, window=cfg.window)
    return run


def _collect(rows: list[dict[str, Any]], parts: list[Trained], trained: Trained,
             seeds: Sequence[int], id_seed: int) -> None:
    parts.append(trained)
    rows.extend(per_seed_row(s, id_seed, m) for s, m in zip(seeds, trained.metrics, strict=True))


def _agent_result(kind: AgentKind, run: PaperRun, rows: list[dict[str, Any]],
                  parts: list[Trained]) -> AgentResult:
    cfg = run.config
    fit_sim = fit_one = None
    by_id: list[dict[str, Any]] = []
    n_id = 0
    if kind.surrogate != "plant":
        reports = [run.fits[i][kind.surrogate] for i in sorted(run.fits)]
        fit_sim = float(np.mean([r.sim_fit for r in reports]))
        fit_one = float(np.mean([r.one_step_fit for r in reports]))
        # [h2, issue 11] each entry also carries fit_sim_truth_percent and fit_sim_raw_start_percent
        by_id = [{"id_seed": i, **r.as_row()} for i, r in zip(sorted(run.fits), reports, strict=True)]
        n_id = reports[0].n_identification
    notes = ""
    if kind.dyna and cfg.dyna_episodes != 300:
        notes = f"reduced budget: {cfg.dyna_episodes} Dyna-Q episodes instead of the paper's 300"
    return AgentResult(
        kind=kind.kind, label=kind.label, surrogate=kind.surrogate, agent=kind.agent,
        identification_samples=n_id, fit_sim=fit_sim, fit_one_step=fit_one, per_seed=tuple(rows),
        real_interactions=sum(t.real_interactions for t in parts), notes=notes,
        fit_by_id_seed=tuple(by_id),
    )
