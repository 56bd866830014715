"""Table 1 as Markdown, CSV and JSON (schema ``msd-bench/table1`` v1, see README)."""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from msd_bench.core.evaluation.results import METRIC_KEYS, AgentResult
from msd_bench.core.evaluation.risk_table import RISK_HEADERS, RISK_NOTE, compact, risk_cell, summary_of
from msd_bench.core.evaluation.stats import rate_text, wilson
from msd_bench.io.storage.artifacts import jsonable
from msd_bench.io.storage.atomic import write_text_atomic

TABLE_SCHEMA = "msd-bench/table1"
TABLE_VERSION = 1

RISK_CSV = ("contacts", "time_at_stop", "peak_x", "peak_v", "time_outside", "override_share", "aborted")
"""Per-run risk columns of the CSV (empty for a run without a record)."""

_HEADERS = {
    "mae": "MAE (m)",
    "std": "STD (m)",
    "po": "PO (%)",
    "ts": "ts 2% (s)",
    "ts5": "ts 5% (s)",
    "sse": "SSE (%)",
}


def table_json(results: Sequence[AgentResult], run: Mapping[str, Any]) -> dict[str, Any]:
    """The ``table1.json`` document: run facts, then one object per agent kind."""
    return {
        "schema": TABLE_SCHEMA,
        "schema_version": TABLE_VERSION,
        "run": jsonable(dict(run)),
        "agents": [_agent_json(r) for r in results],
    }


def _agent_json(r: AgentResult) -> dict[str, Any]:
    doc: dict[str, Any] = jsonable(
        {
            "kind": r.kind,
            "label": r.label,
            "surrogate": r.surrogate,
            "agent": r.agent,
            "identification_samples": r.identification_samples,
            "fit_sim_percent": r.fit_sim,
            "fit_one_step_percent": r.fit_one_step,
            "fit_by_id_seed": list(r.fit_by_id_seed),
            "real_interactions": r.real_interactions,
            "notes": r.notes,
            "n": r.n,
            "n_success": r.n_success,
            "success_rate": r.success_rate,
            "ci95": list(wilson(r.n_success, r.n)),
            "summary": {k: s.as_dict() for k, s in r.summary().items()},
            "risk": r.risk(),
            "per_seed": list(r.per_seed),
        }
    )
    return doc


_LINE_BREAKS = re.compile(r"[\n\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]+")
"""Every character str.splitlines breaks on (Markdown itself breaks on \\n and \\r)."""


def md_text(value: object) -> str:
    """``value`` on one line: text from a received ``result.json`` must not start a line of its own."""
    return _LINE_BREAKS.sub(" ", str(value))


def md_cell(value: object) -> str:
    """``value`` as one Markdown table cell: one line, ``|`` escaped so it cannot open another cell."""
    return md_text(value).replace("\\", "\\\\").replace("|", "\\|")


def supervised(run: Mapping[str, Any]) -> bool:
    """Whether the runs were validated behind the supervisor: ``msd-bench paper`` states it as a bool,
    bench.py as its report facts (``{"on": ..., "line": ...}``, a dict even when it was off)."""
    said = run.get("supervisor")
    return bool(said.get("on")) if isinstance(said, Mapping) else bool(said)


def table_markdown(results: Sequence[AgentResult], run: Mapping[str, Any]) -> str:
    """Table 1 for humans: fits, samples, each metric as mean ± sd (median), success rate."""
    head = ["Agent", "Fit sim (%)", "Fit 1-step (%)", "Id. samples", *_HEADERS.values(), "Success",
            *RISK_HEADERS]
    lines = [
        f"Table 1 — unit step on the true plant ({run.get('preset', '?')} preset); each row is n "
        f"trained agents (n in the Success column); SSE over the last {run.get('window', '?')} "
        f"steps; success = SSE < 5 %; cells are mean ± sd (med median) [defined/n]."
        + (" Validated behind the safety supervisor (docs/supervisor.md)." if supervised(run) else ""),
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in results:
        summ = r.summary()
        cells = [
            md_cell(r.label),
            _fmt(r.fit_sim),
            _fmt(r.fit_one_step),
            str(r.identification_samples) if r.identification_samples else "—",
            *(summ[k].text(3 if k in ("mae", "std") else 1) for k in METRIC_KEYS),
            rate_text(r.n_success, r.n),
            *compact(r.risk()),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    notes = [f"- {md_text(r.label)}: {md_text(r.notes)}" for r in results if r.notes]
    return "\n".join(lines + ["", RISK_NOTE] + (["", *notes] if notes else [])) + "\n"


def write_report(out_dir: Path, results: Sequence[AgentResult], run: Mapping[str, Any],
                 root: Path | None = None) -> dict[str, Path]:
    """Write ``table1.json``, ``table1.csv`` and ``table1.md`` under ``out_dir``, each atomically.

    ``root`` is the output directory no write may leave (default ``out_dir``).
    """
    out_dir = Path(out_dir)
    root = out_dir if root is None else root
    paths = {
        "json": out_dir / "table1.json",
        "csv": out_dir / "table1.csv",
        "md": out_dir / "table1.md",
    }
    write_text_atomic(paths["json"], json.dumps(table_json(results, run), indent=1) + "\n", root=root)
    write_text_atomic(paths["csv"], table_csv(results), root=root)
    write_text_atomic(paths["md"], table_markdown(results, run), root=root)
    return paths


def table_csv(results: Sequence[AgentResult]) -> str:
    """One line per agent kind and seed (tidy data), so any tool can re-summarise."""
    cols = ["kind", "label", "surrogate", "agent", "identification_samples",
            "fit_sim_percent", "fit_one_step_percent", "seed", "id_seed", *METRIC_KEYS, "success",
            *RISK_CSV]
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    w.writerow(cols)
    for r in results:
        for s in r.per_seed:
            w.writerow([r.kind, r.label, r.surrogate, r.agent, r.identification_samples,
                        _csv(r.fit_sim), _csv(r.fit_one_step), s["seed"], s["id_seed"],
                        *(_csv(s[k]) for k in METRIC_KEYS), int(bool(s["success"])),
                        *_risk_csv(s.get("risk"))])
    return fh.getvalue()


def _risk_csv(risk: Mapping[str, Any] | None) -> list[str]:
    """A run's risk record as CSV cells (blank where it has none)."""
    if not risk:
        return [""] * len(RISK_CSV)
    return [str(risk.get(k) or "") if k == "aborted" else str(risk.get(k, "")) for k in RISK_CSV]


def _fmt(v: float | None) -> str:
    return "—" if v is None or not math.isfinite(v) else f"{v:.1f}"


def _csv(v: float | None) -> str:
    return "" if v is None or not math.isfinite(v) else repr(float(v))


ROBUSTNESS_SCHEMA = "msd-bench/robustness"
ROBUSTNESS_VERSION = 2


def robustness_json(rob: Mapping[str, Mapping[str, Mapping[str, Any]]],
                    labels: Mapping[str, str]) -> dict[str, Any]:
    """``robustness.json`` v2: scenario ids, then per agent kind its cells by scenario id."""
    scenarios = list(next(iter(rob.values()))) if rob else []
    agents = [{"kind": kind, "label": labels.get(kind, kind),
               "cells": {sid: dict(cell) for sid, cell in cells.items()}} for kind, cells in rob.items()]
    doc: dict[str, Any] = jsonable({"schema": ROBUSTNESS_SCHEMA, "schema_version": ROBUSTNESS_VERSION,
                                    "scenarios": scenarios, "agents": agents})
    return doc


def robustness_markdown(rob: Mapping[str, Mapping[str, Mapping[str, Any]]],
                        labels: Mapping[str, str]) -> str:
    """Successes/n (Wilson interval; median SSE) of each agent kind's fixed tables per scenario."""
    if not rob:
        return ""
    scenarios = list(next(iter(rob.values())))
    lines = [
        "Robustness — the trained tables held fixed, validated under each scenario (no retraining); "
        "cells are successes/n (Wilson 95 % interval, %; median SSE %).",
        "",
        "| Agent | " + " | ".join(f"`{md_cell(s)}`" for s in scenarios) + " |",
        "|" + "---|" * (len(scenarios) + 1),
    ]
    for kind, by_scenario in rob.items():
        cells = [_rob_cell(r) for r in by_scenario.values()]
        lines.append(f"| {md_cell(labels.get(kind, kind))} | " + " | ".join(md_cell(c) for c in cells) + " |")
    return "\n".join(lines + _risk_grid(rob, labels, scenarios)) + "\n"


def _risk_grid(rob: Mapping[str, Mapping[str, Mapping[str, Any]]], labels: Mapping[str, str],
               scenarios: Sequence[str]) -> list[str]:
    """The same grid with each cell's risk (:func:`msd_bench.core.evaluation.risk_table.risk_cell`); nothing
    when no cell recorded risk (a document from before risk was recorded)."""
    if not any(isinstance(c, Mapping) and c.get("risk") for cells in rob.values() for c in cells.values()):
        return []
    lines = ["", "Risk of the same runs — hard-stop contacts (runs with one/n) · peak |x| (m) · "
             "overrides (%) · aborts; — where a cell recorded none.", "",
             "| Agent | " + " | ".join(f"`{md_cell(s)}`" for s in scenarios) + " |",
             "|" + "---|" * (len(scenarios) + 1)]
    for kind, by_scenario in rob.items():
        cells = [risk_cell(summary_of(by_scenario.get(s))) for s in scenarios]
        lines.append(f"| {md_cell(labels.get(kind, kind))} | " + " | ".join(md_cell(c) for c in cells) + " |")
    return lines


def _rob_cell(r: Mapping[str, Any]) -> str:
    lo, hi = wilson(int(r["n_success"]), int(r["n"]))
    return f"{r['n_success']}/{r['n']} ({100 * lo:.0f}–{100 * hi:.0f}; {r['median_sse']:.1f})"


def write_robustness(out_dir: Path, rob: Mapping[str, Any], labels: Mapping[str, str],
                     root: Path | None = None) -> dict[str, Path]:
    """``robustness.json`` (schema v2, per kind, scenario and seed) and ``robustness.md``, atomically."""
    out_dir = Path(out_dir)
    root = out_dir if root is None else root
    paths = {"json": out_dir / "robustness.json", "md": out_dir / "robustness.md"}
    write_text_atomic(paths["json"], json.dumps(robustness_json(rob, labels), indent=1) + "\n", root=root)
    write_text_atomic(paths["md"], robustness_markdown(rob, labels), root=root)
    return paths
