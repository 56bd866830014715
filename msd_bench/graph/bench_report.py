"""The bench's report stage: read what the node processes wrote, write Table 1 and figures.

Everything comes from files of the run (model artifacts, ``fits.json``, each
agent's ``result.json``, Q-tables and validation bags), so the report can be
rebuilt at any time with ``bench.py --stages report --out <run>``.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from msd_bench.core import robustness
from msd_bench.core.identify import FitReport
from msd_bench.core.pipeline import AGENT_KINDS, PaperConfig, PaperRun
from msd_bench.core.plant import preset
from msd_bench.core.qconfig import QConfig, improved_config
from msd_bench.core.results import AgentResult
from msd_bench.io import artifacts
from msd_bench.io.bag_records import load_records, roles_from_dir
from msd_bench.io.bags import UNCHECKED, read_experiment
from msd_bench.io.report import write_report, write_robustness
from msd_bench.io.run_output import write_figures

from .bench import BenchConfig


def load_results(cfg: BenchConfig) -> list[AgentResult]:
    """One Table-1 row per agent kind that wrote a result."""
    fits = _fits(cfg)
    rows = []
    for kind in cfg.agents:
        path = cfg.run_dir / "agents" / kind / "result.json"
        if not path.is_file():
            continue
        doc = json.loads(path.read_text())
        k = AGENT_KINDS[kind]
        fit = fits.get(k.surrogate)
        notes = [] if doc["training"] == "in-process" else [f"trained {doc['training']}"]
        if k.dyna and cfg.dyna_episodes != 300:
            notes.append(f"reduced budget: {cfg.dyna_episodes} Dyna-Q episodes instead of the paper's 300 "
                         f"(every one is 3,000 real steps on the plant node)")
        rows.append(AgentResult(
            kind=kind, label=k.label, surrogate=k.surrogate, agent=k.agent,
            identification_samples=int(fit.n_identification) if fit else 0,
            fit_sim=fit.sim_fit if fit else None, fit_one_step=fit.one_step_fit if fit else None,
            per_seed=tuple(doc["per_seed"]), real_interactions=int(doc["real_interactions"]),
            notes="; ".join(notes)))
    return rows


def _fits(cfg: BenchConfig) -> dict[str, FitReport]:
    path = cfg.run_dir / "models" / "fits.json"
    if not path.is_file():
        return {}
    return {name: FitReport(**doc) for name, doc in json.loads(path.read_text()).items()}


def figure_run(cfg: BenchConfig, results: list[AgentResult]) -> PaperRun:
    """A :class:`PaperRun` rebuilt from the run's files, for the shared figure writer."""
    run = PaperRun(PaperConfig(preset=cfg.preset), results)
    models = {name: artifacts.load_model(cfg.run_dir / "models" / f"{name}.json")
              for name in cfg.surrogates() if (cfg.run_dir / "models" / f"{name}.json").is_file()}
    run.models[0], run.fits[0] = models, _fits(cfg)
    run.records[0] = load_records(roles_from_dir(cfg.excitation_dir), "plm" in models)
    for r in results:
        agent_dir = cfg.run_dir / "agents" / r.kind
        arrays, _ = artifacts.load_qtables(agent_dir / "qtables.npz")
        run.qtables[r.kind] = arrays
        run.responses[r.kind] = np.stack([
            read_experiment(agent_dir / "validation" / f"seed_{s['seed']}", timing=UNCHECKED)[0].y
            for s in r.per_seed])
    return run


def write_bench_report(cfg: BenchConfig, facts: dict[str, Any]) -> dict[str, Any]:
    """Table 1 (md/csv/json) and figures under ``report/``."""
    results = load_results(cfg)
    out = cfg.run_dir / "report"
    paths: dict[str, Any] = {"table": write_report(out, results, facts)}
    run = figure_run(cfg, results)
    paths["figures"] = write_figures(out / "figures", run)
    rob = {r.kind: robustness.evaluate(run.qtables[r.kind]["q"], _qconfig(r.agent), preset(cfg.preset),
                                       steps=cfg.validation_steps, window=cfg.window) for r in results}
    paths["robustness"] = write_robustness(out, rob, {r.kind: r.label for r in results})
    return paths


def _qconfig(agent: str) -> QConfig:
    """The learner settings an agent kind was trained with (its state encoder matters here)."""
    return improved_config() if agent == "improved" else QConfig()
