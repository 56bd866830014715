"""``msd-bench rigs --refine`` for the other refinable robust kinds: the improved NLARX and the grey-box
rig model, on two design rigs at a tiny size (the held-out sweep of every kind is docs/rigs.md's command,
not a test: ~100 min of both cores)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from msd_bench.cli import main as cli_main

KINDS = ("nlarx-improved+robust", "greybox-rig+robust")
RIGS = (42, 43)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("refine-kinds") / "run"
    assert cli_main(["rigs", "--design", "--rigs", "2", "--first-rig", str(RIGS[0]), "--seeds", "1",
                     "--agents", ",".join(KINDS), "--episodes", "3", "--steps", "200", "--samples", "500",
                     "--val-samples", "400", "--validation-steps", "300", "--rig-scenarios", "",
                     "--bootstrap", "200", "--refine", "1", "--workers", "1", "--out", str(out)]) == 0
    doc: dict[str, Any] = json.loads((out / "rigs.json").read_text())
    return doc


def test_each_kind_is_refitted_retrained_and_tried_again_on_every_rig(run: dict[str, Any]) -> None:
    assert [k["kind"] for k in run["kinds"]] == [*KINDS, *(f"{k}+refined" for k in KINDS)]
    for rig in run["rigs"]:
        assert rig["rig"] in RIGS and not rig["identification_failed"]
        for kind in KINDS:
            (row,) = [o for o in rig["outcomes"] if o["kind"] == f"{kind}+refined"]
            ref = row["refine"]
            # round 1 ran: its refit worked (a fit on the validation record) and its policy was tried
            assert [r["round"] for r in ref["rounds"]] == [0, 1] and not ref["rounds"][1]["failed"]
            assert ref["rounds"][1]["fit"]["fit_sim_percent"] > 0
            tried = ref["rounds"]
            best = min(tried, key=lambda r: (r["aborted"], r["sse_measured"], r["round"]))
            assert ref["chosen_round"] == best["round"]  # the better *measured* try is kept
            assert isinstance(row["success"], bool) and row["risk"]["contacts"] >= 0
            bill = ref["real_samples"]
            assert bill["accounting"] == "route+rests" and bill["runs"] == 3 * 300
            assert bill["total"] == rig["charged"][kind]["total"] + bill["runs"] + bill["run_rests"]


def test_the_summary_counts_both_rounds_of_both_kinds(run: dict[str, Any]) -> None:
    for k in run["kinds"][len(KINDS):]:
        rounds = k["refine"]["rounds"]
        assert [r["tries"] for r in rounds] == [2, 2] and sum(r["kept"] for r in rounds) == 2
        assert k["refine"]["real_samples_per_run"]["accounting"] == "route+rests"
