"""No caller switches on what a kind is: ``k.dyna``, ``== PLANT`` and ``LEARNERS[`` live in the designs only.

Why a test: the protocol is only worth having if every question about a kind
goes through its design; one switch outside the package and the next design
needs an edit there again (issue 22).
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("msd_bench", "scripts", "launch_scripts", "benchmarks")
DESIGNS = ROOT / "msd_bench" / "designs"


def _named(node: ast.AST, name: str) -> bool:
    return (isinstance(node, ast.Name) and node.id == name) or (
        isinstance(node, ast.Attribute) and node.attr == name)


def switches(tree: ast.AST) -> list[tuple[int, str]]:
    """Every ``<x>.dyna``, ``== PLANT`` / ``!= PLANT`` and ``LEARNERS[...]`` in ``tree`` (a class's own
    field called ``dyna``, ``self.dyna``, is not a kind: plant_ns's Duration has one, in seconds)."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr == "dyna" and not _named(node.value, "self"):
            found.append((node.lineno, ".dyna"))
        elif isinstance(node, ast.Compare) and any(isinstance(op, ast.Eq | ast.NotEq) for op in node.ops) \
                and any(_named(side, "PLANT") for side in [node.left, *node.comparators]):
            found.append((node.lineno, "== PLANT"))
        elif isinstance(node, ast.Subscript) and _named(node.value, "LEARNERS"):
            found.append((node.lineno, "LEARNERS["))
    return found


def test_the_scan_finds_each_switch():
    tree = ast.parse("a = k.dyna\nz = self.dyna\nb = k.surrogate == PLANT\nc = PLANT != x\n"
                     "d = agents.LEARNERS[k.agent]()\n")
    assert [w for _, w in switches(tree)] == [".dyna", "== PLANT", "== PLANT", "LEARNERS["]


def test_no_switch_on_a_kind_outside_the_designs_package():
    hits = []
    for top in SCANNED:
        for path in sorted((ROOT / top).rglob("*.py")):
            if DESIGNS in path.parents:
                continue
            hits += [f"{path.relative_to(ROOT)}:{line}: {what}"
                     for line, what in switches(ast.parse(path.read_text(), str(path)))]
    assert hits == [], "switches on a kind outside msd_bench/designs:\n" + "\n".join(hits)
