"""The committed ceiling and refinement sweeps (docs/results/rigs_heldout100_ceiling.json,
rigs_heldout100_refine2_kinds.json): the ceiling sweep's agent rows are the held-out sweep's, run for run,
and every refined run charges what it tried and kept its best measured try."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results"
SAME = ("kind", "seed", "success", "sse", "sse_measured", "start_x", "risk")
"""What a run of the ceiling sweep must share with the held-out sweep's (every scored field)."""


def _load(name: str) -> dict[str, Any]:
    path = RESULTS / f"{name}.json"
    if not path.is_file():
        pytest.skip(f"{path.name} is not committed")
    doc: dict[str, Any] = json.loads(path.read_text())
    return doc


def test_the_ceiling_sweep_reproduces_the_held_out_sweep_run_for_run() -> None:
    """``--ceiling`` runs after every agent kind: their runs are the committed held-out ones (the kinds
    whose runs the file keeps, run for run; every kind's pooled row, whole)."""
    ceiling, before = _load("rigs_heldout100_ceiling"), _load("rigs_heldout100")
    assert ceiling["rigs_run"] == before["rigs_run"] and ceiling["agents"] == before["agents"]
    routes = [c["kind"] for c in ceiling["ceiling"]]
    pooled = {k["kind"]: k for k in ceiling["kinds"]}
    for k in before["kinds"]:
        assert json.dumps(pooled[k["kind"]], sort_keys=True) == json.dumps(k, sort_keys=True)
    assert [k["kind"] for k in ceiling["kinds"]] == [*before["agents"], *routes]
    kept = set(ceiling["trimmed"].get("runs_of", ceiling["agents"]))
    compared = 0
    for new, old in zip(ceiling["rigs"], before["rigs"], strict=True):
        rows = [o for o in new["outcomes"] if o["kind"] not in routes]
        olds = [o for o in old["outcomes"] if o["kind"] in kept]
        assert json.dumps([{k: o.get(k) for k in SAME} for o in rows]) == \
            json.dumps([{k: o.get(k) for k in SAME} for o in olds]), new["rig"]
        compared += len(rows)
    assert compared >= 1600


def test_every_refined_run_charges_its_tries_and_keeps_its_best_measured_one() -> None:
    """The refined runs the committed file keeps (``trimmed.runs_of``): each tried at most R + 1
    policies, kept the best measured try, and was charged every record, try and fresh run with the
    rests before them (the one bill, ``app/rig_cost.py: spent``)."""
    doc = _load("rigs_heldout100_refine2_kinds")
    steps = doc["validation"]["steps"]
    kept = set(doc["trimmed"].get("runs_of", [k["kind"] for k in doc["kinds"]]))
    refined = [o for r in doc["rigs"] for o in r["outcomes"] if "refine" in o]
    assert len(refined) == sum(k["n"] for k in doc["kinds"] if "refine" in k and k["kind"] in kept) >= 800
    for o in refined:
        ref = o["refine"]
        tried = [r for r in ref["rounds"] if "samples" in r]
        assert len(tried) <= doc["run_config"]["refine"] + 1 and ref["rounds"][0] in tried
        ranked = min(tried, key=lambda r: (r["aborted"], r["sse_measured"], r["round"]))
        assert ref["chosen_round"] == ranked["round"]
        charged = ref["real_samples"]
        assert charged["accounting"] == "route+rests"
        assert charged["tries"] == steps * len(tried) and charged["fresh_validation"] == steps
        assert charged["runs"] == charged["tries"] + charged["fresh_validation"]
        parts = charged["records"] + charged["record_rests"] + charged["runs"] + charged["run_rests"]
        assert charged["total"] == parts


def test_every_refinable_robust_kind_was_refined_beside_the_ceiling() -> None:
    """The sweep refined each robust kind it ran, and pooled a refined row for each beside the two
    ceiling rows (the rows the refinement table reads)."""
    doc = _load("rigs_heldout100_refine2_kinds")
    kinds = [k["kind"] for k in doc["kinds"]]
    routes = [c["kind"] for c in doc["ceiling"]]
    assert set(routes) == {"truth+robust", "truth-plant+robust"}
    for agent in doc["agents"]:
        assert f"{agent}+refined" in kinds, agent
    assert all(k["n"] == 400 for k in doc["kinds"])
