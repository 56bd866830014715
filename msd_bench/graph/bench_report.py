"""The bench's report stage: read what the node processes wrote, write Table 1 and figures.

Everything comes from files of the run (model artifacts, ``fits.json``, each
agent's ``result.json``, Q-tables with their learner config, and validation
bags), so the report can be rebuilt at any time with
``bench.py --stages report --out <run>``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from msd_bench.app.agents import PLANT, agent_kind, budget_note
from msd_bench.app.scoring import agent_result
from msd_bench.core import robustness
from msd_bench.core.identify import FitReport
from msd_bench.core.model import StepModel
from msd_bench.core.registry import needs_bias_records
from msd_bench.core.results import AgentResult
from msd_bench.io import artifacts
from msd_bench.io.atomic import write_text_atomic
from msd_bench.io.bag_records import load_records, roles_from_dir
from msd_bench.io.bags import UNCHECKED, read_experiment
from msd_bench.io.report import write_report, write_robustness
from msd_bench.io.run_output import FigureData, write_figures

from .bench import BenchConfig
from .run_files import read_fits, read_qtables, read_result


def load_results(cfg: BenchConfig) -> list[AgentResult]:
    """One Table-1 row per agent kind that wrote a result."""
    fits = _fits(cfg)
    rows = []
    for kind in cfg.run.agents:
        path = cfg.run_dir / "agents" / kind / "result.json"
        if not path.is_file():
            continue
        doc = read_result(path)
        fit = fits.get(agent_kind(kind).surrogate)
        notes = [] if doc.training == "in-process" else [f"trained {doc.training}"]
        notes.append(budget_note(kind, cfg.run.dyna_episodes))
        rows.append(agent_result(kind, doc.per_seed, {cfg.id_seed: fit} if fit else {},
                                 doc.real_interactions, notes))
    return rows


def _fits(cfg: BenchConfig) -> dict[str, FitReport]:
    path = cfg.run_dir / "models" / "fits.json"
    if not path.is_file():
        return {}
    return read_fits(path)


def _qtables(cfg: BenchConfig, results: list[AgentResult]) -> dict[str, tuple[dict[str, Any], Any, Any]]:
    """Per agent kind: its Q-table arrays, the learner config and the seeds stored beside them."""
    out = {}
    for r in results:
        tables = read_qtables(cfg.run_dir / "agents" / r.kind / "qtables.npz")
        out[r.kind] = (tables.arrays, tables.learner, tables.seeds)
    return out


def figure_data(cfg: BenchConfig, results: list[AgentResult],
                qtables: dict[str, tuple[dict[str, Any], Any, Any]]) -> FigureData:
    """The figures' inputs rebuilt from the run's files."""
    models_dir = cfg.run_dir / "models"
    models = {name: artifacts.load_model(models_dir / f"{name}.json")
              for name in cfg.run.surrogates_needed() if (models_dir / f"{name}.json").is_file()}
    responses = {r.kind: np.stack([
        read_experiment(cfg.run_dir / "agents" / r.kind / "validation" / f"seed_{s['seed']}",
                        cfg.namespace, timing=UNCHECKED)[0].y
        for s in r.per_seed]) for r in results}
    return FigureData(
        target=cfg.run.target, dt=cfg.run.plant.dt, models=models, fits=_fits(cfg),
        records=load_records(roles_from_dir(cfg.excitation_dir, cfg.namespace, cfg.run.plant.dt),
                             needs_bias_records(models), cfg.namespace, cfg.run.plant.dt,
                             iface=cfg.interface, force_limit=cfg.run.plant.F),
        qtables={k: a for k, (a, _, _) in qtables.items()}, responses=responses)


def _trained_on(cfg: BenchConfig, kind: str) -> StepModel:
    """The model an agent kind trained on: a ``model`` observer predicts with it."""
    k = agent_kind(kind)
    name = "plant" if k.surrogate == PLANT else k.surrogate
    return artifacts.load_model(cfg.run_dir / "models" / f"{name}.json")


def on_node_robustness(cfg: BenchConfig, results: list[AgentResult]) -> dict[str, dict[str, Any]]:
    """Per kind: the nominal validation and every scenario validated *on the node* (a --plant-ns run).

    Never the emulator's model: a foreign node's scenarios are the ones its
    agent processes ran on it (``on_node_scenarios`` in each ``result.json``).
    The table has one column per scenario, so it holds the kinds validated
    under the scenarios (all kinds, nominal only, when there are none).
    """
    rob: dict[str, dict[str, Any]] = {}
    chosen = [r for r in results if r.kind in cfg.scenario_kinds and cfg.node_scenarios] or results
    for r in chosen:
        doc = read_result(cfg.run_dir / "agents" / r.kind / "result.json")
        cells = {"nominal": robustness.cell([s["sse"] for s in r.per_seed], [s["mae"] for s in r.per_seed])}
        cells.update(doc.on_node_scenarios)
        rob[r.kind] = cells
    return rob


def _plant_ns_lines(facts: dict[str, Any]) -> str:
    """What a reader of Table 1 must know about a run on a foreign node."""
    lines = [f"Run against `{facts['plant_ns']}` (no emulator; real time; no reset: zero force until "
             f"still before every experiment and episode; docs/plant-ns.md)."]
    face = facts.get("interface", {})
    if face.get("interface", "msd") != "msd":
        lines.append(f"Through the {face['interface']} face: commands on `{face['command_topic']}` for joint "
                     f"`{face['joint']}`, effort {face['effort']} (docs/ros2-control.md).")
    lines += [f"{facts[k][0].upper()}{facts[k][1:]}." for k in ("left_out", "dyna_budget") if facts[k]]
    scenarios = ", ".join(facts["node_scenarios"]) or "no scenario"
    lines.append(f"Robustness: measured on the node for {scenarios} "
                 f"({', '.join(facts['scenario_kinds']) or 'no kind'}); nothing on the emulator's model.")
    return "\n".join(f"- {line}" for line in lines) + "\n"


def write_bench_report(cfg: BenchConfig, facts: dict[str, Any]) -> dict[str, Any]:
    """Table 1 (md/csv/json), robustness and figures under ``report/``."""
    results = load_results(cfg)
    out, root = cfg.run_dir / "report", cfg.run_dir  # every write stays in the run, no symlink followed
    paths: dict[str, Any] = {"table": write_report(out, results, facts, root=root)}
    qtables = _qtables(cfg, results)
    paths["figures"] = write_figures(out / "figures", figure_data(cfg, results, qtables), root=root)
    if cfg.plant_ns is not None:  # the title names the node, not the emulator's true plant
        md = paths["table"]["md"]
        text = md.read_text().replace(f"on the true plant ({cfg.run.preset} preset)",
                                      f"on {cfg.plant_ns} (real time, measured position)", 1)
        write_text_atomic(md, text.rstrip("\n") + "\n\n" + _plant_ns_lines(facts), root=root)
        rob = on_node_robustness(cfg, results)
    else:
        rob = {kind: robustness.evaluate(arrays["q"], learner, cfg.run.plant, seeds,
                                         cfg.run.scenario_suite(), steps=cfg.run.validation_steps,
                                         window=cfg.run.window, observer=_trained_on(cfg, kind))
               for kind, (arrays, learner, seeds) in qtables.items()}
    paths["robustness"] = write_robustness(out, rob, {r.kind: r.label for r in results}, root=root)
    return paths
