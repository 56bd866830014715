"""Risk records summed up for a table row: a few compact cells, the full record in JSON.

Kept apart from :mod:`msd_bench.core.evaluation.risk` (which imports the compiled
supervisor) so the report writers and the README views read risk records
without loading numba.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from statistics import fmean
from typing import Any, TypeGuard

RISK_HEADERS = ("Stop contacts (runs)", "Peak \\|x\\| (m)", "Overrides (%)", "Aborts")
"""The compact risk columns of every table (:func:`compact`), as Markdown header cells."""
RISK_NOTE = ("Risk: hard-stop contacts summed over the runs (runs with one/n), the largest |x| of any "
             "run, the mean share of samples the supervisor overrode (0 without it) and the runs it "
             "aborted; — where the runs recorded no risk.")
"""Says what the risk columns mean, under every table that has them."""


NUMBERS = ("contacts", "time_at_stop", "peak_x", "peak_v", "time_outside", "exits_beyond_margin",
           "override_share")
"""The numeric fields of a run's risk record (``RunRisk``) a summary reads."""


def well_formed(r: object) -> TypeGuard[Mapping[str, Any]]:
    """A risk record a summary can read: every number finite and >= 0, ``aborted`` text or None.

    Why check: bench.py's report reads records from agent processes' ``result.json``;
    a record that is not one counts as no record rather than as a crash or a wrong total.
    """
    if not isinstance(r, Mapping) or not all(k in r for k in NUMBERS):
        return False
    nums = [r[k] for k in NUMBERS]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < float("inf")
               for v in nums):
        return False
    return r.get("aborted") is None or isinstance(r.get("aborted"), str)


def summarise(risks: Iterable[object]) -> dict[str, Any] | None:
    """What a table row shows of its runs' risk records (``RunRisk.as_dict``); None when no run
    carries a well-formed one (a table written before risk was recorded renders "—")."""
    rs: list[Mapping[str, Any]] = [r for r in risks if well_formed(r)]
    if not rs:
        return None
    aborts: dict[str, int] = {}
    for r in rs:
        if r.get("aborted"):
            aborts[str(r["aborted"])] = aborts.get(str(r["aborted"]), 0) + 1
    return {"runs": len(rs), "contacts": int(sum(int(r["contacts"]) for r in rs)),
            "runs_with_contact": int(sum(int(r["contacts"]) > 0 for r in rs)),
            "time_at_stop": float(sum(float(r["time_at_stop"]) for r in rs)),
            "peak_x": float(max(float(r["peak_x"]) for r in rs)),
            "peak_v": float(max(float(r["peak_v"]) for r in rs)),
            "time_outside": float(sum(float(r["time_outside"]) for r in rs)),
            "exits_beyond_margin": int(sum(int(r["exits_beyond_margin"]) for r in rs)),
            "override_share": fmean(float(r["override_share"]) for r in rs),
            "runs_overridden": int(sum(float(r["override_share"]) > 0 for r in rs)),
            "aborts": aborts}


def compact(summary: Mapping[str, Any] | None) -> tuple[str, str, str, str]:
    """The four table cells of a :func:`summarise` record: contacts (runs with one), peak |x|,
    overrides %, aborts; "—" each for a row without a risk record."""
    if not summary or not _readable(summary):
        return ("—", "—", "—", "—")
    contacts = f"{summary['contacts']} ({summary['runs_with_contact']}/{summary['runs']})"
    aborts = sum(int(v) for v in summary.get("aborts", {}).values() if isinstance(v, int))
    return (contacts, f"{float(summary['peak_x']):.2f}", f"{100 * float(summary['override_share']):.1f}",
            str(aborts))


def summary_of(cell: object) -> Mapping[str, Any] | None:
    """A robustness cell's risk summary if it carries a readable one (else None)."""
    if not isinstance(cell, Mapping):
        return None
    risk = cell.get("risk")
    return risk if isinstance(risk, Mapping) and _readable(risk) else None


def _readable(summary: Mapping[str, Any]) -> bool:
    """A :func:`summarise` record whose cells :func:`compact` can print."""
    keys = ("contacts", "runs_with_contact", "runs", "peak_x", "override_share")
    numbers = all(isinstance(summary.get(k), (int, float)) and not isinstance(summary.get(k), bool)
                  for k in keys)
    return numbers and isinstance(summary.get("aborts", {}), Mapping)


def risk_cell(summary: Mapping[str, Any] | None) -> str:
    """One cell holding all four figures of :func:`compact`, "·"-separated ("—" without a record)."""
    if summary is None:
        return "—"
    contacts, peak, overrides, aborts = compact(summary)
    return f"{contacts} · {peak} · {overrides} · {aborts}"
