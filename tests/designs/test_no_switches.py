"""No caller switches on what a kind is: every question about a kind is answered in the designs package.

Why a test: the protocol is only worth having if every question about a kind
goes through its design; one switch outside the package and the next design
needs an edit there again (issues 22 and 31). Three scans, each proven on a
planted case:

- switches: ``k.dyna``, ``== PLANT`` and ``LEARNERS[``;
- property checks: reading ``.on_plant``, ``.model_free``, ``.baseline`` or
  ``.deterministic`` of anything but ``self`` (ask :mod:`msd_bench.designs.kinds`
  or the policy's facts instead);
- literal kind names in the product (``msd_bench/``): a string naming an agent
  kind that only an agent kind is called (``plm+robust``, ``plm@away``,
  ``dyna-q``). Bare model names (``plm``) and ``plant`` also name model kinds,
  nodes and namespaces, so they are not flagged. Docstrings may name kinds.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from msd_bench.designs import AGENT_KINDS
from msd_bench.designs.registry import PLANT
from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]
SCANNED = ("msd_bench", "scripts", "launch_scripts", "benchmarks")
DESIGNS = ROOT / "msd_bench" / "designs"
PROPERTIES = ("on_plant", "model_free", "baseline", "deterministic")
"""What callers used to ask of a kind, its design or its policy's facts."""


def _named(node: ast.AST, name: str) -> bool:
    return (isinstance(node, ast.Name) and node.id == name) or (
        isinstance(node, ast.Attribute) and node.attr == name)


def switches(tree: ast.AST) -> list[tuple[int, str]]:
    """Every ``<x>.dyna``, ``== PLANT`` / ``!= PLANT``, ``LEARNERS[...]`` and read of a kind property in
    ``tree`` (a class's own field, ``self.<name>``, is not a kind's: plant_ns's Duration has ``dyna``)."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and not _named(node.value, "self") \
                and node.attr in ("dyna", *PROPERTIES):
            found.append((node.lineno, f".{node.attr}"))
        elif isinstance(node, ast.Compare) and any(isinstance(op, ast.Eq | ast.NotEq) for op in node.ops) \
                and any(_named(side, "PLANT") for side in [node.left, *node.comparators]):
            found.append((node.lineno, "== PLANT"))
        elif isinstance(node, ast.Subscript) and _named(node.value, "LEARNERS"):
            found.append((node.lineno, "LEARNERS["))
    return found


def only_kind_names() -> set[str]:
    """Agent kind names that name nothing else (see the module docstring)."""
    models_and_plant = {k for k in AGENT_KINDS if "+" not in k and "@" not in k and k != "dyna-q"}
    return set(AGENT_KINDS) - models_and_plant - {PLANT}


def _docstrings(tree: ast.AST) -> set[int]:
    return {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)}


def literal_kinds(tree: ast.AST, names: set[str]) -> list[tuple[int, str]]:
    """Every string (not a docstring) holding one of ``names`` as a word of a list (``"a,b"``, ``"a b"``)."""
    skip = _docstrings(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip:
            hits = sorted(set(re.split(r"[\s,;]+", node.value)) & names)
            found += [(node.lineno, f"literal {h!r}") for h in hits]
    return found


def _scan(tops: tuple[str, ...], find) -> list[str]:  # type: ignore[no-untyped-def]
    hits = []
    for top in tops:
        for path in sorted((ROOT / top).rglob("*.py")):
            if DESIGNS in path.parents:
                continue
            hits += [f"{path.relative_to(ROOT)}:{line}: {what}"
                     for line, what in find(parse_source(path.read_text(), str(path)))]
    return hits


def test_the_scan_finds_each_switch():
    tree = parse_source("a = k.dyna\nz = self.dyna\nb = k.surrogate == PLANT\nc = PLANT != x\n"
                     "d = agents.LEARNERS[k.agent]()\n")
    assert [w for _, w in switches(tree)] == [".dyna", "== PLANT", "== PLANT", "LEARNERS["]


def test_the_scan_finds_each_property_check():
    tree = parse_source("a = [k for k in ks if agent_kind(k).on_plant]\nb = k.design.model_free\n"
                     "c = facts.baseline\nd = policy.facts.deterministic\ne = self.baseline\n")
    assert [w for _, w in sorted(switches(tree))] == [
        ".on_plant", ".model_free", ".baseline", ".deterministic"]


def test_the_scan_finds_literal_kind_names_but_not_docstrings_or_model_names():
    names = only_kind_names()
    assert {"plm+robust", "dyna-q", "glm+pid", "plm@away"} <= names and not {"plm", "glm", "plant"} & names
    tree = parse_source('"""Docstring naming plm+robust."""\nA = ("plm+robust", "plm")\n'
                     'B = "glm+improved,dyna-q"\nif "dyna-q" in free:\n    pass\nC = "plant.py"\n')
    assert [w for _, w in sorted(literal_kinds(tree, names))] == [
        "literal 'plm+robust'", "literal 'dyna-q'", "literal 'glm+improved'", "literal 'dyna-q'"]
    assert sorted(line for line, _ in literal_kinds(tree, names)) == [2, 3, 3, 4]


def test_no_switch_on_a_kind_outside_the_designs_package():
    hits = _scan(SCANNED, switches)
    assert hits == [], "switches on a kind outside msd_bench/designs:\n" + "\n".join(hits)


def test_no_literal_kind_name_in_the_product_outside_the_designs_package():
    names = only_kind_names()
    hits = _scan(("msd_bench",), lambda tree: literal_kinds(tree, names))
    assert hits == [], "agent kind names outside msd_bench/designs:\n" + "\n".join(hits)
