"""``msd-bench rigs --ceiling --refine R`` on one tiny rig: the new rows, what they charge, and that
the rows a run had before stay its runs bit for bit."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from msd_bench.cli import main as cli_main

TINY = ["rigs", "--rigs", "1", "--first-rig", "1012", "--seeds", "2", "--agents", "plm,greybox+robust",
        "--episodes", "3", "--steps", "200", "--samples", "500", "--val-samples", "400",
        "--validation-steps", "300", "--rig-scenarios", "setpoint=-0.5", "--bootstrap", "200",
        "--workers", "1"]


def _task(*extra: str) -> tuple[Any, dict[str, Any]]:
    from msd_bench.app.rigs import rig_task
    from msd_bench.cli import build_parser
    from msd_bench.commands.rigs import rigs_config

    cfg = rigs_config(build_parser().parse_args([*TINY, *extra, "--out", "unused"]))
    return cfg, rig_task(cfg, 1012)


Both = tuple[dict[str, Any], Any, dict[str, Any]]
"""A run without the new rows, the configuration with them, and that run."""


@pytest.fixture(scope="module")
def both() -> Both:
    plain = _task()[1]
    cfg, more = _task("--ceiling", "--refine", "2")
    return plain, cfg, more


def test_the_rows_of_a_run_without_them_are_unchanged(both: Both) -> None:
    plain, cfg, more = both
    assert cfg.kinds() == ("plm", "greybox+robust", "truth+robust", "truth-plant+robust",
                           "plm+refined", "greybox+robust+refined")
    old = [o for o in more["outcomes"] if o["kind"] in ("plm", "greybox+robust")]
    # the ceiling and the refinement run after them, on their own streams (compared as text: NaN == NaN)
    assert json.dumps(old) == json.dumps(plain["outcomes"])
    assert {k: v for k, v in more.items() if k not in ("outcomes", "seconds")} == \
        {k: v for k, v in plain.items() if k not in ("outcomes", "seconds")}


def test_the_ceiling_and_the_refined_rows_charge_every_real_sample(both: Both) -> None:
    _, cfg, more = both
    for route in ("truth+robust", "truth-plant+robust"):
        ceiling = [o for o in more["outcomes"] if o["kind"] == route]
        assert [o["seed"] for o in ceiling] == [0, 1] and all(isinstance(o["success"], bool) for o in ceiling)
    refined = [o for o in more["outcomes"] if o["kind"] == "greybox+robust+refined"]
    assert [o["seed"] for o in refined] == [0, 1]
    steps = cfg.run.validation_steps
    for o in refined:
        ref = o["refine"]
        rounds = [r for r in ref["rounds"] if "samples" in r]
        assert [r["round"] for r in ref["rounds"]] == [0, 1, 2] and len(rounds) == 3
        assert all(r["risk"]["override_share"] >= 0 and r["risk"]["aborted"] is None for r in rounds)
        assert ref["rounds"][0]["fit"] == {} and "fit_sim_percent" in ref["rounds"][1]["fit"]
        best = min(rounds, key=lambda r: r["sse_measured"])  # the kept policy: the best *measured* try
        assert ref["chosen_round"] == best["round"]
        charged = ref["real_samples"]
        assert charged["accounting"] == "route+rests"
        assert charged["tries"] == 3 * steps and charged["fresh_validation"] == steps
        assert charged["runs"] == 4 * steps  # three tries and the fresh run ...
        assert charged["run_rests"] >= 4 * 300  # ... each after a rest of at least the rest window
        # the open-loop route's own bill (its records and their rests, not the PLM's bias records), then
        # the runs: the one accounting of the efficiency curve too
        own = more["charged"]["greybox+robust"]
        assert (charged["records"], charged["record_rests"]) == (own["records"], own["record_rests"])
        assert charged["total"] == own["total"] + charged["runs"] + charged["run_rests"]
        assert o["risk"]["override_share"] >= 0 and set(o["scenarios"]) == {"setpoint=-0.5"}


def test_the_plm_is_refitted_through_its_blend_and_charged_its_bias_records(both: Both) -> None:
    _, cfg, more = both
    refined = [o for o in more["outcomes"] if o["kind"] == "plm+refined"]
    assert [o["seed"] for o in refined] == [0, 1]
    own = more["charged"]["plm"]
    for o in refined:
        ref = o["refine"]
        assert [r["failed"] for r in ref["rounds"]] == ["", "", ""]  # both refits of the PLM held
        assert all("fit_sim_percent" in r["fit"] for r in ref["rounds"][1:])
        charged = ref["real_samples"]
        assert (charged["records"], charged["record_rests"]) == (own["records"], own["record_rests"])
        assert charged["tries"] == 3 * cfg.run.validation_steps


def test_a_route_is_charged_its_own_records_and_the_rests_before_them(both: Both) -> None:
    plain, _, _ = both
    grey, plm = plain["charged"]["greybox+robust"], plain["charged"]["plm"]
    assert grey["records"] == 500 + 400  # the broad record and the broad validation record, no settle
    rests = plain["rests"]["before_experiments"]
    assert grey["record_rests"] == rests[5] + rests[11] and min(rests) >= 300  # plan: 5 bias, broad, twice
    # the PLM: its five bias records (settle segments included) and the same validation record
    assert plm["records"] == 5 * (500 + 1000) + 400 and plm["record_rests"] == sum(rests[:5]) + rests[11]
    assert grey["total"] == grey["records"] + grey["record_rests"]
    assert plain["charged"].keys() == {"plm", "greybox+robust"}


def test_the_summary_counts_each_round(both: Both) -> None:
    from msd_bench.app.rigs import document

    _, cfg, more = both
    doc = document(cfg, [more])
    row = doc["kinds"][-1]
    assert row["kind"] == "greybox+robust+refined"
    assert row["label"] == "Grey-box (robust agent), refined on the rig"
    rounds = row["refine"]["rounds"]
    assert [r["tries"] for r in rounds] == [2, 2, 2] and sum(r["kept"] for r in rounds) == 2
    runs = [o for o in more["outcomes"] if o["kind"] == row["kind"]]
    assert [r["successes"] for r in rounds] == \
        [sum(o["refine"]["rounds"][i]["success"] for o in runs) for i in range(3)]
    assert [c["kind"] for c in doc["ceiling"]] == ["truth+robust", "truth-plant+robust"]


@pytest.mark.parametrize(("extra", "message"), [
    (["--refine", "-1"], "--refine must be in 0..10"),
    (["--refine", "1", "--refine-weight", "0"], "--refine-weight in 1..10"),
    (["--refine", "1", "--agents", "plant"], "--refine refits the identified model an agent was made on"),
])
def test_bad_refine_options_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         extra: list[str], message: str) -> None:
    assert cli_main([*TINY, *extra, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and not (tmp_path / "x").exists()
