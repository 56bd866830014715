"""check-rig on the ros2_control face: the rig emulator passes; a wrong joint or order fails its clause."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import pytest
from rclpy.context import Context
from rclpy.parameter import Parameter

from msd_bench.cli import main
from msd_bench.io.rigs.rig_file import read_rig
from msd_bench.nodes.rig_node import RigNode
from tests.rig.conftest import check, failed, serving

pytestmark = pytest.mark.ros
_names = itertools.count()
R2C = ["--interface", "ros2_control", "--controller", "effort_controller"]


def r2c_rig(ns: str, **params: object):  # type: ignore[no-untyped-def]
    values = {"duplicate_check": 0.0, "interface": "ros2_control",
              "controller_joints": ["wheel", "slider_to_cart"], **params}

    def build(ctx: Context) -> RigNode:
        return RigNode(namespace=ns, context=ctx,
                       parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
    return serving(build)


def _ns() -> str:
    return f"/r2c{os.getpid()}_{next(_names)}"


def test_the_rig_emulator_with_the_ros2_control_face_passes(tmp_path: Path) -> None:
    ns, written = _ns(), tmp_path / "measured.yaml"
    with r2c_rig(ns):
        clauses = check(ns, *R2C, "--joint", "slider_to_cart", "--controller-joints", "wheel,slider_to_cart",
                        "--write-rig", str(written))
    _written_rig_is_what_was_measured(written, ns)
    report = "\n".join(c.line() for c in clauses)
    assert failed(clauses) == [], report
    names = [c.name for c in clauses]
    assert "joint" in names and "position" not in names, report
    joint = next(c for c in clauses if c.name == "joint")
    assert "entry 2 of 2: ['pole_joint', 'slider_to_cart']" in joint.figure
    by_name = {c.name: c for c in clauses}
    assert "effort_controller/commands subscribers 1" in by_name["publishers"].figure
    assert next(c for c in clauses if c.name == "reset").figure.startswith("unsupported")


@pytest.mark.realtime
def test_a_wrong_joint_and_a_wrong_joint_order_fail_their_clauses() -> None:
    ns = _ns()
    with r2c_rig(ns):
        absent = check(ns, *R2C, "--joint", "cart", "--controller-joints", "wheel,cart")
        # one value per joint, but ours first: the rig reads the command for 'wheel' and applies 0 N
        swapped = check(ns, *R2C, "--joint", "slider_to_cart", "--controller-joints", "slider_to_cart,wheel")
    assert "joint" in failed(absent), "\n".join(c.line() for c in absent)
    assert {"effort-step", "saturation"} <= set(failed(swapped)), "\n".join(c.line() for c in swapped)


def test_the_readme_command_passes_against_the_default_face() -> None:
    """rig.py -p interface:=ros2_control, checked with exactly the README's options."""
    ns = _ns()
    values = {"duplicate_check": 0.0, "interface": "ros2_control"}

    def build(ctx: Context) -> RigNode:
        return RigNode(namespace=ns, context=ctx,
                       parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
    with serving(build):
        clauses = check(ns, *R2C, "--joint", "slider_to_cart")
    assert failed(clauses) == [], "\n".join(c.line() for c in clauses)



def _written_rig_is_what_was_measured(out: Path, ns: str) -> None:
    """check-rig --write-rig (the check above): the file reads back as a description whose rate and
    force limit are the node's, whose stroke is what the mass moved within, with the face it was
    checked through; a second run refuses to overwrite it before any ROS work."""
    rig = read_rig(out)
    assert rig.rate == pytest.approx(100.0, rel=1e-3) and rig.force_limit == pytest.approx(10.0, rel=0.01)
    assert 0.0 < rig.stroke <= 5.0 and rig.plant_ns == ns
    assert (rig.interface, rig.joint, rig.controller_joints) == ("ros2_control", "slider_to_cart",
                                                                ("wheel", "slider_to_cart"))
    before = out.read_text()
    assert before.startswith("# Starting rig description written by msd-bench check-rig")
    assert main(["check-rig", ns, "--write-rig", str(out)]) == 2
    assert out.read_text() == before
