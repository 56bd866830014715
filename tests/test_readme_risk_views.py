"""The README's Table 1 and robustness views with risk, and with documents written before it."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import readme_results  # noqa: E402

PROV = {"command": "x", "commit": "0123456789ab", "machine": {"cpu": "c", "cores": 2}, "seconds": 1}
RISK = {"runs": 4, "contacts": 3, "runs_with_contact": 2, "time_at_stop": 0.2, "peak_x": 2.5, "peak_v": 4.0,
        "time_outside": 1.0, "exits_beyond_margin": 2, "override_share": 0.125, "runs_overridden": 1,
        "aborts": {"divergence": 1}}


def _agent(risk: dict[str, Any] | None) -> dict[str, Any]:
    a: dict[str, Any] = {"label": "PLM", "fit_sim_percent": 97.0, "identification_samples": 12000,
                         "real_interactions": 0, "n_success": 3, "n": 4, "summary": {"sse": {"median": 1.0}}}
    return a if risk is None else {**a, "risk": risk}


def test_table1_view_shows_the_risk_columns_and_a_dash_for_old_documents() -> None:
    doc = {**PROV, "table1": {"agents": [_agent(RISK), _agent(None), _agent({"contacts": "?"})]}}
    lines = readme_results.view_table1(doc, "t").splitlines()
    assert lines[0].endswith("| Stop contacts (runs) | Peak \\|x\\| (m) | Overrides (%) | Aborts |")
    assert lines[2].endswith("| 3 (2/4) | 2.50 | 12.5 | 1 |")
    assert lines[3].endswith("| — | — | — | — |") and lines[4].endswith("| — | — | — | — |")


def test_robustness_view_names_contacts_and_aborts_only_where_they_happened() -> None:
    cell = {"n_success": 3, "n": 4}
    rob = {"scenarios": ["nominal", "delay=1"],
           "agents": [{"kind": "plm", "cells": {"nominal": {**cell, "risk": RISK}, "delay=1": cell}}]}
    text = readme_results.view_robustness({**PROV, "robustness": rob}, "t")
    assert "| `nominal` | 3/4 (30–95) · 3 contacts (2 runs) · 1 aborted |" in text
    assert "| `delay=1` | 3/4 (30–95) |" in text
