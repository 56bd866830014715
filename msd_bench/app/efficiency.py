"""The data-efficiency curve: closed-loop success against the real-plant samples each route used.

The paper's title claim — identification first, then learning on the model, is
more data-efficient than learning on the plant — is shown there as one point
per method. Here it is a curve per method:

* the **surrogate route** (GLM, PLM, improved NLARX, grey-box): identification
  records from about 1,000 to 60,000 plant samples in total — settle segments
  and the validation record included — then agents trained on the model only;
* the **on-plant route** (Q-learning on the plant, Dyna-Q): training budgets
  from about 30,000 to 900,000 real steps.

Each point is ``n`` agents validated on the true plant (success = SSE < 5 %),
with its Wilson 95 % interval.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from msd_bench.app.agents import PLANT, agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import identify_surrogates, records_from_plan, train_and_validate
from msd_bench.app.plan import paper_plan, real_samples
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.model import plant_model
from msd_bench.core.registry import model_kind
from msd_bench.core.results import SUCCESS_SSE
from msd_bench.core.stats import wilson

Progress = Callable[[str, int, int], None]

RECORD_SAMPLES = (300, 1_000, 2_500, 6_000, 12_000)
"""Samples per identification record; with settle and validation, 1k–60k plant samples in total."""
EPISODES = (10, 30, 100, 300)
"""On-plant training budgets in episodes of 3,000 steps: 30,000 to 900,000 real steps."""
SURROGATE_AGENTS = ("plm+improved", "nlarx-improved+improved", "greybox+improved", "glm+improved")
PLANT_AGENTS = ("plant+improved", "plant", "dyna-q")


@dataclass(frozen=True)
class EfficiencyConfig:
    """What the curve sweeps."""

    run: RunConfig
    """Seeds, preset, budgets of every point (``run.agents`` is ignored)."""
    surrogate_agents: tuple[str, ...] = SURROGATE_AGENTS
    """Agent kinds of the surrogate route (one line each)."""
    plant_agents: tuple[str, ...] = PLANT_AGENTS
    """Agent kinds of the on-plant route (one line each)."""
    record_samples: tuple[int, ...] = RECORD_SAMPLES
    """Samples per identification record at each point of the surrogate route."""
    episodes: tuple[int, ...] = EPISODES
    """Training episodes at each point of the on-plant route."""

    def __post_init__(self) -> None:
        for kind in (*self.surrogate_agents, *self.plant_agents):
            agent_kind(kind)
        if any(agent_kind(k).surrogate == PLANT for k in self.surrogate_agents):
            raise ConfigError("surrogate_agents must train on an identified model")
        if any(agent_kind(k).surrogate != PLANT for k in self.plant_agents):
            raise ConfigError("plant_agents must learn on the plant (plant, dyna-q)")
        if min(self.record_samples, default=1) < 100 or min(self.episodes, default=1) < 1:
            raise ConfigError("record samples must be >= 100 and episodes >= 1")


def settle_for(n: int) -> int:
    """Settle segment before a PRBS record of ``n`` samples: the paper's 1,000, shorter for tiny records."""
    return min(1_000, max(50, n // 4))


def validation_samples(n: int) -> int:
    """Validation record length: a third of the training record, but never so short that it may hold
    a single level of the multilevel signal (its dwell reaches 300 samples)."""
    return max(1_000, n // 3)


def _point(n_success: int, n: int, real: int) -> dict[str, Any]:
    return {"real_samples": int(real), "n": n, "n_success": n_success, "ci95": list(wilson(n_success, n))}


def surrogate_points(cfg: EfficiencyConfig, tell: Progress) -> dict[str, list[dict[str, Any]]]:
    """One point per record length for every surrogate-route agent kind."""
    run = cfg.run
    out: dict[str, list[dict[str, Any]]] = {k: [] for k in cfg.surrogate_agents}
    models_needed = list(dict.fromkeys(agent_kind(k).surrogate for k in cfg.surrogate_agents))
    for i, n in enumerate(cfg.record_samples):
        tell(f"surrogate route, {n} samples per record", i, len(cfg.record_samples))
        wins: dict[str, int] = dict.fromkeys(cfg.surrogate_agents, 0)
        reals: dict[str, int] = {}
        failed: dict[str, str] = {}
        for j, id_seed in enumerate(run.id_seed_values()):
            plan = paper_plan(id_seed, n, validation_samples(n), settle_for(n))
            records = records_from_plan(run.plant, plan)
            for name in models_needed:
                try:
                    models, _ = identify_surrogates(records, [name], id_seed, run.plant, run.nlarx_scale)
                except MsdBenchError as err:  # too little data to identify: the route fails here
                    failed[name] = str(err)
                    continue
                for kind in (k for k in cfg.surrogate_agents if agent_kind(k).surrogate == name):
                    seeds = run.learning_seeds(j)
                    trained = train_and_validate(kind, models[name], run, seeds, scenarios=False)
                    wins[kind] += sum(m["sse"] < SUCCESS_SSE for m in trained.metrics)
            for kind in cfg.surrogate_agents:
                reals[kind] = real_samples(plan, model_kind(agent_kind(kind).surrogate).records)
        for kind in cfg.surrogate_agents:
            point = _point(wins[kind], run.seeds * run.id_seeds, reals[kind])
            if agent_kind(kind).surrogate in failed:  # agents of a failed identification count as failures
                point["identification_failed"] = failed[agent_kind(kind).surrogate]
            out[kind].append(point)
    return out


def plant_points(cfg: EfficiencyConfig, tell: Progress) -> dict[str, list[dict[str, Any]]]:
    """One point per training budget for every on-plant agent kind."""
    out: dict[str, list[dict[str, Any]]] = {k: [] for k in cfg.plant_agents}
    plant = plant_model(cfg.run.plant)
    seeds = [s for j in range(cfg.run.id_seeds) for s in cfg.run.learning_seeds(j)]
    for i, episodes in enumerate(cfg.episodes):
        tell(f"on-plant route, {episodes} episodes", i, len(cfg.episodes))
        run = replace(cfg.run, episodes=episodes, dyna_episodes=episodes)
        for kind in cfg.plant_agents:
            trained = train_and_validate(kind, plant, run, seeds, scenarios=False)
            wins = sum(m["sse"] < SUCCESS_SSE for m in trained.metrics)
            out[kind].append(_point(wins, len(seeds), trained.real_interactions // len(seeds)))
    return out


def efficiency(cfg: EfficiencyConfig, progress: Progress | None = None) -> dict[str, Any]:
    """``efficiency.json``: per method, success with its interval at each real-sample budget."""
    tell = progress or (lambda stage, done, total: None)
    return document({**surrogate_points(cfg, tell), **plant_points(cfg, tell)})


def document(lines: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """``efficiency.json`` from each method's points (the command builds it from its route files)."""
    return {
        "schema": "msd-bench/efficiency", "schema_version": 1,
        "success_sse_percent": SUCCESS_SSE,
        "methods": [{"name": kind, "label": agent_kind(kind).label, "points": pts}
                    for kind, pts in lines.items()],
    }


def reaches(points: Sequence[dict[str, Any]], rate: float) -> int | None:
    """Fewest real samples at which a method's success rate reaches ``rate`` (None if never)."""
    for p in sorted(points, key=lambda p: p["real_samples"]):
        if p["n"] and p["n_success"] / p["n"] >= rate:
            return int(p["real_samples"])
    return None


def crossings(methods: Sequence[dict[str, Any]]) -> list[str]:
    """Where each method first reaches the final success rate of each on-plant Q-learner."""
    lines = []
    refs = [m for m in methods if agent_kind(m["name"]).surrogate == PLANT and not agent_kind(m["name"]).dyna]
    for ref in refs:
        final = max(ref["points"], key=lambda p: p["real_samples"])
        rate = final["n_success"] / final["n"]
        lines.append(f"{ref['label']} at {final['real_samples']:,} real steps: {100 * rate:.0f} % success; "
                     "reached by:")
        for m in methods:
            at = reaches(m["points"], rate)
            where = f"{at:,} real samples" if at is not None else "not in the sweep"
            lines.append(f"  {m['label']}: {where}")
    return lines
