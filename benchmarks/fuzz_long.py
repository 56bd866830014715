"""The fuzz tier's long run: every property in tests/fuzz at >= 10,000 random cases, counted.

    python benchmarks/fuzz_long.py                       # all of tests/fuzz, the long profile
    python benchmarks/fuzz_long.py --examples 2000 tests/fuzz/test_fuzz_models.py
    python benchmarks/fuzz_long.py --out docs/results/fuzz_long.json

Runs ``pytest`` on the fuzz files (every ``tests/fuzz/test_*.py`` by default,
whoever wrote them) with ``MSD_FUZZ_PROFILE=long`` (tests/fuzz/conftest.py:
10,000 random, non-derandomised examples per property unless ``--examples``
says otherwise) and prints one JSON document: per test its outcome and the
number of examples Hypothesis ran (from ``--hypothesis-show-statistics``:
passing + failing test cases summed over its phases; ``null`` for a plain
test), the totals and the wall time. Exits 1 if any test failed.

Why a script and not a marker: the long run takes tens of minutes and is run
on purpose (in the background, ``nice``), never as part of the default suite.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
FUZZ = REPO / "tests" / "fuzz"
HEADER = re.compile(r"^(tests/\S+::\S+):$")
COUNTS = re.compile(r"- (\d+) passing, (\d+) failing, and (\d+) invalid test cases")


def parse_statistics(text: str) -> dict[str, int]:
    """Examples run per test node id, from pytest's ``--hypothesis-show-statistics`` section."""
    counts: dict[str, int] = {}
    current = None
    section = text.split("Hypothesis Statistics", 1)[-1] if "Hypothesis Statistics" in text else ""
    for line in section.splitlines():
        if match := HEADER.match(line.strip()):
            current = match.group(1)
            counts.setdefault(current, 0)
        elif current is not None and (match := COUNTS.search(line)):
            counts[current] += int(match.group(1)) + int(match.group(2))
    return counts


def parse_outcomes(junit: Path) -> dict[str, str]:
    """``passed``/``failed``/``error``/``skipped`` per test node id, from a JUnit XML report."""
    outcomes: dict[str, str] = {}
    for case in ET.parse(junit).getroot().iter("testcase"):
        module, name = case.get("classname", ""), case.get("name", "")
        node = module.replace(".", "/") + ".py::" + name
        tags = {child.tag for child in case}
        outcomes[node] = ("failed" if "failure" in tags else "error" if "error" in tags
                          else "skipped" if "skipped" in tags else "passed")
    return outcomes


def run(files: list[str], examples: int | None, select: str | None = None) -> dict[str, Any]:
    """Run pytest on ``files`` (``select``: its ``-k`` expression) under the long profile; the JSON."""
    load_before = os.getloadavg()[0]
    env = {**os.environ, "MSD_FUZZ_PROFILE": "long"}
    if examples is not None:
        env["MSD_FUZZ_EXAMPLES"] = str(examples)
    with tempfile.TemporaryDirectory() as tmp:
        junit = Path(tmp) / "junit.xml"
        cmd = [sys.executable, "-m", "pytest", *files, *(["-k", select] if select else []), "-q",
               "-p", "no:cacheprovider",
               "--hypothesis-show-statistics", f"--junitxml={junit}"]
        t0 = time.monotonic()
        proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True)
        wall = time.monotonic() - t0
        outcomes = parse_outcomes(junit) if junit.is_file() else {}
    counts = parse_statistics(proc.stdout)
    prefix = ["MSD_FUZZ_PROFILE=long", *([f"MSD_FUZZ_EXAMPLES={examples}"] if examples is not None else [])]
    tests = {node: {"outcome": outcome, "examples": _examples(node, counts)}
             for node, outcome in sorted(outcomes.items())}
    return {
        "command": " ".join([*prefix, "python", *cmd[1:-1]]),
        **provenance(load_before),
        "profile": "long", "examples_setting": examples or 10_000,
        "tests": tests,
        "failed": sorted(n for n, t in tests.items() if t["outcome"] in ("failed", "error")),
        "total_examples": sum(t["examples"] or 0 for t in tests.values()),
        "wall_seconds": round(wall, 1),
        "pytest_exit": proc.returncode,
        "pytest_tail": proc.stdout.strip().splitlines()[-1:] if proc.returncode else [],
        "failing_cases": failing_cases(proc.stdout),
    }


def merge(paths: list[Path]) -> dict[str, Any]:
    """Several runs as one document, keyed by each run's command (the generated docs list them all)."""
    runs = {}
    for path in paths:
        one = json.loads(path.read_text())
        for run_doc in (one["runs"].values() if "runs" in one else [one]):
            runs[run_doc["command"]] = run_doc
    failed = sorted(n for r in runs.values() for n in r["failed"])
    return {"runs": runs, "failed": failed, "pytest_exit": max(r["pytest_exit"] for r in runs.values()),
            "total_examples": sum(r["total_examples"] for r in runs.values())}


def provenance(load_before: float) -> dict[str, Any]:
    """Commit, machine and the load at the start: the generated docs cite them beside the counts."""
    sys.path.insert(0, str(REPO / "scripts"))
    from make_results import commit, machine

    return {"commit": commit(), "machine": machine(), "loadavg_1min_before": round(load_before, 2)}


def failing_cases(text: str, context: int = 12) -> list[str]:
    """The falsifying examples Hypothesis printed (each with the lines after it), so a failed long
    run can be reproduced from its JSON alone."""
    lines = text.splitlines()
    out: list[str] = []
    for i, line in enumerate(lines):
        if "Failing test case" in line or "Falsifying example" in line:
            out += [*lines[max(0, i - 3): i + context], "..."]
    return out[:200]


def _examples(node: str, counts: dict[str, int]) -> int | None:
    """Hypothesis' count for a node (a parametrised node id may carry its parameters)."""
    return counts.get(node, counts.get(node.split("[", 1)[0]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="*", help="fuzz files (default: every tests/fuzz/test_*.py)")
    parser.add_argument("--examples", type=int,
                        help="examples per property (default: the long profile's 10,000)")
    parser.add_argument("-k", dest="select", help="pytest's -k: run only the properties it selects "
                        "(a slow property can then get fewer cases than a fast one, in runs of their own)")
    parser.add_argument("--out", type=Path, help="also write the JSON here")
    parser.add_argument("--merge", type=Path, nargs="+", metavar="RUN_JSON",
                        help="instead of running: combine earlier runs' JSON files into one document")
    args = parser.parse_args(argv)
    if args.examples is not None and args.examples < 1:
        print("fuzz_long: error: --examples must be >= 1", file=sys.stderr)
        return 2
    if args.out is not None and args.out.exists():
        print(f"fuzz_long: error: --out {args.out} already exists; refusing to overwrite", file=sys.stderr)
        return 2
    if args.merge:
        doc = merge(args.merge)
    else:
        files = args.files or sorted(str(p.relative_to(REPO)) for p in FUZZ.glob("test_*.py"))
        doc = run(files, args.examples, args.select)
    text = json.dumps(doc, indent=1)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")
    return 0 if doc["pytest_exit"] == 0 and not doc["failed"] else 1


if __name__ == "__main__":
    sys.exit(main())
