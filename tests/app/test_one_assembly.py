"""Table 1 and robustness are assembled in one place, whichever engine or executor made the policies.

Why a scan: ``app/pipeline._collect`` and ``graph/bench_report.load_results`` once built Table 1 each
their own way (issue 22), and ``app/paper_tasks`` evaluated and merged robustness beside
:func:`msd_bench.app.scoring.assemble`; the next copy would drift silently. So outside
``app/scoring.py`` (and the science in ``core/evaluation/robustness.py``) no module makes a Table-1 row
(``agent_result``) or evaluates or merges robustness cells (``evaluate_policy``, ``merge``).
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]
OWNERS = {ROOT / "msd_bench" / "app" / "scoring.py",
          ROOT / "msd_bench" / "core" / "evaluation" / "robustness.py"}


def assemblies(tree: ast.AST) -> list[tuple[int, str]]:
    """Every call of a Table-1 or robustness assembler in ``tree``."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        fn = node.func
        name = fn.id if isinstance(fn, ast.Name) else fn.attr if isinstance(fn, ast.Attribute) else ""
        owner = fn.value.id if isinstance(fn, ast.Attribute) and isinstance(fn.value, ast.Name) else ""
        if name in ("agent_result", "evaluate_policy") or (name == "merge" and owner == "robustness"):
            found.append((node.lineno, name))
    return sorted(found)


def test_the_scan_finds_each_assembly():
    tree = parse_source("a = agent_result(k, rows)\nb = robustness.evaluate_policy(p)\n"
                        "c = robustness.merge(x)\nd = scoring.agent_result(k)\ne = other.merge(x)\n"
                        "f = assemble(k, r)\n")
    assert [n for _, n in assemblies(tree)] == ["agent_result", "evaluate_policy", "merge", "agent_result"]


def test_table1_and_robustness_are_assembled_only_by_scoring():
    hits = []
    for top in ("msd_bench", "scripts", "launch_scripts"):
        for path in sorted((ROOT / top).rglob("*.py")):
            if path in OWNERS:
                continue
            hits += [f"{path.relative_to(ROOT)}:{line}: {name}"
                     for line, name in assemblies(parse_source(path.read_text(), str(path)))]
    assert hits == [], "Table 1 or robustness assembled outside app/scoring.py:\n" + "\n".join(hits)

