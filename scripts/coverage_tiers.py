"""Line coverage of ``msd_bench`` by the default test tier beside the full suite's (every tier).

    python scripts/coverage_tiers.py                      # every tier, then docs/results/coverage.json
    python scripts/coverage_tiers.py --tiers realtime     # rerun some tiers, keeping the others' data

Each tier runs once, as its own pytest process, under coverage.py; the full suite is the union of
the tiers (their marker expressions partition the suite, so no test runs twice). Node processes and
other Python subprocesses the tests start are measured too: coverage.py's wheel installs a start-up
hook (``a1_coverage.pth``) that calls ``coverage.process_startup()`` in every Python process that
finds ``COVERAGE_PROCESS_START`` in its environment, so nothing is written into the environment
and no ``sitecustomize`` is needed. A process killed by SIGKILL, or started with an environment of
its own, is not measured; numba-compiled loops never run their Python lines. Both numbers share
these limits, so their difference is the default tier's loss.

A tier's data is kept under ``build/coverage/<tier>/`` (ours alone: wiped before the tier reruns);
docs/results/coverage.json is written, atomically, only when every tier has data (or, with
``--partial``, naming the tiers that have none), and
``scripts/readme_results.py`` renders it into docs/testing.md.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))
sys.path.insert(0, str(REPO))

from make_results import commit, machine  # noqa: E402

from msd_bench.io.storage.atomic import write_text_atomic  # noqa: E402

TIERS: dict[str, str] = {
    "default": "not slow and not realtime and not cluster and not node",
    "realtime": "realtime and not slow and not cluster and not node",
    "cluster": "cluster and not slow",
    "node": "node and not slow and not cluster",
    "slow": "slow",
}
"""Each tier's marker expression: together they select every test exactly once."""
STORE = REPO / "build" / "coverage"
OUT = REPO / "docs" / "results" / "coverage.json"
RC = """[run]
source_pkgs = msd_bench
parallel = true
data_file = {data}
sigterm = true
patch = _exit, fork
disable_warnings = no-data-collected, module-not-imported, module-not-measured, already-imported

[report]
precision = 2
"""
"""The coverage configuration every measured process reads (through COVERAGE_PROCESS_START):
data files per process (``parallel``), saved on SIGTERM, ``os._exit`` and in forked children,
and no warning printed into a test's captured output."""


def default_expression() -> str:
    """The marker expression of ``make test`` (pyproject's addopts): the default tier must be it."""
    import shlex
    import tomllib
    addopts = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["addopts"]
    words = shlex.split(addopts)
    return words[words.index("-m") + 1]


def _rcfile(where: Path) -> Path:
    rc = where / "coveragerc"
    rc.write_text(RC.format(data=where / ".coverage"))
    return rc


def _counts(junit: Path) -> dict[str, int]:
    """Tests, failures, errors and skips from pytest's JUnit XML (zeros if pytest wrote none)."""
    if not junit.is_file():
        return {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    suite = ET.parse(junit).getroot()
    suite = suite if suite.tag == "testsuite" else suite[0]
    return {k: int(suite.get(k, "0")) for k in ("tests", "failures", "errors", "skipped")}


def run_tier(name: str, pytest_args: list[str]) -> dict[str, Any]:
    """One tier's tests under coverage, its data combined into ``build/coverage/<name>/.coverage``."""
    where = STORE / name
    if where.exists():
        shutil.rmtree(where)
    where.mkdir(parents=True)
    rc = _rcfile(where)
    env = {**os.environ, "COVERAGE_PROCESS_START": str(rc)}
    cmd = [sys.executable, "-m", "pytest", "-m", TIERS[name], "-p", "no:cacheprovider", "-q",
           f"--junitxml={where / 'junit.xml'}", *pytest_args]
    print(f"coverage_tiers: {name}: {' '.join(cmd[1:])}", flush=True)
    start = time.monotonic()
    code = subprocess.run(cmd, cwd=REPO, env=env, check=False).returncode
    seconds = round(time.monotonic() - start, 1)
    percent = _combine(where, rc)
    meta = {"marker": TIERS[name], "commit": commit(), "exit": code, "seconds": seconds,
            "line_percent": percent,
            **_counts(where / "junit.xml")}
    (where / "tier.json").write_text(json.dumps(meta, indent=1))
    print(f"coverage_tiers: {name}: {percent:.2f} % of lines, pytest exit {code}, {seconds} s", flush=True)
    return meta


def _combine(where: Path, rc: Path) -> float:
    """Merge the per-process data files of one tier and return its total line coverage."""
    import coverage
    cov = coverage.Coverage(config_file=str(rc), data_file=str(where / ".coverage"))
    cov.combine([str(where)], keep=False)
    cov.save()
    return float(cov.report(file=io.StringIO()))


def union(names: list[str]) -> dict[str, Any]:
    """Line coverage of the tiers together: every tier's combined data merged into one."""
    import coverage
    where = STORE / "full"
    if where.exists():
        shutil.rmtree(where)
    where.mkdir(parents=True)
    rc = _rcfile(where)
    for n in names:
        shutil.copy(STORE / n / ".coverage", where / f".coverage.{n}")
    cov = coverage.Coverage(config_file=str(rc), data_file=str(where / ".coverage"))
    cov.combine([str(where)], keep=False)
    cov.save()
    out = io.StringIO()
    percent = float(cov.report(file=out))
    total = out.getvalue().strip().splitlines()[-1].split()
    return {"line_percent": percent, "statements": int(total[1]), "missed": int(total[2])}


def stored(name: str) -> dict[str, Any] | None:
    """A tier's record from an earlier run, or None if it has none."""
    meta = STORE / name / "tier.json"
    return json.loads(meta.read_text()) if meta.is_file() and (STORE / name / ".coverage").is_file() else None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tiers", default=",".join(TIERS),
                   help=f"comma-separated tiers to (re)run, of {', '.join(TIERS)} (default: all)")
    p.add_argument("--partial", action="store_true",
                   help="write the JSON even if a tier other than default has no data, naming it as missing "
                        "(the full-suite number is then the measured tiers' union, and says so)")
    p.add_argument("pytest_args", nargs="*", help="more pytest arguments (after --), e.g. --durations=0")
    args = p.parse_args(argv)
    chosen = [t.strip() for t in args.tiers.split(",") if t.strip()]
    unknown = [t for t in chosen if t not in TIERS]
    if unknown:
        p.error(f"unknown tier {unknown[0]!r}; choose from {', '.join(TIERS)}")
    if default_expression() != TIERS["default"]:
        p.error(f"pyproject's default marker expression {default_expression()!r} is not the default "
                f"tier's {TIERS['default']!r}; update TIERS")
    for name in chosen:
        run_tier(name, args.pytest_args)
    found = {n: stored(n) for n in TIERS}
    tiers = {n: m for n, m in found.items() if m is not None}
    missing = [n for n in TIERS if n not in tiers]
    if (missing and not args.partial) or "default" in missing:
        print(f"coverage_tiers: no data for tier(s) {', '.join(missing)}; docs/results/coverage.json not "
              f"written (run --tiers {','.join(missing)})", file=sys.stderr)
        return 1
    full = union(list(tiers))
    doc = {"command": "python scripts/coverage_tiers.py", "commit": commit(), "machine": machine(),
           "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "package": "msd_bench",
           "tiers": tiers, "missing": missing, "full": full}
    write_text_atomic(OUT, json.dumps(doc, indent=1) + "\n")
    default = tiers["default"] or {}
    print(f"coverage_tiers: default {default['line_percent']:.2f} %, "
          f"{'full suite' if not missing else 'tiers but ' + ', '.join(missing)} "
          f"{full['line_percent']:.2f} % -> {OUT.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
