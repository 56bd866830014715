"""The README is a front door: its first screen holds the two commands, the run time and the way on.

A newcomer reads the first screen (about 40 lines) and decides. These tests
keep that screen true: the two commands exactly as the Makefile runs them, the
generated run time (a block ``scripts/readme_results.py`` fills from
``docs/results/performance.json``), the report's page, and links into
``docs/`` that resolve — and the whole README well under 100 lines.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
FIRST_SCREEN = 40

COMMANDS = ["make bench   # sets up .venv if needed, then runs: python launch_scripts/bench.py",
            "make test    # sets up .venv if needed, then runs the default test tier (pytest; every tier: "
            "docs/testing.md)"]
"""The two commands as the README gives them (they must stay true: see the Makefile test); ``make
test`` runs the default tier, the opt-in tiers are CI's (docs/testing.md §Tiers)."""

NEXT = ["docs/paper.md", "docs/bench.md", "docs/own-bags.md", "docs/extending.md", "docs/results.md"]
"""Where to go next: in-process runs, the main job, a rig and your own bags, extending, every result."""

LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def _lines() -> list[str]:
    return README.read_text(encoding="utf-8").splitlines()


def test_the_first_screen_holds_the_commands_the_run_time_and_the_links() -> None:
    screen = "\n".join(_lines()[:FIRST_SCREEN])
    assert all(c in screen for c in COMMANDS)
    assert "report/index.html" in screen
    assert all(f"]({page})" in screen for page in NEXT), "the way on must be on the first screen"
    block = screen.split("<!-- results:performance:bench_time -->")[1].split("<!-- /results -->")[0]
    assert re.search(r"takes about \*\*\d+ s\*\*", block), "the generated run time is missing or empty"


def test_the_commands_are_what_the_makefile_runs() -> None:
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^bench:.*\n(\t.*\n)*\t.*launch_scripts/bench\.py", makefile, re.MULTILINE)
    assert re.search(r"^test:.*\n(\t.*\n)*\t.*pytest", makefile, re.MULTILINE)


def test_the_readme_is_short_and_links_on() -> None:
    lines = _lines()
    assert len(lines) < 100
    text = "\n".join(lines)
    assert "docs/img/report.png" in text and "<!-- results:table1_default:headline -->" in text
    assert all(f"]({page})" in text for page in NEXT)
    targets = LINK.findall(text)
    missing = [t for t in targets if not t.startswith(("http://", "https://")) and not (REPO / t).exists()]
    assert targets and not missing, f"README links that do not resolve: {missing}"


def test_every_docs_link_resolves() -> None:
    """The pages the README's prose moved to link each other relatively; none may dangle."""
    missing = []
    for page in sorted((REPO / "docs").glob("*.md")):
        for target in LINK.findall(page.read_text(encoding="utf-8")):
            local = not target.startswith(("http://", "https://", "mailto:"))
            if local and not (page.parent / target).exists():
                missing.append(f"{page.name} -> {target}")
    assert not missing, missing
