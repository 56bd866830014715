"""The bench's report stage: read what the node processes wrote, write Table 1 and figures.

Everything comes from files of the run (model artifacts, ``fits.json``, each
agent's ``result.json`` and trained-policy artifact, and validation bags), so
the report can be rebuilt at any time with ``bench.py --stages report --out
<run>``. Table 1 and robustness are assembled by the function the in-process
run uses (:func:`msd_bench.app.scoring.assemble`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from msd_bench import designs
from msd_bench.app.agents import agent_kind
from msd_bench.app.pipeline import settings
from msd_bench.app.scoring import PolicyRecord, Validation, assemble
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.results import AgentResult
from msd_bench.core.evaluation.risk import trace_risk
from msd_bench.core.evaluation.risk_table import well_formed
from msd_bench.core.identification.identify import FitReport
from msd_bench.core.identification.model_kinds import needs_bias_records
from msd_bench.core.physics.model import StepModel
from msd_bench.designs import Policy
from msd_bench.designs.kinds import made_on_plant
from msd_bench.io.bags.bag_error import BagError
from msd_bench.io.bags.bag_records import load_records as load_records_of
from msd_bench.io.bags.bag_records import roles_from_dir
from msd_bench.io.bags.reader import UNCHECKED, read_experiment
from msd_bench.io.reports.html_report import write_index
from msd_bench.io.reports.report import write_report, write_robustness
from msd_bench.io.storage import artifacts
from msd_bench.io.storage.atomic import write_text_atomic
from msd_bench.io.storage.run_output import FigureData, write_figures
from msd_msgs_py.interface import PlantInterface

from .bench import BenchConfig, unmade_agents
from .run_files import AgentDoc, read_fits, read_result


def load_records(cfg: BenchConfig) -> dict[str, tuple[PolicyRecord, AgentDoc]]:
    """Per agent kind that wrote a result: its trained-policy record (the policy loaded back from its
    artifact, on the model it was made on, and the validation its node ran) and its ``result.json``."""
    fits = _fits(cfg)
    out: dict[str, tuple[PolicyRecord, AgentDoc]] = {}
    for kind in cfg.run.agents:
        agent_dir = cfg.run_dir / "agents" / kind
        if not (agent_dir / "result.json").is_file():
            continue
        doc = read_result(agent_dir / "result.json")
        policy = designs.load(agent_dir, _trained_on(cfg, kind))
        fit = fits.get(agent_kind(kind).surrogate)
        rows = [_with_risk(cfg, kind, row) for row in doc.per_seed]
        out[kind] = (PolicyRecord(policy, cfg.id_seed, cfg.seeds, rows, fit), doc)
    return out


def _with_risk(cfg: BenchConfig, kind: str, row: dict[str, Any]) -> dict[str, Any]:
    """A per-seed row with its risk: the record the agent's ``result.json`` carries (its node knows
    the supervisor's overrides and aborts) or, failing one, the risk of the run's validation bag.

    Why the bag: it is the run as the plant reported it, so even an agent that records no
    risk has its contacts and peaks in the table. It holds the *measured* position (on the
    emulator the true one, so the record is the in-process run's, bit for bit) and no
    overrides. A bag that cannot be read leaves the row without risk ("—").
    """
    if well_formed(row.get("risk")):
        return row
    bag = cfg.run_dir / "agents" / kind / "validation" / f"seed_{row['seed']}"
    if not bag.is_dir():
        return row
    try:
        y = read_experiment(bag, cfg.namespace, timing=UNCHECKED)[0].y
        risk = trace_risk(y, cfg.run.plant).as_dict()
    except (BagError, InvalidInputError):
        return row
    return {**row, "risk": risk}


def assemble_all(cfg: BenchConfig, records: dict[str, tuple[PolicyRecord, AgentDoc]],
                 scenarios: bool) -> tuple[list[AgentResult], dict[str, dict[str, Any]]]:
    """Table 1 and robustness from the records: :func:`msd_bench.app.scoring.assemble`, as in-process."""
    results: list[AgentResult] = []
    rob: dict[str, dict[str, Any]] = {}
    val = Validation.of(cfg.run, scenarios)
    for kind, (record, doc) in records.items():
        notes = [] if doc.training == "in-process" else [f"trained {doc.training}"]
        result, cells = assemble(kind, [record], settings(cfg.run), val, notes)
        results.append(result)
        if cells:
            rob[kind] = cells
    return results, rob


def load_results(cfg: BenchConfig) -> list[AgentResult]:
    """One Table-1 row per agent kind that wrote a result."""
    return assemble_all(cfg, load_records(cfg), scenarios=False)[0]


def _fits(cfg: BenchConfig) -> dict[str, FitReport]:
    path = cfg.run_dir / "models" / "fits.json"
    if not path.is_file():
        return {}
    return read_fits(path)


def figure_data(cfg: BenchConfig, results: list[AgentResult],
                policies: dict[str, Policy]) -> FigureData:
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
        records=load_records_of(roles_from_dir(cfg.excitation_dir, cfg.namespace, cfg.run.plant.dt),
                                needs_bias_records(models), cfg.namespace, cfg.run.plant.dt,
                                iface=cfg.interface, force_limit=cfg.run.plant.F,
                                hold=cfg.run.hold),
        policies=policies, responses=responses)


def _trained_on(cfg: BenchConfig, kind: str) -> StepModel | None:
    """The model a kind was made on (a ``model`` observer predicts with it; a baseline is redesigned
    on it); None for a kind that learned on the plant's topics when the run has no plant model."""
    path = cfg.run_dir / "models" / f"{agent_kind(kind).surrogate}.json"
    return artifacts.load_model(path) if path.is_file() or not made_on_plant(kind) else None


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
        risks = [s["risk"] for s in r.per_seed if well_formed(s.get("risk"))]
        cells = {"nominal": robustness.cell([s["sse"] for s in r.per_seed], [s["mae"] for s in r.per_seed],
                                            risks if len(risks) == r.n else None)}
        cells.update(doc.on_node_scenarios)
        rob[r.kind] = cells
    return rob


def _plant_ns_lines(facts: dict[str, Any], iface: PlantInterface) -> str:
    """What a reader of Table 1 must know about a run on a foreign node (and its face, if not ours)."""
    lines = [f"Run against `{facts['plant_ns']}` (no emulator; real time; no reset: zero force until "
             f"still before every experiment and episode; docs/plant-ns.md)."]
    lines += [note for note in (iface.report_note(),) if note is not None]
    lines += [f"{facts[k][0].upper()}{facts[k][1:]}." for k in ("left_out", "dyna_budget") if facts[k]]
    scenarios = ", ".join(facts["node_scenarios"]) or "no scenario"
    lines.append(f"Robustness: measured on the node for {scenarios} "
                 f"({', '.join(facts['scenario_kinds']) or 'no kind'}); nothing on the emulator's model.")
    return "\n".join(f"- {line}" for line in lines) + "\n"


def rig_line(rig: dict[str, Any]) -> str:
    """The rate, stroke and force a ``--rig`` run ran with, one line under Table 1."""
    return (f"Rig (`--rig`): {rig['rate_hz']:g} Hz (dt {rig['dt_s']:g} s), stroke {rig['stroke']:g} "
            f"{rig['position_unit']}, force limit {rig['force_limit']:g} {rig['force_unit']}, "
            f"{rig['samples_per_decision']} sample(s) per {rig['decision_period_s']:g} s decision, "
            f"{rig['interface']} face{_hold_text(rig)}.\n")


def _hold_text(rig: dict[str, Any]) -> str:
    """The stated hold loop the rig ran under, if any: what every command and record was beyond."""
    hold = rig.get("hold_loop")
    if not isinstance(hold, dict):
        return ""
    return (f"; held by its drive's position loop (stiffness {hold['stiffness']:.4g} {rig['force_unit']}/"
            f"{rig['position_unit']}, damping {hold['damping']:.4g}, at {hold['position']:g} "
            f"{rig['position_unit']}): the commands, records and models are of the held system")


def write_bench_report(cfg: BenchConfig, facts: dict[str, Any]) -> dict[str, Any]:
    """Table 1 (md/csv/json), robustness, figures and their page (``index.html``) under ``report/``."""
    records = load_records(cfg)
    results, rob = assemble_all(cfg, records, scenarios=cfg.plant_ns is None)
    out, root = cfg.run_dir / "report", cfg.run_dir  # every write stays in the run, no symlink followed
    unmade = unmade_agents(cfg)  # kinds whose model could not be fitted: failed rows, with the reason
    facts = {**facts, "failed_agents": unmade} if unmade else facts
    paths: dict[str, Any] = {"table": write_report(out, results, facts, root=root)}
    if unmade:
        md = paths["table"]["md"]
        rows = "".join(f"| {kind} | failed: {why} |\n" for kind, why in unmade.items())
        text = md.read_text().rstrip("\n") + "\n\n| agent kind | not run |\n|---|---|\n" + rows
        write_text_atomic(md, text, root=root)
    policies = {kind: record.policy for kind, (record, _) in records.items()}
    paths["figures"] = write_figures(out / "figures", figure_data(cfg, results, policies), root=root)
    if cfg.plant_ns is not None:  # the title names the node, not the emulator's true plant
        md = paths["table"]["md"]
        text = md.read_text().replace(f"on the true plant ({cfg.run.preset} preset)",
                                      f"on {cfg.plant_ns} (real time, measured position)", 1)
        write_text_atomic(md, text.rstrip("\n") + "\n\n" + _plant_ns_lines(facts, cfg.interface), root=root)
        rob = on_node_robustness(cfg, results)
    if facts.get("supervisor"):  # on or off, and what it reported: one line under Table 1
        md = paths["table"]["md"]
        text = md.read_text().rstrip("\n") + "\n\n" + facts["supervisor"]["line"] + "\n"
        write_text_atomic(md, text, root=root)
    if cfg.rig is not None:  # only with --rig: a default run's report stays byte for byte
        md = paths["table"]["md"]
        text = md.read_text()
        if cfg.plant_ns is None:  # the emulator serves the description's plant, not a preset
            text = text.replace(f"on the true plant ({cfg.run.preset} preset)",
                                "on the true plant (the emulator's plant for the `--rig` description)", 1)
        write_text_atomic(md, text.rstrip("\n") + "\n\n" + rig_line(cfg.rig), root=root)
    paths["robustness"] = write_robustness(out, rob, {r.kind: r.label for r in results}, root=root)
    paths["index"] = write_index(out, root=root, title=f"bench.py run {root.name}", run_dir=root, config=cfg)
    return paths
