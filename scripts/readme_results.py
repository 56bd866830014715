"""Rewrite the README's result tables from ``docs/results/*.json``; ``--check`` fails on drift.

A block in README.md looks like::

    <!-- results:table1_default:table1 -->
    ...generated, never edited by hand...
    <!-- /results -->

``NAME`` is a file ``docs/results/NAME.json`` (written by ``scripts/make_results.py``
or a benchmark) and ``VIEW`` says how to render it. ``--check`` exits 1, naming
the first block that differs, when the README and the JSON disagree; the test
suite runs it.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from msd_bench.core.stats import wilson  # noqa: E402

BLOCK = re.compile(r"(<!-- results:(?P<name>[\w.-]+):(?P<view>[\w-]+) -->\n)(?P<body>.*?)(<!-- /results -->)",
                   re.DOTALL)


def _pct(v: float | None, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def _rate(k: int, n: int) -> str:
    lo, hi = wilson(k, n)
    return f"{k}/{n} ({100 * k / n:.0f} %; {100 * lo:.0f}–{100 * hi:.0f} %)"


def _source(doc: dict[str, Any], name: str) -> str:
    m = doc.get("machine", {})
    return (f"_Generated from `docs/results/{name}.json`: `{doc['command']}` at commit "
            f"`{str(doc['commit'])[:10]}` on {m.get('cpu', '?')} ({m.get('cores', '?')} cores), "
            f"{doc.get('seconds', '?')} s. Cells: successes/n (rate; Wilson 95 % interval)._")


def view_table1(doc: dict[str, Any], name: str) -> str:
    """Table 1 over seeds: fit, identification samples, success with its interval, median SSE."""
    lines = ["| Agent | Fit sim (%) | Id. samples | Real samples in training | Success | SSE median (%) |",
             "|---|---|---|---|---|---|"]
    for a in doc["table1"]["agents"]:
        lines.append(
            f"| {a['label']} | {_pct(a['fit_sim_percent'])} | {a['identification_samples'] or '—'} | "
            f"{a['real_interactions'] or 0:,} | {_rate(a['n_success'], a['n'])} | "
            f"{_pct(a['summary']['sse']['median'])} |")
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def view_robustness(doc: dict[str, Any], name: str) -> str:
    """Each agent kind's fixed tables under every scenario: successes/n with the interval."""
    agents = doc["robustness"]["agents"]
    labels = {a["kind"]: a["label"] for a in doc["table1"]["agents"]}
    scenarios = list(next(iter(agents.values())))
    lines = ["| Agent | " + " | ".join(scenarios) + " |", "|" + "---|" * (len(scenarios) + 1)]
    for kind, cells in agents.items():
        row = [f"{c['n_success']}/{c['n']} ({100 * wilson(c['n_success'], c['n'])[0]:.0f}–"
               f"{100 * wilson(c['n_success'], c['n'])[1]:.0f} %)" for c in cells.values()]
        lines.append(f"| {labels.get(kind, kind)} | " + " | ".join(row) + " |")
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def view_json(doc: dict[str, Any], name: str) -> str:
    """A benchmark's own ``table`` rows (a list of flat objects) as a Markdown table."""
    rows = doc["table"]
    cols = list(rows[0])
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_cell(r.get(c)) for c in cols) + " |" for r in rows]
    return "\n".join([*lines, "", _source(doc, name)]) + "\n"


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.2f}"
    return "—" if v is None else str(v)


VIEWS: dict[str, Callable[[dict[str, Any], str], str]] = {
    "table1": view_table1, "robustness": view_robustness, "table": view_json}


def render(readme: str, results_dir: Path) -> str:
    """The README with every block regenerated from its JSON file."""
    def block(m: re.Match[str]) -> str:
        name, view = m["name"], m["view"]
        path = results_dir / f"{name}.json"
        if not path.is_file():
            raise SystemExit(f"readme_results: error: README block {name}:{view} needs missing {path}")
        if view not in VIEWS:
            raise SystemExit(f"readme_results: error: unknown view {view!r}; choose from {', '.join(VIEWS)}")
        return m.group(1) + VIEWS[view](json.loads(path.read_text()), name) + m.group(5)

    return BLOCK.sub(block, readme)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--check", action="store_true", help="exit 1 if the README differs from the JSON")
    p.add_argument("--readme", type=Path, default=REPO / "README.md")
    p.add_argument("--results", type=Path, default=REPO / "docs" / "results")
    args = p.parse_args(argv)
    text = args.readme.read_text()
    new = render(text, args.results)
    if args.check:
        if new != text:
            first = next(m for m, n in zip(BLOCK.finditer(text), BLOCK.finditer(new), strict=False)
                         if m.group(0) != n.group(0))
            print(f"readme_results: README block {first['name']}:{first['view']} differs from "
                  f"docs/results/{first['name']}.json; run python scripts/readme_results.py", file=sys.stderr)
            return 1
        print(f"readme_results: {len(BLOCK.findall(text))} blocks agree with docs/results")
        return 0
    args.readme.write_text(new)
    print(f"readme_results: rewrote {len(BLOCK.findall(new))} blocks")
    return 0


if __name__ == "__main__":
    sys.exit(main())
