"""scripts/rigs_baselines.py: the learned rows are copied unchanged beside the baselines' of the same
rigs; sweeps that differ are refused in one line; an existing result is never overwritten."""

from __future__ import annotations

import copy
import importlib.util
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]
SPEC = importlib.util.spec_from_file_location("rigs_baselines", REPO / "scripts" / "rigs_baselines.py")
assert SPEC is not None and SPEC.loader is not None
rb = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(rb)


def _kind(kind: str, successes: int, n: int) -> dict[str, Any]:
    return {"kind": kind, "label": kind.upper(), "n": n, "successes": successes, "rate": successes / n,
            "wilson95": [0.1, 0.9], "bootstrap95": [0.2, 0.8], "rigs": 2, "measured_successes": successes,
            "risk": {"runs": n, "contacts": 0}, "scenarios": {"setpoint=0.5": {"n": n}}}


def _sweep(kinds: list[dict[str, Any]], outcomes: list[dict[str, Any]]) -> dict[str, Any]:
    return {"rig_set": "held-out", "population": {"module": "p", "held_out_first": 1000},
            "rigs_run": [1000, 1001],
            "validation": {"target": 1.0}, "success_sse_percent": 5.0, "learning_seeds": [0, 1, 2, 3],
            "seconds": {"total": 60.0}, "kinds": kinds,
            "rigs": [{"rig": 1000, "outcomes": outcomes, "identification_failed": {}, "design_failed": {}},
                     {"rig": 1001, "outcomes": [], "identification_failed": {"plm": "x"},
                      "design_failed": {}}]}


def test_the_learned_rows_stand_unchanged_beside_the_baselines() -> None:
    stored = _sweep([_kind("plm+robust", 7, 8)], [])
    base = _sweep([_kind("glm+pid", 2, 2), _kind("plm+mpc", 1, 2)],
                  [{"kind": "plm+mpc", "seed": 0, "success": False, "identified": False}])
    base["population"]["module"] = "moved"  # the layout change renamed it; the seeds are what count
    before = copy.deepcopy(stored)
    doc = rb.beside(stored, base)
    assert stored == before
    learned = [k for k in doc["kinds"] if k["sweep"] == "learned"]
    assert learned == [{**{key: stored["kinds"][0][key] for key in rb.KIND_KEYS}, "sweep": "learned"}]
    assert [k["kind"] for k in doc["kinds"]] == ["plm+robust", "glm+pid", "plm+mpc"]
    assert {k["kind"]: k["not_run"] for k in doc["kinds"] if k["sweep"] == "baselines"} == \
        {"glm+pid": 0, "plm+mpc": 1}
    assert doc["sweeps"]["baselines"]["identification_failed"] == 1
    sys.path.insert(0, str(REPO / "scripts"))
    from readme_results import view_rigs_beside

    page = view_rigs_beside({**doc, "command": "c", "commit": "0" * 40, "machine": {}}, "x")
    assert "| PLM+ROBUST | per rig and learning seed | 7 / 8 |" in page and "PLM+MPC 1" in page


@pytest.mark.parametrize(("key", "other"), [
    ("rigs_run", [1]), ("validation", {"other": 1}), ("success_sse_percent", 2.0),
    ("population", {"held_out_first": 5}),
])
def test_sweeps_of_other_rigs_or_settings_are_refused(key: str, other: object) -> None:
    stored, base = _sweep([_kind("plm", 1, 8)], []), _sweep([_kind("glm+pid", 1, 2)], [])
    base[key] = other
    with pytest.raises(rb.ConfigError, match=repr(key)):
        rb.beside(stored, base)


def test_an_existing_result_is_never_overwritten(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    out.write_text("theirs")
    proc = subprocess.run([sys.executable, "scripts/rigs_baselines.py", "--out", str(out)], cwd=REPO,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "exists" in proc.stderr and out.read_text() == "theirs"
    assert len(proc.stderr.strip().splitlines()) == 1


def test_the_committed_table_holds_both_sweeps_rows_unchanged() -> None:
    """docs/results/rigs_heldout100_baselines.json: its learned rows are rigs_heldout100.json's, its
    baselines' rows the committed baselines sweep's, key for key (nothing re-derived or retyped)."""
    import json

    results = REPO / "docs" / "results"
    doc = json.loads((results / "rigs_heldout100_baselines.json").read_text())
    sources = {"learned": results / "rigs_heldout100.json",
               "baselines": results / "rigs_heldout100_baselines_sweep.json"}
    for sweep, path in sources.items():
        source = json.loads(path.read_text())
        rows = [k for k in doc["kinds"] if k["sweep"] == sweep]
        assert [k["kind"] for k in rows] == source["agents"]
        for row, kind in zip(rows, source["kinds"], strict=True):
            assert {key: row[key] for key in rb.KIND_KEYS} == {key: kind[key] for key in rb.KIND_KEYS}
        assert source["rigs_run"] == doc["rigs_run"]
