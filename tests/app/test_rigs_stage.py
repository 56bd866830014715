"""``msd-bench rigs --family stage``: stages recorded under their hold loop, their held systems
identified, agents deciding at the paper's pace under the loop (issue 38 item 3), at a tiny budget."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from msd_bench.cli import main as cli_main

STAGE = ["rigs", "--family", "stage", "--design", "--first-rig", "1", "--rigs", "1", "--seeds", "1",
         "--agents", "plm+robust,greybox+robust", "--episodes", "3", "--steps", "200", "--samples", "500",
         "--val-samples", "400", "--validation-steps", "300", "--rig-scenarios", "", "--bootstrap", "200",
         "--workers", "1"]


def test_a_stage_runs_in_process_under_its_hold_loop(tmp_path: Path) -> None:
    from msd_bench.core.rigs.stage_family import draw

    out = tmp_path / "stage"
    assert cli_main([*STAGE, "--out", str(out)]) == 0
    doc = json.loads((out / "rigs.json").read_text())
    (rig,) = doc["rigs"]
    spec = draw(1)
    assert rig["rig"] == 1 and rig["design"] and doc["population"]["family"] == "stage"
    assert not rig["identification_failed"] and set(rig["fits"]) == {"plm", "greybox"}
    assert all(f["fit_sim_percent"] > 50.0 for f in rig["fits"].values())  # the held system, not the drift
    assert [o["kind"] for o in rig["outcomes"]] == ["plm+robust", "greybox+robust"]
    for o in rig["outcomes"]:
        assert o["identified"] and o["risk"]["contacts"] == 0
        assert abs(o["start_x"]) < 0.05 * spec.params.L  # every run starts where the hold loop rested it
    # a plant of its own is reported in physical units, with its stroke, force limit, rate and offset
    p = spec.params
    assert (rig["parameters"]["mass"], rig["parameters"]["stroke"], rig["parameters"]["rate"]) == (
        p.m, p.L, 1.0 / p.dt)
    assert rig["parameters"]["offset"] == spec.imperfections.offset
    assert "| rig | mass kg | stroke m | F N | rate Hz |" in (out / "rigs.md").read_text()


@pytest.mark.parametrize("extra", [["--ceiling"], ["--refine", "1"], ["--supervisor", "on"]])
def test_what_a_held_family_cannot_do_yet_is_one_line_and_writes_nothing(
        extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main([*STAGE, *extra, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "rig family 'stage' runs under its hold loop" in err, err
    assert not (tmp_path / "x").exists()
