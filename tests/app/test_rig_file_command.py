"""``msd-bench rig-file``: a family member's description holds what its owner states, and nothing else."""

from __future__ import annotations

from pathlib import Path

import pytest

from msd_bench.cli import main as cli_main
from msd_bench.core.rigs import families
from msd_bench.io.rigs.rig_file import read_rig


def test_a_stages_file_states_its_rate_stroke_force_decision_and_hold_loop(tmp_path: Path) -> None:
    out = tmp_path / "stage.yaml"
    assert cli_main(["rig-file", "--family", "stage", "--member", "1000", "--out", str(out)]) == 0
    member, rig = families.draw("stage", 1000), read_rig(out)
    p = member.params
    assert (rig.dt, rig.stroke, rig.force_limit) == pytest.approx((p.dt, p.L, p.F))
    assert rig.samples_per_decision == member.decision_samples() and rig.hold() == member.hold
    text = out.read_text()
    assert "mass" not in text and "friction" not in text  # never what a real rig's file would not hold


def test_a_default_members_file_has_no_hold_loop_and_nothing_is_overwritten(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "rig.yaml"
    assert cli_main(["rig-file", "--member", "1000", "--out", str(out)]) == 0
    assert read_rig(out).hold() is None and read_rig(out).samples_per_decision == 1
    before = out.read_text()
    capsys.readouterr()
    assert cli_main(["rig-file", "--member", "1001", "--out", str(out)]) == 2
    assert out.read_text() == before and len(capsys.readouterr().err.strip().splitlines()) == 1
    assert cli_main(["rig-file", "--family", "stages", "--member", "1", "--out", str(tmp_path / "x")]) == 2
    assert "unknown rig family 'stages'" in capsys.readouterr().err and not (tmp_path / "x").exists()
