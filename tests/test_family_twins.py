"""scripts/family_twins.py: a family's runs paired with their default-family twins, run by run; runs
of other rigs, seeds or kinds refused in one line; a file it did not write never replaced."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import family_twins  # noqa: E402
import readme_results  # noqa: E402

RIGS, SEEDS, KINDS = [1000, 1001, 1002], [0, 1], ["plm", "greybox+robust"]


def rigs_doc(family: str | None, fail: frozenset[tuple[int, str, int]] = frozenset()) -> dict[str, Any]:
    """A rigs.json of the given family in which every run succeeds but those in ``fail``."""
    population: dict[str, Any] = {"module": "msd_bench.core.population", "held_out_first": 1000}
    if family is not None:
        population["family"] = family
    return {"rigs_run": RIGS, "learning_seeds": SEEDS, "agents": KINDS, "population": population,
            "sweep": {"wall_seconds": 600.0, "workers": 1},
            "rigs": [{"rig": r, "outcomes": [{"kind": k, "seed": s, "success": (r, k, s) not in fail}
                                             for k in KINDS for s in SEEDS]} for r in RIGS]}


def write(path: Path, doc: dict[str, Any]) -> Path:
    path.write_text(json.dumps(doc))
    return path


def test_the_pairing_counts_equal_runs_and_names_every_one_that_parts(tmp_path: Path) -> None:
    parts = frozenset({(1001, "plm", 1), (1002, "greybox+robust", 0)})
    fam = write(tmp_path / "scaled.json", rigs_doc("scaled", parts))
    twin = write(tmp_path / "default.json", rigs_doc(None, frozenset({(1001, "plm", 1), (1000, "plm", 0)})))
    out = tmp_path / "twins.json"
    assert family_twins.main([str(fam), str(twin), "--out", str(out), "--runs-at", "abc"]) == 0
    doc = json.loads(out.read_text())
    assert doc["pairs"] == 12 and doc["equal"] == 10 and doc["runs_commit"] == "abc"
    assert doc["parted"] == [
        {"rig": 1000, "kind": "plm", "seed": 0, "family": True, "twin": False},
        {"rig": 1002, "kind": "greybox+robust", "seed": 0, "family": False, "twin": True}]
    assert doc["rigs_parted"] == [1000, 1002]
    assert doc["kinds"]["plm"]["equal"] == 5 and doc["kinds"]["plm"]["family"]["successes"] == 5
    assert doc["kinds"]["plm"]["twin"]["successes"] == 4
    assert (doc["kinds"]["plm"]["only_family"], doc["kinds"]["plm"]["only_twin"]) == (1, 0)
    assert doc["kinds"]["plm"]["mcnemar_p"] == 1.0

    assert doc["runs"]["family"]["command"].startswith(
        "msd-bench rigs --family scaled --rigs 3 --first-rig 1000")
    text = readme_results.VIEWS["family_twins"](doc, "twins")
    assert "**10 of 12**" in text and "| `plm` | 5 / 6 | 1 / 0 | 1.00 |" in text and "1000, 1002" in text
    assert family_twins.main([str(fam), str(twin), "--out", str(out)]) == 0  # its own file: rewritten


@pytest.mark.parametrize(("change", "says"), [
    (lambda d: d.update(learning_seeds=[0]), "differ in learning_seeds"),
    (lambda d: d.update(agents=["plm"]), "differ in agents"),
    (lambda d: d["population"].update(family="scaled"), "not 'default'"),
])
def test_runs_that_are_not_twins_are_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], change: Any, says: str) -> None:
    twin_doc = rigs_doc(None)
    change(twin_doc)
    fam = write(tmp_path / "scaled.json", rigs_doc("scaled"))
    twin = write(tmp_path / "default.json", twin_doc)
    out = tmp_path / "twins.json"
    assert family_twins.main([str(fam), str(twin), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1 and not out.exists()


def test_a_file_it_did_not_write_is_never_replaced(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fam = write(tmp_path / "scaled.json", rigs_doc("scaled"))
    twin = write(tmp_path / "default.json", rigs_doc(None))
    out = write(tmp_path / "notes.json", {"mine": True})
    assert family_twins.main([str(fam), str(twin), "--out", str(out)]) == 2
    assert "not overwriting" in capsys.readouterr().err and json.loads(out.read_text()) == {"mine": True}
    missing = tmp_path / "nothing.json"
    assert family_twins.main([str(missing), str(twin), "--out", str(tmp_path / "x.json")]) == 2


def test_mcnemar_p_is_small_only_for_a_one_sided_split() -> None:
    assert family_twins.mcnemar_p(0, 0) == 1.0
    assert family_twins.mcnemar_p(5, 5) == 1.0
    assert family_twins.mcnemar_p(0, 10) == 2 / 2 ** 10
    assert 0.05 < family_twins.mcnemar_p(3, 8) < 0.3


def test_the_twin_run_is_checked_against_a_committed_run(tmp_path: Path) -> None:
    fam = write(tmp_path / "scaled.json", rigs_doc("scaled"))
    twin = write(tmp_path / "default.json", rigs_doc(None))
    ref = write(tmp_path / "ref.json", rigs_doc(None, frozenset({(1000, "plm", 0)})))
    out = tmp_path / "twins.json"
    assert family_twins.main([str(fam), str(twin), "--twin-reference", str(ref), "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["twin_reproduces"] == {"reference": str(ref), "runs": 12, "equal_success": 11, "equal_sse": 12}
    assert "11 of 12 successes" in readme_results.VIEWS["family_twins"](doc, "twins")
