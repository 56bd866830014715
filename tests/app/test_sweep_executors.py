"""The sweeps give the same files whichever executor ran their tasks (local pool or a Ray cluster)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from msd_bench.cli import main as cli_main

EFFICIENCY = ["efficiency", "--seeds", "1", "--id-seeds", "2", "--agents", "glm+improved,plant",
              "--record-samples", "300", "--budgets", "1,2", "--steps", "100", "--validation-steps", "100",
              "--episodes", "2"]


@pytest.mark.cluster  # a whole sweep on Ray: the cluster tier (docs/testing.md §Tiers)
@pytest.mark.usefixtures("ray_cluster")
def test_efficiency_on_ray_writes_the_json_of_the_local_pool(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main([*EFFICIENCY, "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    assert cli_main([*EFFICIENCY, "--executor", "ray", "--workers", "2", "--out", str(tmp_path / "ray")]) == 0
    local, ray = (json.loads((tmp_path / d / "efficiency.json").read_text()) for d in ("local", "ray"))
    assert ray == local
    assert [len(m["points"]) for m in local["methods"]] == [1, 2]  # one record length, two budgets


def test_an_unknown_executor_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        cli_main([*EFFICIENCY, "--executor", "slurm", "--out", str(tmp_path / "x")])
    assert stop.value.code == 2 and "invalid choice: 'slurm'" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_ray_address_without_ray_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main([*EFFICIENCY, "--ray-address", "auto", "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err.strip().endswith("--ray-address needs --executor ray")


PAPER = ["paper", "--seeds", "1", "--id-seeds", "2", "--agents", "glm,greybox+lqr", "--episodes", "2",
         "--steps", "100", "--samples", "300", "--val-samples", "300", "--validation-steps", "200",
         "--dyna-episodes", "1", "--no-figures", "--nlarx-scale", "0.05"]


def _without_run_facts(doc: dict[str, Any]) -> dict[str, Any]:
    """table1.json apart from timing and where it ran (the run's ``seconds`` and ``executor``)."""
    run = {k: v for k, v in doc["run"].items() if k not in ("seconds", "executor")}
    return {**doc, "run": run}


@pytest.mark.cluster  # a whole sweep on Ray: the cluster tier (docs/testing.md §Tiers)
@pytest.mark.usefixtures("ray_cluster")
def test_paper_on_ray_writes_the_tables_of_the_local_pool(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main([*PAPER, "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    assert cli_main([*PAPER, "--executor", "ray", "--workers", "2", "--out", str(tmp_path / "ray")]) == 0
    for name in ("table1.json", "robustness.json"):
        local, ray = (json.loads((tmp_path / d / name).read_text()) for d in ("local", "ray"))
        if name == "table1.json":
            assert ray["run"]["executor"] == "ray" and local["run"]["executor"] == "local"
            local, ray = _without_run_facts(local), _without_run_facts(ray)
        assert ray == local
