"""``msd-bench efficiency --rigs``: the data-efficiency curve on a population of rigs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from msd_bench.cli import main as cli_main

SMALL = ["--seeds", "1", "--agents", "glm,glm+robust", "--episodes", "3", "--steps", "200",
         "--validation-steps", "300", "--workers", "1"]
LENGTH = 4500
"""A record length whose point plays exactly what ``msd-bench rigs --samples 4500 --val-samples 1500`` plays
(the paper's 1,000-sample settle, validation a third of the record)."""


@pytest.fixture(scope="module")
def curve(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("curve") / "run"
    # one run for every test: the open-loop kinds, the refined route (one round) and an on-plant learner
    assert cli_main(["efficiency", "--rigs", "2", "--design", "--first-rig", "3", *SMALL,
                     "--agents", "glm,glm+robust,plant", "--refine", "1", "--budgets", "2,5",
                     "--bootstrap", "200", "--record-samples", f"300,{LENGTH}", "--out", str(out)]) == 0
    doc: dict[str, Any] = json.loads((out / "efficiency.json").read_text())
    doc["points"] = {p.name: json.loads(p.read_text()) for p in (out / "points").iterdir()}
    assert (out / "efficiency.png").stat().st_size > 1000
    return doc


def test_each_point_pools_every_rig_with_a_bootstrap_over_rigs(curve: dict[str, Any]) -> None:
    assert curve["on"] == "rigs" and curve["family"] == "default" and curve["rig_set"] == "design"
    assert curve["rigs_run"] == [3, 4]
    assert [m["name"] for m in curve["methods"]] == ["glm", "glm+robust", "glm+refined", "glm+robust+refined",
                                                     "plant"]
    for method in curve["methods"]:
        lengths = [300, LENGTH] if method["name"] != "plant" else [None, None]
        assert [p["record_samples"] for p in method["points"]] == lengths
        for p in method["points"]:
            assert p["n"] == 2 and p["rigs"] == 2 and 0 <= p["n_success"] <= 2
            assert p["ci95"] == p["bootstrap95"] and 0.0 <= p["ci95"][0] <= p["ci95"][1] <= 1.0
            lo, hi = p["real_samples_range"]
            assert lo <= p["real_samples"] <= hi


def test_a_point_is_charged_its_records_settles_and_the_rests_before_them(curve: dict[str, Any]) -> None:
    part = curve["points"]["n300-rig3.json"]
    # glm: the broad training record (300) and the broad validation record (1,000: never shorter), no
    # settle (multilevel records have none), and whatever the rig took to come to rest before each.
    assert part["charged"]["glm"] > 300 + 1000
    longer = curve["points"][f"n{LENGTH}-rig3.json"]
    assert longer["charged"]["glm"] > part["charged"]["glm"] + 3000  # 4,200 + 500 more
    assert part["charged"]["glm"] == part["charged"]["glm+robust"]  # one surrogate, one bill


def test_the_point_at_the_rigs_record_length_is_the_rigs_result(curve: dict[str, Any],
                                                                 tmp_path: Path) -> None:
    """The curve repeats `msd-bench rigs`, record length aside: at the same plan, the same outcomes."""
    out = tmp_path / "rigs"
    assert cli_main(["rigs", "--rigs", "2", "--design", "--first-rig", "3", *SMALL, "--bootstrap", "200",
                     "--samples", str(LENGTH), "--val-samples", str(LENGTH // 3), "--rig-scenarios", "",
                     "--out", str(out)]) == 0
    for seed in (3, 4):
        rig = json.loads((out / "rigs" / f"rig-{seed}.json").read_text())
        point = curve["points"][f"n{LENGTH}-rig{seed}.json"]
        open_loop = [o for o in point["outcomes"] if "refined" not in o["kind"]]
        assert [(o["kind"], o["success"], o["sse"]) for o in open_loop] == \
            [(o["kind"], o["success"], o["sse"]) for o in rig["outcomes"]]


def test_the_refined_route_is_charged_its_tries_and_its_fresh_run(curve: dict[str, Any]) -> None:
    assert curve["refine_rounds"] == 1
    assert curve["methods"][3]["label"].endswith("refined on the rig")
    for name in curve["points"]:
        if name.startswith("n300-"):
            charged = curve["points"][name]["charged"]
            # one round: the open-loop try, then (if the refit and retraining worked) the refined one,
            # then the fresh validation run: 300 samples each, and a rest of at least 300 before each
            extra = charged["glm+robust+refined"] - charged["glm+robust"]
            assert 2 * (300 + 300) <= extra < 3 * 300 + 3 * 3000, extra


def test_on_plant_learners_train_on_each_rig_and_are_charged_every_step(curve: dict[str, Any]) -> None:
    plant = curve["methods"][-1]
    assert plant["label"].endswith("trained on each rig")
    got = [(p["episodes"], p["real_samples"], p["n"]) for p in plant["points"]]
    assert got == [(2, 400, 2), (5, 1000, 2)]  # episodes x 200 steps, one run per rig


@pytest.mark.parametrize(("extra", "line"), [
    (["--design"], "--design apply to the curve on rigs: add --rigs N or --family NAME"),
    (["--refine", "1"], "--refine apply to the curve on rigs"),
    (["--rigs", "2", "--budgets", "0"], "budgets must be >= 1 episode"),
    (["--family", "stages"], "unknown rig family 'stages'"),
    (["--family", "stage"], "rig family 'stage' runs under its hold loop: the efficiency curve is not built"),
    (["--rigs", "2", "--agents", "plant,dyna-q"], "draws on-plant learners beside a surrogate route"),
    (["--rigs", "2", "--record-samples", "50"], "record samples must be >= 100"),
    (["--rigs", "2", "--record-samples", "300,300"], "record samples repeat"),
    (["--rigs", "2", "--id-seeds", "2"], "--id-seeds must be 1"),
])
def test_bad_options_are_one_line_and_write_nothing(extra: list[str], line: str, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x"
    assert cli_main(["efficiency", *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert line in err and len(err.splitlines()) == 1, err
    assert not out.exists()
