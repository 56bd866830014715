"""A rig description given as --params-file: checked whole before any node starts (one line, exit 2)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench.core.errors import ConfigError
from msd_bench.nodes.params import check_rig_files

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_RIG = ROOT / "config" / "rigs" / "default.yaml"


def _argv(path: Path) -> list[str]:
    return ["node", "--ros-args", "--params-file", str(path)]


def test_default_rig_and_plain_params_files_pass(tmp_path: Path) -> None:
    check_rig_files(_argv(DEFAULT_RIG))
    plain = tmp_path / "plain.yaml"
    plain.write_text("/**:\n  ros__parameters:\n    seed: 3\n")  # no rate: not a rig description
    check_rig_files(_argv(plain))


@pytest.mark.parametrize(("text", "needle"), [
    ("rate: 100.0\n    strok: 5.0\n    force_limit: 10.0\n", "did you mean stroke?"),
    ("rate: 100.0\n    stroke: 5.0\n", "force_limit in"),
    ("rate: 1000.0\n    stroke: 0.25\n    force_limit: 350.0\n", "paper's plant only so far"),
])
def test_bad_or_unsupported_rig_is_one_line(tmp_path: Path, text: str, needle: str) -> None:
    path = tmp_path / "rig.yaml"
    path.write_text("/**:\n  ros__parameters:\n    " + text)
    with pytest.raises(ConfigError) as caught:
        check_rig_files(_argv(path))
    assert needle in str(caught.value) and str(path) in str(caught.value)


def test_plant_node_refuses_a_bad_rig_file_before_starting(tmp_path: Path) -> None:
    path = tmp_path / "rig.yaml"
    path.write_text("/**:\n  ros__parameters:\n    rate: 0\n    stroke: 5.0\n    force_limit: 10.0\n")
    done = subprocess.run([sys.executable, str(ROOT / "launch_scripts" / "plant.py"), "--ros-args",
                           "--params-file", str(path)], capture_output=True, text=True, timeout=60,
                          check=False)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip().splitlines() == [f"error: rate in {path} must be > 0, got 0"]
