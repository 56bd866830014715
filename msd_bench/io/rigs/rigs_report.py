"""``rigs.md``: the population report, generated from ``rigs.json`` only (nothing re-derived).

Per agent kind the success rate over (rig, seed) runs with both intervals; the
scenario cells beside it; the ten worst rigs with every parameter; a per-rig
table; the figure. Text taken from the document is put on one line with ``|``
escaped (:func:`msd_bench.io.reports.report.md_cell`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

from msd_bench.core.evaluation.risk_table import RISK_HEADERS, RISK_NOTE, compact
from msd_bench.io.reports.report import md_cell
from msd_bench.io.storage.atomic import write_text_atomic

PARAMETERS = ("mass", "damping", "spring", "hardening", "friction", "delay", "lag", "noise", "quant")
"""Rig parameters in column order (multipliers, then the imperfections): every rig records these."""
OWN_PLANT = ("mass", "stroke", "force_limit", "rate", "damping", "friction", "offset", "delay", "lag",
             "quant")
"""The columns of a family whose rigs are plants of their own (a ``stage``), in physical units: a
multiplier of the paper's plant would say nothing there. Such a rig records ``stroke`` (the marker)."""
FIGURE = "rigs.png"


class Column(NamedTuple):
    """One parameter column: its key in a rig's ``parameters``, its header, its cell and its unit."""

    key: str
    header: str
    cell: Callable[[float], str]
    unit: str


_MULTIPLIED_COLUMNS = (
    *(Column(k, f"{k} ×", lambda v: f"{v:.3f}", "×") for k in ("mass", "damping", "spring", "hardening")),
    Column("friction", "friction N", lambda v: f"{v:.3f}", "N"),
    Column("delay", "delay", lambda v: str(int(v)), "samples"),
    Column("lag", "lag ms", lambda v: f"{1e3 * v:.1f}", "s"),
    Column("noise", "noise mm", lambda v: f"{1e3 * v:.2f}", "m"),
    Column("quant", "quant mm", lambda v: f"{1e3 * v:.1f}", "m"))
_OWN_COLUMNS = (
    Column("mass", "mass kg", lambda v: f"{v:.3g}", "kg"),
    Column("stroke", "stroke m", lambda v: f"{v:.3g}", "m"),
    Column("force_limit", "F N", lambda v: f"{v:.3g}", "N"),
    Column("rate", "rate Hz", lambda v: f"{v:.0f}", "Hz"),
    Column("damping", "c N·s/m", lambda v: f"{v:.3g}", "N·s/m"),
    Column("friction", "friction N", lambda v: f"{v:.3g}", "N"),
    Column("offset", "offset N", lambda v: f"{v:.3g}", "N"),
    Column("delay", "delay", lambda v: str(int(v)), "samples"),
    Column("lag", "lag ms", lambda v: f"{1e3 * v:.2f}", "s"),
    Column("quant", "encoder µm", lambda v: f"{1e6 * v:.1f}", "m"))


def columns(doc: Mapping[str, Any]) -> tuple[Column, ...]:
    """The parameter columns of a sweep's rigs: physical units for plants of their own, else multipliers."""
    rigs = [r for r in (*(doc.get("worst") or ()), *(doc.get("rigs") or ())) if "parameters" in r]
    own = bool(rigs) and "stroke" in rigs[0]["parameters"]
    return _OWN_COLUMNS if own else _MULTIPLIED_COLUMNS


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def _interval(ci: Sequence[float | None]) -> str:
    lo, hi = ci
    return "–" if lo is None or hi is None else f"{100 * lo:.0f}–{100 * hi:.0f} %"


def parameter_cells(params: Mapping[str, Any], cols: Sequence[Column] = _MULTIPLIED_COLUMNS) -> list[str]:
    """A rig's parameters as cells (multipliers ×, friction N, delay samples, lag ms, noise/quant mm; or a
    plant of its own in physical units)."""
    return [c.cell(float(params[c.key])) for c in cols]


def _row(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def kinds_table(doc: Mapping[str, Any]) -> list[str]:
    """Per kind: successes/runs, the rate, Wilson 95 % over runs, bootstrap-over-rigs 95 %, measured,
    and the nominal runs' risk (a document written before risk was recorded shows "—")."""
    lines = [_row(("kind", "successes / runs", "rate", "Wilson 95 %", "bootstrap over rigs 95 %",
                   "on the measured position", *RISK_HEADERS)), _row(("---",) * (6 + len(RISK_HEADERS)))]
    for k in doc["kinds"]:
        lines.append(_row((md_cell(k["label"]), f"{k['successes']} / {k['n']}", _pct(k["rate"]),
                           _interval(k["wilson95"]), _interval(k["bootstrap95"]),
                           f"{k['measured_successes']} / {k['n']}", *compact(k.get("risk")))))
    return lines


def scenarios_table(doc: Mapping[str, Any]) -> list[str]:
    """Per kind and rig scenario: successes/runs (bootstrap-over-rigs interval)."""
    ids = doc["validation"]["scenarios"]
    if not ids:
        return []
    lines = [_row(("kind", *(md_cell(s) for s in ids))), _row(("---",) * (1 + len(ids)))]
    for k in doc["kinds"]:
        cells = [f"{c['successes']}/{c['n']} ({_interval(c['bootstrap95'])})"
                 for c in (k["scenarios"][s] for s in ids)]
        lines.append(_row((md_cell(k["label"]), *cells)))
    return lines


def worst_table(doc: Mapping[str, Any]) -> list[str]:
    """The worst rigs with every parameter and which model kinds could not be identified."""
    cols = columns(doc)
    lines = [_row(("rig", "successes / runs", *(c.header for c in cols), "not identified")),
             _row(("---",) * (3 + len(cols)))]
    for w in doc["worst"]:
        lines.append(_row((str(w["rig"]), f"{w['successes']} / {w['runs']}",
                           *parameter_cells(w["parameters"], cols),
                           md_cell(", ".join(w["identification_failed"]) or "–"))))
    return lines


def per_rig_table(doc: Mapping[str, Any]) -> list[str]:
    """Per rig: its parameters, each kind's successes over its seeds, and its time."""
    kinds, cols = doc["agents"], columns(doc)
    lines = [_row(("rig", *(c.header for c in cols), *(md_cell(k) for k in kinds), "s")),
             _row(("---",) * (2 + len(cols) + len(kinds)))]
    for r in doc["rigs"]:
        wins = []
        for kind in kinds:
            rows = [o for o in r["outcomes"] if o["kind"] == kind]
            wins.append(f"{sum(bool(o['success']) for o in rows)}/{len(rows)}")
        lines.append(_row((str(r["rig"]), *parameter_cells(r["parameters"], cols), *wins,
                           f"{r['seconds']['total']:.0f}")))
    return lines


def render(doc: Mapping[str, Any]) -> str:
    """The whole ``rigs.md``."""
    v, b = doc["validation"], doc["bootstrap"]
    rigs = doc["rigs_run"]
    head = [
        f"# The method on {len(rigs)} {doc['rig_set']} rigs",
        "",
        f"Rigs {rigs[0]}–{rigs[-1]} ({doc['rig_set']}; design rigs are seeds "
        f"{doc['population']['design_seeds'][0]}–{doc['population']['design_seeds'][1]}, drawn by "
        f"`{doc['population']['module']}`), learning seeds {', '.join(map(str, doc['learning_seeds']))}. "
        f"Success: SSE < {doc['success_sse_percent']:g} % on the {v['judged_on']} ({v['target']:g} m, "
        f"{v['steps']} steps, the last {v['window']} for the SSE). Every run starts where the rig came to "
        "rest after the previous one. The bootstrap resamples rigs with replacement "
        f"({b['resamples']} resamples, seed {b['seed']}): runs on one rig are not independent.",
        "", "## Success per kind", "", *kinds_table(doc), "", f"{RISK_NOTE} Risk is of the nominal runs"
        + (", each validated behind the safety supervisor (told the nominal plant)." if v.get("supervisor")
           else "."), "",
        "## Scenarios a rig can be given", "", *scenarios_table(doc), "",
        f"## The {len(doc['worst'])} worst rigs", "", *worst_table(doc), "",
        "## Success against each parameter", "", f"![success against each rig parameter]({FIGURE})", "",
        "## Every rig", "", *per_rig_table(doc), "",
        f"Time per rig: median {doc['seconds']['per_rig_median']:.0f} s, "
        f"longest {doc['seconds']['per_rig_max']:.0f} s.",
        "",
    ]
    return "\n".join(head)


def write_rigs_markdown(path: Path, doc: Mapping[str, Any], root: Path | None = None) -> Path:
    """Write ``rigs.md`` atomically."""
    return write_text_atomic(path, render(doc), root=root)
