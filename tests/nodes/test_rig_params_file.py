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
    ("rate: 250.0\n    stroke: 20.0\n    force_limit: 40.0\n", "not a whole number of rig samples"),
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


def test_a_described_rig_is_kept_and_gives_the_nodes_its_plant(tmp_path: Path) -> None:
    from msd_bench.core.physics.plant import PlantParams
    from msd_bench.nodes.params import params_file_rig, rig_plant

    stage = ROOT / "config" / "rigs" / "stage_1khz.yaml"
    check_rig_files(_argv(stage))
    try:
        rig = params_file_rig()
        assert rig is not None and rig.rate == 1000.0
        p = rig_plant(PlantParams())
        assert (p.L, p.F, p.dt) == (0.25, 350.0, 0.001)
        with pytest.raises(ConfigError, match="give one rig description per node"):
            check_rig_files([*_argv(stage), "--params-file", str(DEFAULT_RIG)])
    finally:
        check_rig_files(["node"])
    assert params_file_rig() is None and rig_plant(PlantParams()) == PlantParams()


def test_the_rig_option_is_the_params_file_form(tmp_path: Path) -> None:
    from msd_bench.nodes.params import expand_rig_option

    assert expand_rig_option(["rig.py", "--rig", str(DEFAULT_RIG), "--ros-args", "-p", "seed:=1"]) == [
        "rig.py", "--ros-args", "-p", "seed:=1", "--ros-args", "--params-file", str(DEFAULT_RIG)]
    plain = ["rig.py", "--ros-args", "-r", "__ns:=/x"]
    assert expand_rig_option(plain) == plain
    with pytest.raises(ConfigError, match="--rig needs a file"):
        expand_rig_option(["rig.py", "--rig"])
    with pytest.raises(ConfigError, match="no such file"):
        expand_rig_option(["rig.py", "--rig", str(tmp_path / "missing.yaml")])


def test_rig_script_refuses_a_missing_rig_file_in_one_line(tmp_path: Path) -> None:
    missing = tmp_path / "missing.yaml"
    done = subprocess.run([sys.executable, str(ROOT / "launch_scripts" / "rig.py"), "--rig", str(missing)],
                          capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [f"error: --rig {missing}: no such file"]
