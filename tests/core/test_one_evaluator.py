"""One evaluator under scenarios: :func:`robustness.evaluate_policy` (issue 34 item 1).

Why a test: three evaluators once scored a policy under the scenario suite beside
``evaluate_policy`` (the Q-tables', the baselines', deep RL's), each building a
scenario's loop view and noise streams itself; two evaluators of one design can
then disagree, and only one of them recorded risk. Every design is now a policy
scored by ``evaluate_policy``. The rule: outside :data:`EVALUATOR`, nothing in the
product, its scripts or its benchmarks uses what only an evaluator needs, the
scenario's noise streams and loop view (:data:`SCENARIO_PARTS`), and the old
evaluators' names do not come back. :data:`EXCEPTIONS` names what still does, with why.

The scan is proven on planted cases, as tests/core/test_one_loop.py proves its own.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]
EVALUATOR = "msd_bench/core/evaluation/robustness.py"
"""The one evaluator's module."""
SCENARIO_PARTS = frozenset({"sensor_noise", "conditions"})
"""robustness's scenario -> noise streams and scenario -> loop conditions: an evaluator's parts."""
SCANNED = ("msd_bench", "scripts", "benchmarks")

EXCEPTIONS: dict[str, str] = {
    "scripts/robust_design.py": "the robust agent's design study scores its candidates on a surrogate "
    "standing in for the plant (so no plant takes part in the choice); evaluate_policy scores on the "
    "plant, and that study's recorded rounds stay reproducible as they ran",
}

GONE = tuple((f"msd_bench.core.{module}", name)
             for module in ("baselines.designs", "deeprl.validate", "evaluation.robustness")
             for name in ("evaluate", "rollouts"))
"""(module, name) of the folded evaluators and their per-design rollouts under a scenario."""


def scenario_parts_used(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, name) of every use of robustness's scenario parts: imported by name, or as
    ``robustness.<part>``."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").endswith("evaluation.robustness"):
            found += [(node.lineno, a.name) for a in node.names if a.name in SCENARIO_PARTS]
        elif (isinstance(node, ast.Attribute) and node.attr in SCENARIO_PARTS
              and isinstance(node.value, ast.Name) and node.value.id == "robustness"):
            found.append((node.lineno, node.attr))
    return found


def scan(root: Path = ROOT) -> dict[str, list[str]]:
    """File -> the scenario parts it uses, for every scanned file but the evaluator's module."""
    hits: dict[str, list[str]] = {}
    for top in SCANNED:
        for path in sorted((root / top).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            if rel == EVALUATOR:
                continue
            for line, name in scenario_parts_used(parse_source(path.read_text(), rel)):
                hits.setdefault(rel, []).append(f"{rel}:{line}: {name}")
    return hits


def test_the_scan_finds_each_way_of_reaching_the_parts() -> None:
    planted = ("from msd_bench.core.evaluation.robustness import cell, sensor_noise\n"
               "from msd_bench.core.evaluation import robustness\n"
               "from msd_bench.core.rigs.rig_loop import conditions\n"
               "x = robustness.conditions(sc, 0.01)\n"
               "y = robustness.evaluate_policy\n")
    assert scenario_parts_used(parse_source(planted)) == [(1, "sensor_noise"), (4, "conditions")]


def test_a_planted_evaluator_fails_the_check(tmp_path: Path) -> None:
    core = tmp_path / "msd_bench" / "core" / "evaluation"
    core.mkdir(parents=True)
    (core / "robustness.py").write_text("def sensor_noise(sc, seeds, steps):\n    return None\n")
    (tmp_path / "scripts").mkdir()
    (tmp_path / "scripts" / "again.py").write_text(
        "from msd_bench.core.evaluation.robustness import conditions\n"
        "def evaluate(policy, scenarios):\n    return [conditions(sc, 0.01) for sc in scenarios]\n")
    assert scan(tmp_path) == {"scripts/again.py": ["scripts/again.py:1: conditions"]}


@pytest.fixture(scope="module")
def found() -> dict[str, list[str]]:
    """The repository's scan, once for both checks below."""
    return scan()


def test_no_evaluator_outside_the_one_but_the_named_exceptions(found: dict[str, list[str]]) -> None:
    new = sorted(set(found) - set(EXCEPTIONS))
    assert not new, "scenario evaluation outside robustness.evaluate_policy:\n" + "\n".join(
        line for key in new for line in found[key])


def test_every_exception_is_still_needed(found: dict[str, list[str]]) -> None:
    stale = sorted(set(EXCEPTIONS) - set(found))
    assert not stale, "exceptions that no longer evaluate on their own (drop them):\n" + "\n".join(stale)


@pytest.mark.parametrize(("module", "name"), GONE)
def test_the_folded_evaluators_do_not_come_back(module: str, name: str) -> None:
    assert not hasattr(importlib.import_module(module), name)
