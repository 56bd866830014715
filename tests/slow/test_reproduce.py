"""Opt-in (``pytest -m slow``): the README's headline counts reproduce within 99 % prediction intervals.

Reruns each stored results command (``scripts/make_results.py``) and checks
every agent kind's success count against the count stored in
``docs/results/<name>.json``. On the machine that wrote them the rerun is bit
for bit identical; on another CPU only in distribution, hence the interval.
Takes minutes per result, so it is not in the default run.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from msd_bench.core.evaluation.stats import prediction_interval

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))

import make_results  # noqa: E402

pytestmark = pytest.mark.slow
STORED = sorted(p.stem for p in (REPO / "docs" / "results").glob("table1_*.json"))


@pytest.mark.parametrize("name", STORED)
def test_counts_reproduce_within_the_prediction_interval(name, tmp_path, monkeypatch):
    stored = json.loads((REPO / "docs" / "results" / f"{name}.json").read_text())
    monkeypatch.setattr(make_results, "RESULTS", tmp_path)
    fresh = json.loads(make_results.run(name).read_text())
    old = {a["kind"]: a for a in stored["table1"]["agents"]}
    for a in fresh["table1"]["agents"]:
        before = old[a["kind"]]
        lo, hi = prediction_interval(before["n_success"], before["n"], a["n"])
        assert lo <= a["n_success"] <= hi, (
            f"{name} {a['kind']}: {a['n_success']}/{a['n']} outside [{lo}, {hi}] "
            f"predicted from {before['n_success']}/{before['n']}")
