"""scripts/trim_rigs.py: a committed rigs.json without each run's scenario cells renders the same."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import readme_results  # noqa: E402
import trim_rigs  # noqa: E402

SOURCE = REPO / "docs" / "results" / "rigs_heldout20.json"


def test_the_trimmed_file_renders_every_view_as_the_whole_one(tmp_path: Path) -> None:
    whole = json.loads(SOURCE.read_text())
    assert any("scenarios" in o for rig in whole["rigs"] for o in rig["outcomes"])  # something to trim
    out = tmp_path / "small.json"
    assert trim_rigs.main([str(SOURCE), str(out)]) == 0
    small = json.loads(out.read_text())
    assert not any("scenarios" in o for rig in small["rigs"] for o in rig["outcomes"])
    assert small["trimmed"] == {"dropped": trim_rigs.DROPPED} and out.stat().st_size < SOURCE.stat().st_size
    for view in ("rigs_kinds", "rigs_floors"):
        assert readme_results.VIEWS[view](small, "x") == readme_results.VIEWS[view](whole, "x")


@pytest.mark.parametrize("text, message", [("{", "rigs.json: "),
                                           ('{"schema": "other"}', "is not a rigs.json")])
def test_a_file_that_is_not_a_rigs_json_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                     text: str, message: str) -> None:
    source = tmp_path / "rigs.json"
    source.write_text(text)
    assert trim_rigs.main([str(source), str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("trim_rigs: error: ") and message in err
    assert not (tmp_path / "out.json").exists()


def test_the_sweep_options_come_along_from_its_run_directory(tmp_path: Path) -> None:
    """rigs.json does not hold the sweep's options; its run directory's manifest does."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "rigs.json").write_text(SOURCE.read_text())
    out = tmp_path / "small.json"
    assert trim_rigs.main([str(run / "rigs.json"), str(out)]) == 0
    assert "run_config" not in json.loads(out.read_text())  # no manifest: nothing invented
    config = {"run": {"agents": ["glm+pid"], "seeds": 4}, "robust_actuator": "measured"}
    (run / "manifest.json").write_text(json.dumps({"schema": "msd-bench/run", "command": "rigs",
                                                   "config": config}))
    assert trim_rigs.main([str(run / "rigs.json"), str(out)]) == 0
    assert json.loads(out.read_text())["run_config"] == config


def test_runs_of_keeps_the_runs_of_those_kinds_and_every_pooled_row(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    whole = json.loads(SOURCE.read_text())
    out = tmp_path / "some.json"
    assert trim_rigs.main([str(SOURCE), str(out), "--runs-of", "plm+robust"]) == 0
    small = json.loads(out.read_text())
    assert {o["kind"] for rig in small["rigs"] for o in rig["outcomes"]} == {"plm+robust"}
    assert small["kinds"] == whole["kinds"] and small["trimmed"]["runs_of"] == ["plm+robust"]
    assert readme_results.VIEWS["rigs_kinds"](small, "x") == readme_results.VIEWS["rigs_kinds"](whole, "x")
    assert trim_rigs.main([str(SOURCE), str(tmp_path / "no.json"), "--runs-of", "nope"]) == 2
    assert "--runs-of nope: not a kind of" in capsys.readouterr().err and not (tmp_path / "no.json").exists()
