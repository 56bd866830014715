"""Every test tier is run by something: ``make test`` runs the default, ``.ci/run`` each opt-in tier
(the slow one with its Table 1 reruns capped in size), and docs/testing.md lists them all with the
marker expressions ``scripts/coverage_tiers.py`` measures."""

from __future__ import annotations

import re
import shlex
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import coverage_tiers  # noqa: E402

OPT_IN = ("realtime", "cluster", "node", "slow")
"""The markers the default tier leaves out; each names a tier."""
RELEASE_ONLY: tuple[str, ...] = ()
"""Tiers left to a release check, not to CI: none (no test is run by nothing)."""


def _ci_expressions() -> list[str]:
    """The ``-m`` expressions of the Kilted ``make test`` lines of .ci/run (the bare one runs the
    default); the Jazzy line leaves out e2e, so it cannot stand in for a tier."""
    found = []
    for line in (REPO / ".ci" / "run").read_text().splitlines():
        if not re.match(r"(\w+=\S+ )*make test", line) or "DISTRO=" in line:
            continue
        args = re.search(r'ARGS="(.*)"', line)
        words = shlex.split(args.group(1)) if args else []
        found.append(words[words.index("-m") + 1] if "-m" in words else coverage_tiers.TIERS["default"])
    return found


def _selects(expression: str, marker: str) -> bool:
    """Whether a marker expression of ands can select a test carrying ``marker``."""
    terms = [t.strip() for t in expression.split(" and ")]
    return marker in terms and f"not {marker}" not in terms


def test_the_default_tier_is_make_tests_and_leaves_out_each_opt_in_tier() -> None:
    pytest_ini = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert coverage_tiers.default_expression() == coverage_tiers.TIERS["default"]
    for marker in OPT_IN:
        assert any(m.startswith(f"{marker}:") for m in pytest_ini["markers"]), marker
        assert f"not {marker}" in coverage_tiers.TIERS["default"]


def test_ci_runs_the_default_tier_and_every_opt_in_tier() -> None:
    expressions = _ci_expressions()
    assert coverage_tiers.TIERS["default"] in expressions
    for marker in OPT_IN:
        ran = any(_selects(e, marker) for e in expressions)
        assert ran == (marker not in RELEASE_ONLY), f"tier {marker}: run by .ci/run is {ran}"


def test_the_tiers_partition_the_suite_and_docs_list_each() -> None:
    """A test carrying two opt-in markers belongs to the first tier of PRECEDENCE it carries: each
    tier leaves out the markers before its own, so the tiers together run every test once."""
    precedence = ("slow", "cluster", "node", "realtime")
    assert set(coverage_tiers.TIERS) == {"default", *OPT_IN} == {"default", *precedence}
    for i, tier in enumerate(precedence):
        terms = coverage_tiers.TIERS[tier].split(" and ")
        assert set(terms) == {tier, *(f"not {m}" for m in precedence[:i])}, tier
    assert set(coverage_tiers.TIERS["default"].split(" and ")) == {f"not {m}" for m in precedence}
    page = (REPO / "docs" / "testing.md").read_text()
    for tier in coverage_tiers.TIERS:
        assert re.search(rf"^\| {tier} \|", page, re.MULTILINE), f"docs/testing.md has no row for {tier}"
