"""The data-efficiency curve: closed-loop success against the real-plant samples each route used.

The paper's title claim — identification first, then learning on the model, is
more data-efficient than learning on the plant — is shown there as one point
per method. Here it is a curve per method:

* the **surrogate route** (GLM, PLM, improved NLARX, grey-box): identification
  records from about 1,000 to 60,000 plant samples in total — settle segments
  and the validation record included — then agents trained on the model only;
* the **on-plant route** (Q-learning on the plant, Dyna-Q): training budgets
  from about 30,000 to 900,000 real steps. The deep-RL baselines on the plant
  (``plant+dqn``, ``plant+ppo``) are opt-in kinds of this route
  (``--agents plant+dqn``): every environment step of their budget is a real
  sample.

Each point is ``n`` agents validated on the true plant (success = SSE < 5 %),
with its Wilson 95 % interval.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from msd_bench.app.agents import agent_kind
from msd_bench.app.config import RunConfig
from msd_bench.app.executor import task_name
from msd_bench.app.pipeline import identify_surrogates, records_from_plan, train_and_validate
from msd_bench.app.plan import paper_plan, real_samples
from msd_bench.core.errors import ConfigError, MsdBenchError
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.stats import wilson
from msd_bench.core.identification.model_kinds import model_kind
from msd_bench.core.physics.model import plant_model
from msd_bench.designs import kinds

Progress = Callable[[str, int, int], None]

RECORD_SAMPLES = (300, 1_000, 2_500, 6_000, 12_000)
"""Samples per identification record; with settle and validation, 1k–60k plant samples in total."""
EPISODES = (10, 30, 100, 300)
"""On-plant training budgets in episodes of 3,000 steps: 30,000 to 900,000 real steps."""
SURROGATE_AGENTS = kinds.EFFICIENCY_SURROGATE
PLANT_AGENTS = kinds.EFFICIENCY_PLANT


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
        on_model, on_plant = kinds.split_by_model([*self.surrogate_agents, *self.plant_agents])
        if set(on_plant) & set(self.surrogate_agents):
            raise ConfigError("surrogate_agents must train on an identified model")
        if set(on_model) & set(self.plant_agents):
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


def surrogate_point(cfg: EfficiencyConfig, n: int, j: int) -> dict[str, Any]:
    """One task of the surrogate route: record length ``n`` at the ``j``-th identification seed.

    Returns, per agent kind, the successes of its learning seeds and the real
    samples the records cost, and per model kind that could not be identified
    from so little data, why (its agents then count as failures).
    """
    run = cfg.run
    id_seed = run.id_seed_values()[j]
    plan = paper_plan(id_seed, n, validation_samples(n), settle_for(n))
    records = records_from_plan(run.plant, plan)
    wins: dict[str, int] = dict.fromkeys(cfg.surrogate_agents, 0)
    runs: dict[str, int] = dict.fromkeys(cfg.surrogate_agents, 0)
    failed: dict[str, str] = {}
    for name in dict.fromkeys(agent_kind(k).surrogate for k in cfg.surrogate_agents):
        try:
            models, _ = identify_surrogates(records, [name], id_seed, run.plant, run.nlarx_scale)
        except MsdBenchError as err:  # too little data to identify: the route fails here
            failed[name] = str(err)
            continue
        for kind in (k for k in cfg.surrogate_agents if agent_kind(k).surrogate == name):
            trained = train_and_validate(kind, models[name], run, run.learning_seeds(j))
            wins[kind] += sum(m["sse"] < SUCCESS_SSE for m in trained.metrics)
            runs[kind] += len(trained.metrics)  # a deterministic policy: one run per model
    reals = {k: real_samples(plan, model_kind(agent_kind(k).surrogate).records) for k in cfg.surrogate_agents}
    return {"wins": wins, "runs": runs, "real_samples": reals, "failed": failed}


def plant_point(cfg: EfficiencyConfig, episodes: int, kind: str) -> dict[str, Any]:
    """One task of the on-plant route: agent kind ``kind`` at a budget of ``episodes``, every seed."""
    seeds = [s for j in range(cfg.run.id_seeds) for s in cfg.run.learning_seeds(j)]
    run = replace(cfg.run, episodes=episodes, dyna_episodes=episodes)
    trained = train_and_validate(kind, plant_model(cfg.run.plant), run, seeds)
    wins = sum(m["sse"] < SUCCESS_SSE for m in trained.metrics)
    real = trained.real_interactions // len(trained.metrics)  # per agent, as the surrogate route
    return _point(wins, len(trained.metrics), real)


def surrogate_tasks(cfg: EfficiencyConfig) -> list[tuple[str, int, int]]:
    """The surrogate route's tasks: ``(task id, record length, identification seed index)``; none
    without surrogate kinds (``--agents plant+dqn`` sweeps the on-plant route only, no identification)."""
    if not cfg.surrogate_agents:
        return []
    return [(f"surrogate-n{n}-id{cfg.run.id_seed_values()[j]}", n, j)
            for n in cfg.record_samples for j in range(cfg.run.id_seeds)]


def plant_tasks(cfg: EfficiencyConfig) -> list[tuple[str, int, str]]:
    """The on-plant route's tasks: ``(task id, episodes, agent kind)``."""
    return [(f"plant-e{e}-{task_name(kind)}", e, kind) for e in cfg.episodes for kind in cfg.plant_agents]



Parts = dict[str, dict[str, Any]]
"""Task results keyed by task id."""


def surrogate_lines(cfg: EfficiencyConfig, parts: Parts) -> dict[str, list[dict[str, Any]]]:
    """Each surrogate-route kind's points from its tasks' results (keyed by task id)."""
    out: dict[str, list[dict[str, Any]]] = {k: [] for k in cfg.surrogate_agents}
    for n in cfg.record_samples:
        got = [parts[tid] for tid, m, _ in surrogate_tasks(cfg) if m == n]
        for kind in cfg.surrogate_agents:
            wins, runs = sum(g["wins"][kind] for g in got), sum(g["runs"][kind] for g in got)
            n = runs or cfg.run.seeds * cfg.run.id_seeds  # a failed identification: every agent failed
            point = _point(wins, n, got[-1]["real_samples"][kind])
            failed = [g["failed"][agent_kind(kind).surrogate] for g in got
                      if agent_kind(kind).surrogate in g["failed"]]
            if failed:  # agents of a failed identification count as failures
                point["identification_failed"] = failed[-1]
            out[kind].append(point)
    return out


def plant_lines(cfg: EfficiencyConfig, parts: Parts) -> dict[str, list[dict[str, Any]]]:
    """Each on-plant kind's points from its tasks' results (keyed by task id)."""
    out: dict[str, list[dict[str, Any]]] = {k: [] for k in cfg.plant_agents}
    for tid, _, kind in plant_tasks(cfg):
        out[kind].append(parts[tid])
    return out


def efficiency(cfg: EfficiencyConfig, progress: Progress | None = None) -> dict[str, Any]:
    """``efficiency.json`` computed in this process, task after task (the command spreads the tasks
    over an executor and writes each; both give the same document)."""
    tell = progress or (lambda stage, done, total: None)
    total = len(surrogate_tasks(cfg)) + len(plant_tasks(cfg))
    parts: Parts = {}
    for tid, n, j in surrogate_tasks(cfg):
        tell(tid, len(parts), total)
        parts[tid] = surrogate_point(cfg, n, j)
    for tid, e, kind in plant_tasks(cfg):
        tell(tid, len(parts), total)
        parts[tid] = plant_point(cfg, e, kind)
    return document({**surrogate_lines(cfg, parts), **plant_lines(cfg, parts)})


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
    """Where each method first reaches the final success rate of each on-plant Q-learner (a deep-RL
    or other baseline on the plant is a method like the others, never the reference)."""
    lines = []
    references = set(kinds.plant_references([m["name"] for m in methods]))
    refs = [m for m in methods if m["name"] in references]
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
