"""Risk through the tables: a run that hits a stop shows its contacts in table1.json, .md and .csv,
in robustness.md and the rig report; rows and documents without risk render "—"."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.results import AgentResult, per_seed_row
from msd_bench.core.evaluation.risk import trace_risk
from msd_bench.core.evaluation.risk_table import compact, summarise
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.safety.adversaries import adversary, run_on_plant
from msd_bench.core.safety.supervisor import SupervisorOptions
from msd_bench.io.reports.report import robustness_markdown, write_report
from msd_bench.io.rigs.rigs_report import kinds_table

P = PlantParams()
METRICS = {"mae": 0.1, "std": 0.01, "po": 5.0, "ts": 2.0, "ts5": 1.5, "sse": 1.0}


def _pushed_into_the_stop() -> np.ndarray:
    """Always +F on the plant, unsupervised: its overshoot touches the stop."""
    adv = adversary("always_plus", P, 1500)
    return run_on_plant(P, SupervisorOptions().limits(P), adv, np.zeros((1, 1500)), supervised=False).x[0]


def _result(risky: bool, with_risk: bool = True) -> AgentResult:
    x = _pushed_into_the_stop() if risky else np.linspace(0.0, 1.0, 1500)
    metrics = {**METRICS, "risk": trace_risk(x, P).as_dict()} if with_risk else METRICS
    rows = (per_seed_row(0, 0, metrics), per_seed_row(1, 0, {**METRICS, "risk": trace_risk(
        np.linspace(0.0, 1.0, 1500), P).as_dict()} if with_risk else METRICS))
    return AgentResult(kind="plm", label="PLM", surrogate="plm", agent="paper", identification_samples=1,
                       fit_sim=90.0, fit_one_step=99.0, per_seed=rows)


def test_a_run_that_hits_a_stop_shows_its_contacts_in_every_table1_file(tmp_path: Path) -> None:
    paths = write_report(tmp_path, [_result(True)], {"preset": "default", "window": 500})
    doc = json.loads(paths["json"].read_text())
    risk = doc["agents"][0]["risk"]
    assert risk["contacts"] == 1 and risk["runs_with_contact"] == 1 and risk["runs"] == 2
    assert risk["peak_x"] == P.x_max and risk["time_at_stop"] > 0.0  # +F holds 1.98 m after one overshoot
    assert doc["agents"][0]["per_seed"][0]["risk"]["contacts"] == 1
    md = paths["md"].read_text()
    assert "Stop contacts (runs)" in md and "| 1 (1/2) | 2.50 | 0.0 | 0 |" in md
    csv_rows = paths["csv"].read_text().splitlines()
    assert csv_rows[0].endswith("contacts,time_at_stop,peak_x,peak_v,time_outside,override_share,aborted")
    assert csv_rows[1].split(",")[-7] == "1" and csv_rows[2].split(",")[-7] == "0"


def test_rows_without_risk_render_a_dash(tmp_path: Path) -> None:
    md = write_report(tmp_path, [_result(False, with_risk=False)], {})["md"].read_text()
    assert "| — | — | — | — |" in md
    assert _result(False, with_risk=False).risk() is None


def test_malformed_risk_records_count_as_none() -> None:
    good = trace_risk(np.zeros(10), P).as_dict()
    bad = [{"contacts": "1"}, {**good, "peak_x": float("nan")}, {**good, "contacts": True}, 7, None]
    assert summarise(bad) is None
    assert summarise([*bad, good])["runs"] == 1
    assert compact({"contacts": "x"}) == ("—", "—", "—", "—")


def test_robustness_cells_carry_risk_and_pool_it() -> None:
    stop, calm = trace_risk(_pushed_into_the_stop(), P).as_dict(), trace_risk(np.zeros(50), P).as_dict()
    a = {"nominal": robustness.cell([1.0], [0.1], [stop])}
    b = {"nominal": robustness.cell([9.0], [0.3], [calm])}
    pooled = robustness.merge([a, b])["nominal"]
    assert pooled["risk"]["contacts"] == 1 and pooled["risk"]["runs"] == 2 and len(pooled["risks"]) == 2
    md = robustness_markdown({"plm": {"nominal": pooled}}, {"plm": "PLM"})
    assert "| PLM | 1 (1/2) · 2.50 · 0.0 · 0 |" in md
    old = robustness_markdown({"plm": {"nominal": robustness.cell([1.0], [0.1])}}, {"plm": "PLM"})
    assert "Risk of the same runs" not in old
    assert "risk" not in robustness.merge([{"nominal": robustness.cell([1.0], [0.1])}, b])["nominal"]


def test_rig_report_shows_the_kinds_risk_and_a_dash_without_it() -> None:
    kind = {"label": "PLM", "successes": 1, "n": 2, "rate": 0.5, "wilson95": [0.1, 0.9],
            "bootstrap95": [0.0, 1.0], "measured_successes": 1}
    risk = summarise([trace_risk(_pushed_into_the_stop(), P).as_dict()])
    lines = kinds_table({"kinds": [{**kind, "risk": risk}, kind]})
    assert "Stop contacts (runs)" in lines[0]
    assert lines[2].endswith("| 1 (1/1) | 2.50 | 0.0 | 0 |") and lines[3].endswith("| — | — | — | — |")
