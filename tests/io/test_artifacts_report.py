"""Model/Q-table artifacts round-trip exactly; the report files agree with each other."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.evaluation.results import AgentResult, per_seed_row
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel
from msd_bench.io.reports.report import write_report
from msd_bench.io.storage import artifacts


def _model() -> StepModel:
    p = np.array([5.0, 0.1 / 3, 1e-17, -1.9, 0.91, 5.0, 1.4])
    return StepModel(kernels.KIND_LINEAR, p, "glm", {"fit": 86.0, "bad": float("nan")})


def test_model_round_trips_bit_for_bit(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "a.mcap").write_bytes(b"abc")
    prov = artifacts.Provenance((artifacts.source(bag),), {"order": 2}, seed=7)
    path = artifacts.save_model(_model(), tmp_path / "glm.json", prov)
    loaded = artifacts.load_model(path)
    assert np.array_equal(loaded.params, _model().params)
    assert loaded.kind == kernels.KIND_LINEAR and loaded.info["bad"] is None
    doc = json.loads(path.read_text())
    assert doc["provenance"]["seed"] == 7
    assert doc["provenance"]["sources"][0]["sha256"] == artifacts.sha256_path(bag)


def test_hash_changes_with_content(tmp_path: Path) -> None:
    f = tmp_path / "x"
    f.write_bytes(b"1")
    h1 = artifacts.sha256_path(f)
    f.write_bytes(b"2")
    assert artifacts.sha256_path(f) != h1


def test_artifact_errors_are_one_line(tmp_path: Path) -> None:
    path = artifacts.save_model(_model(), tmp_path / "m.json", artifacts.Provenance())
    with pytest.raises(artifacts.ArtifactError, match="refusing to overwrite"):
        artifacts.save_model(_model(), path, artifacts.Provenance())
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(artifacts.ArtifactError, match="not valid JSON"):
        artifacts.load_model(tmp_path / "bad.json")
    doc = json.loads(path.read_text())
    doc["schema_version"] = 99
    (tmp_path / "v99.json").write_text(json.dumps(doc))
    with pytest.raises(artifacts.ArtifactError, match="schema version 99"):
        artifacts.load_model(tmp_path / "v99.json")
    with pytest.raises(artifacts.ArtifactError, match="no such"):
        artifacts.load_model(tmp_path / "missing.json")


def test_qtables_round_trip(tmp_path: Path) -> None:
    q = np.random.default_rng(0).normal(size=(3, 100, 5))
    path = artifacts.save_qtables(tmp_path / "q.npz", {"q": q}, {"seeds": [0, 1, 2]})
    arrays, meta = artifacts.load_qtables(path)
    assert np.array_equal(arrays["q"], q) and meta["seeds"] == [0, 1, 2]


def test_report_files_agree(tmp_path: Path) -> None:
    base = {"mae": 0.05, "std": 0.1, "po": 10.0, "ts": 7.0, "ts5": 4.0}
    rows = tuple(per_seed_row(s, 0, {**base, "sse": sse}) for s, sse in enumerate([0.5, 20.0]))
    result = AgentResult("plm", "PLM (paper agent)", "plm", "paper", 60_000, 92.0, 99.9, rows)
    paths = write_report(tmp_path, [result], {"preset": "default", "seeds": 2, "window": 500})
    doc = json.loads(paths["json"].read_text())
    agent = doc["agents"][0]
    assert doc["schema"] == "msd-bench/table1" and agent["n_success"] == 1
    assert agent["summary"]["sse"]["mean"] == pytest.approx(10.25)
    with paths["csv"].open() as fh:
        lines = list(csv.DictReader(fh))
    assert [float(x["sse"]) for x in lines] == [0.5, 20.0]
    md = paths["md"].read_text()
    assert "PLM (paper agent)" in md and "1/2 (50 %, CI 9–91 %)" in md


@pytest.mark.parametrize(("said", "validated"), [
    (True, True), (False, False), (None, False),
    ({"on": True, "line": "Supervisor: on"}, True),
    ({"on": False, "line": "Supervisor: off (--no-supervisor)."}, False),  # bench.py's facts when off
])
def test_the_title_says_validated_behind_the_supervisor_only_when_it_was(
        said: object, validated: bool) -> None:
    from msd_bench.io.reports.report import table_markdown

    run = {"preset": "default", "window": 500, **({} if said is None else {"supervisor": said})}
    title = table_markdown([], run).splitlines()[0]
    assert ("Validated behind the safety supervisor" in title) is validated
