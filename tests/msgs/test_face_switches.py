"""No caller branches on which plant face it holds: the faces are objects behind one interface.

Why a test: ``PlantInterface`` used to be one tagged dataclass whose kind was
tested in fifteen branches of its own and more in ``msd_msgs_py/ros.py``, the
bag reader and the rig node. Now each face is a subclass registered in
``FACES``, and the faces' differences are answered by the subclasses. One
``if iface.kind == MSD`` outside them and the next face needs an edit there
again. The scan below finds a comparison against a face's name (the constants
``MSD`` / ``ROS2_CONTROL``, the strings ``"msd"`` / ``"ros2_control"``, a
face's ``NAME``) and an ``isinstance``/``type`` test against a face class,
anywhere in the project but inside the face classes themselves; the last tests
prove it catches each on a planted line.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from msd_bench.core.errors import InterfaceError
from msd_msgs_py import interface
from msd_msgs_py.interface import FACES, INTERFACE_KINDS, PlantInterface, make
from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("msd_bench", "msd_msgs_py", "launch_scripts", "scripts", "benchmarks")
FACE_NAMES = frozenset(FACES)
FACE_CONSTANTS = frozenset({"MSD", "ROS2_CONTROL", "NAME"})
FACE_CLASSES = frozenset(cls.__name__ for cls in FACES.values())


def _names_a_face(node: ast.AST) -> bool:
    """The expression mentions a face's name or class anywhere inside it."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.Constant) and isinstance(sub.value, str) and sub.value in FACE_NAMES:
            return True
        name = sub.id if isinstance(sub, ast.Name) else sub.attr if isinstance(sub, ast.Attribute) else None
        if name in FACE_CONSTANTS or name in FACE_CLASSES:
            return True
    return False


def switches(tree: ast.AST) -> list[tuple[int, str]]:
    """Every comparison against a face's name and every isinstance/type test against a face class in
    ``tree``, except inside the face classes' own bodies."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name in FACE_CLASSES:
            inside |= {id(sub) for sub in ast.walk(node)}
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if id(node) in inside:
            continue
        if isinstance(node, ast.Compare) and any(_names_a_face(x) for x in (node.left, *node.comparators)):
            found.append((node.lineno, "compares with a face's name"))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id in ("isinstance", "issubclass", "type") \
                and any(_names_a_face(a) for a in node.args[1:]):
            found.append((node.lineno, "tests a face's class"))
    return found


def _scanned_files() -> list[Path]:
    return sorted(p for d in SCANNED for p in (ROOT / d).rglob("*.py") if "__pycache__" not in p.parts)


def test_no_module_branches_on_a_face() -> None:
    found = [f"{p.relative_to(ROOT)}:{line}: {what}" for p in _scanned_files()
             for line, what in switches(parse_source(p.read_text(), str(p)))]
    assert found == [], "branches on a plant face outside its class:\n" + "\n".join(found)


def test_the_scan_reads_the_faces_module_and_its_classes() -> None:
    """The scan covers interface.py and does skip the face classes (else it proves nothing)."""
    source = (ROOT / "msd_msgs_py" / "interface.py").read_text()
    assert (ROOT / "msd_msgs_py" / "interface.py") in _scanned_files()
    assert all(f"class {name}(PlantInterface)" in source for name in FACE_CLASSES)


@pytest.mark.parametrize("planted", [
    "if iface.kind == MSD:\n    pass\n",
    "r2c = self.interface.kind == ROS2_CONTROL\n",
    "if face.get('interface', 'msd') != 'msd':\n    pass\n",
    "if iface.kind in ('ros2_control',):\n    pass\n",
    "scalar = iface.kind is not interface.ROS2_CONTROL\n",
    "if iface.NAME == other:\n    pass\n",
    "if isinstance(iface, Ros2ControlFace):\n    pass\n",
    "if isinstance(iface, (interface.MsdFace, int)):\n    pass\n",
])
def test_the_scan_catches_a_planted_branch(planted: str) -> None:
    assert switches(parse_source(planted)), planted


@pytest.mark.parametrize("neutral", [
    "if iface.reset is None:\n    pass\n",
    "pos = iface.position or iface.state\n",
    "if model.kind == KIND_PLANT:\n    pass\n",
    "class MsdFace(PlantInterface):\n    def f(self):\n        return self.kind == MSD\n",
])
def test_the_scan_leaves_questions_to_the_face_and_the_face_classes_alone(neutral: str) -> None:
    assert switches(parse_source(neutral)) == [], neutral


def test_faces_are_one_registry() -> None:
    assert INTERFACE_KINDS == tuple(FACES) == ("msd", "ros2_control")
    for name, cls in FACES.items():
        face = make(name)
        assert type(face) is cls and face.kind == name and isinstance(face, PlantInterface)
        assert face.params().resolve() == face


def test_an_unknown_face_is_one_line_everywhere() -> None:
    for build in (lambda: make("gazebo"), lambda: interface.InterfaceParams("gazebo").resolve(),
                  lambda: interface.face_class("gazebo")):
        with pytest.raises(InterfaceError) as err:
            build()
        assert str(err.value) == "interface must be one of msd, ros2_control, got 'gazebo'"


def test_the_faces_interface_cannot_be_built_bare() -> None:
    with pytest.raises(TypeError):
        PlantInterface("slider")  # type: ignore[abstract]
