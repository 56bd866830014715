"""The repository explains itself: no file cites a document outside it, and every docs/ citation resolves.

A maintainer who clones the repository must be able to follow every reference.
Design and decisions live in ``docs/``; code and the README cite them as
``docs/<page>.md §<Section>``, where ``<Section>`` is the first word of a
``## `` heading on that page. The outside documents' names are assembled from
pieces below so that this file does not trip its own check.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
_MD = "." + "md"
OUTSIDE = re.compile(
    "|".join([
        r"\bDESIGN(?:" + re.escape(_MD) + r"|\s*§)",
        r"\bSTYLE" + re.escape(_MD),
        r"\bPAPER" + "_NOTES",
        re.escape(".." + "/shared"),
        re.escape("/work" + "/shared"),
    ])
)
"""Names of the design card, the style notes and the paper notes kept outside the repository."""
CITATION = re.compile(r"(?<![\w/.-])(docs/[\w/.-]+\.md)(?:\s+§([\w-]+))?")
"""A path under docs/ ending in .md, optionally followed by ``§Section``."""


def tracked_text_files() -> dict[str, str]:
    """Path -> text of every file git tracks that decodes as UTF-8 (binary files are skipped)."""
    names = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, check=True, capture_output=True,
                           text=True).stdout.split("\0")
    out = {}
    for name in filter(None, names):
        path = REPO / name
        if not path.is_file():
            continue  # deleted in the working tree, not yet committed
        try:
            out[name] = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
    return out


@pytest.fixture(scope="module")
def files() -> dict[str, str]:
    texts = tracked_text_files()
    assert "README.md" in texts and "msd_bench/core/physics/plant.py" in texts  # the listing really ran
    return texts


def headings(page: Path) -> set[str]:
    """First word of every ``## `` heading of a Markdown page (the § names it can be cited by)."""
    words = set()
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"##\s+([\w-]+)", line)
        if m:
            words.add(m.group(1))
    return words


def test_no_file_cites_a_document_outside_the_repository(files: dict[str, str]) -> None:
    hits = [f"{name}:{i}: {line.strip()}" for name, text in files.items()
            for i, line in enumerate(text.splitlines(), 1) if OUTSIDE.search(line)]
    assert not hits, "cite docs/ instead:\n" + "\n".join(hits)


def test_the_outside_names_are_caught() -> None:
    """The pattern above really matches each way the outside documents were cited."""
    for cited in ["(" + "DESIGN" + _MD + " §2)", "DESIGN" + " §2", "STYLE" + _MD,
                  "PAPER" + "_NOTES: 1/16", "see .." + "/shared/x"]:
        assert OUTSIDE.search(cited), cited
    assert not OUTSIDE.search("the design of docs/design.md §Plant")


def test_every_docs_citation_resolves(files: dict[str, str]) -> None:
    cited = [(name, m.group(1), m.group(2)) for name, text in files.items()
             for m in CITATION.finditer(text)]
    assert len({c[1] for c in cited}) >= 2, "expected code and README to cite docs/ pages"
    broken = []
    for name, page, section in cited:
        target = REPO / page
        if not target.is_file():
            broken.append(f"{name}: {page} does not exist")
        elif section is not None and section not in headings(target):
            broken.append(f"{name}: {page} has no section §{section}")
    assert not broken, "\n".join(broken)


def test_docs_index_lists_every_page() -> None:
    index = (REPO / "docs" / "README.md").read_text(encoding="utf-8")
    pages = sorted(p.name for p in (REPO / "docs").glob("*.md") if p.name != "README.md")
    assert pages, "docs/ has no pages"
    missing = [p for p in pages if f"({p})" not in index]
    assert not missing, f"docs/README.md does not link {missing}"
