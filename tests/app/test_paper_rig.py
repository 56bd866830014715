"""msd-bench paper --rig FILE: the in-process method on the emulated plant of a rig description."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from msd_bench.cli import main

LONG_EVERY_SAMPLE = ("/**:\n  ros__parameters:\n    rate: 250.0\n    stroke: 20.0\n    force_limit: 40.0\n"
                     "    decision_period: 0.004\n")
"""The long-stroke rig of config/rigs/long_250hz.yaml, deciding every sample."""


def test_a_rig_deciding_every_few_samples_is_one_line(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    rig = Path(__file__).resolve().parents[2] / "config" / "rigs" / "long_250hz.yaml"
    assert main(["paper", "--rig", str(rig), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "validates every sample so far; this rig decides every 2 samples" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


@pytest.mark.slow
def test_the_method_runs_in_the_rigs_units(tmp_path: Path) -> None:
    """A tiny run (about 90 s, mostly compiling): the plant is the rig's, the budgets the same seconds, the
    set-point the paper's share of the stroke, the PLM identified from the rig's bias records."""
    rig, out = tmp_path / "rig.yaml", tmp_path / "out"
    rig.write_text(LONG_EVERY_SAMPLE)
    assert main(["paper", "--rig", str(rig), "--out", str(out), "--seeds", "1", "--episodes", "2",
                 "--steps", "200", "--samples", "600", "--val-samples", "400", "--validation-steps", "300",
                 "--agents", "glm+improved,plm", "--workers", "1", "--no-figures"]) == 0
    run = json.loads((out / "table1.json").read_text())["run"]
    assert (run["plant"]["L"], run["plant"]["F"], run["plant"]["dt"]) == (20.0, 40.0, 0.004)
    assert run["rig"]["rate"] == 250.0 and run["samples"] == 1500 and run["target"] == pytest.approx(4.0)
    kinds = {r["kind"] for r in json.loads((out / "table1.json").read_text())["agents"]}
    assert kinds == {"glm+improved", "plm"}
