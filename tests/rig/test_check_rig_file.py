"""check-rig --rig FILE: force limit, dt and face from the file; explicit options win; bad file = one line."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from msd_bench.cli import main
from msd_bench.commands import check_rig

FAST = ("/**:\n  ros__parameters:\n    rate: 1000.0\n    stroke: 0.25\n    force_limit: 350.0\n"
        "    interface: ros2_control\n    joint: stage\n")


def _args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    check_rig.register(parser.add_subparsers())
    return parser.parse_args(["check-rig", *argv])


def test_rig_file_gives_force_limit_dt_and_face(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    rig.write_text(FAST)
    args = _args(["/rig", "--rig", str(rig)])
    check_rig.apply_rig(args)
    assert (args.force_limit, args.dt, args.interface, args.joint) == (350.0, 0.001, "ros2_control", "stage")
    args = _args(["/rig", "--rig", str(rig), "--force-limit", "100", "--joint", "other"])
    check_rig.apply_rig(args)
    assert (args.force_limit, args.joint) == (100.0, "other")


def test_a_typed_default_face_wins_over_the_files(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    rig.write_text(FAST)
    args = _args(["/rig", "--rig", str(rig), "--interface", "msd"])
    check_rig.apply_rig(args)
    assert args.interface == "msd"


def test_without_a_rig_the_defaults_are_the_plants() -> None:
    args = _args(["/rig"])
    check_rig.apply_rig(args)
    assert (args.force_limit, args.dt, args.interface) == (10.0, 0.01, "msd")


@pytest.mark.parametrize(("text", "message"), [
    (FAST.replace("rate: 1000.0", "rate: -1"), "rate in"),
    (FAST.replace("stroke", "strok"), "did you mean stroke?"),
])
def test_a_bad_rig_file_is_one_line_and_writes_nothing(tmp_path: Path, text: str, message: str,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    rig, out = tmp_path / "rig.yaml", tmp_path / "clauses.json"
    rig.write_text(text)
    assert main(["check-rig", "/rig", "--rig", str(rig), "--json", str(out)]) == 2
    stdout, err = capsys.readouterr()
    assert stdout == "" and len(err.splitlines()) == 1 and message in err and str(rig) in err
    assert not out.exists()
