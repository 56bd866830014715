"""Opt-in (``pytest -m slow``): the README's headline counts reproduce within 99 % prediction intervals.

Reruns each stored results command (``scripts/make_results.py``) and checks
every agent kind's success count against the count stored in
``docs/results/<name>.json``. On the machine that wrote them the rerun is bit
for bit identical; on another CPU only in distribution, hence the interval.
Takes minutes per result, so it is not in the default run.

``MSD_REPRODUCE_SEEDS=N`` reruns each command at no more than N learning seeds (``--seeds``): the
first N of the stored run's seeds, so CI (``.ci/run``) reruns every table at a size it can afford.
The interval is predicted for the rerun's own count of trials, so a smaller rerun is judged as
fairly, only less tightly.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from msd_bench.core.evaluation.stats import prediction_interval

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))

import make_results  # noqa: E402

pytestmark = pytest.mark.slow
STORED = sorted(p.stem for p in (REPO / "docs" / "results").glob("table1_*.json"))
SCRIPTS = {"table1_deeprl": "scripts/deeprl_table1.py"}
"""Stored Table 1 documents another script writes (not a ``make_results.py`` command): each is rerun
by the script its ``command`` field names, so every stored table has a rerun that can pass."""


def capped(argv: list[str], cap: int | None) -> list[str]:
    """``argv`` with its ``--seeds`` value lowered to ``cap`` (unchanged without one)."""
    out = list(argv)
    if cap is not None and "--seeds" in out:
        i = out.index("--seeds") + 1
        out[i] = str(min(int(out[i]), cap))
    return out


def seeds_cap() -> int | None:
    """``MSD_REPRODUCE_SEEDS`` as a positive count, None when unset (the stored size)."""
    raw = os.environ.get("MSD_REPRODUCE_SEEDS", "")
    if not raw:
        return None
    if not raw.isdigit() or int(raw) < 1:
        pytest.fail(f"MSD_REPRODUCE_SEEDS={raw!r}: must be a positive whole number")
    return int(raw)


def rerun(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """The document ``name``'s own command writes afresh under ``tmp_path``."""
    if name in make_results.COMMANDS:
        monkeypatch.setattr(make_results, "RESULTS", tmp_path)
        monkeypatch.setitem(make_results.COMMANDS, name, capped(make_results.COMMANDS[name], seeds_cap()))
        doc: dict[str, Any] = json.loads(make_results.run(name).read_text())
        return doc
    if name not in SCRIPTS:
        pytest.fail(f"{name}.json: no make_results.py command and no script in SCRIPTS reruns it")
    out = tmp_path / f"{name}.json"
    subprocess.run([sys.executable, str(REPO / SCRIPTS[name]), "--out", str(out)], cwd=REPO, check=True,
                   timeout=3600)
    written: dict[str, Any] = json.loads(out.read_text())
    return written


@pytest.mark.parametrize("name", STORED)
def test_counts_reproduce_within_the_prediction_interval(name: str, tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    stored = json.loads((REPO / "docs" / "results" / f"{name}.json").read_text())
    assert stored["command"].startswith("msd-bench paper") or stored["command"] == SCRIPTS.get(name), name
    fresh = rerun(name, tmp_path, monkeypatch)
    old = {a["kind"]: a for a in stored["table1"]["agents"]}
    for a in fresh["table1"]["agents"]:
        before = old[a["kind"]]
        lo, hi = prediction_interval(before["n_success"], before["n"], a["n"])
        assert lo <= a["n_success"] <= hi, (
            f"{name} {a['kind']}: {a['n_success']}/{a['n']} outside [{lo}, {hi}] "
            f"predicted from {before['n_success']}/{before['n']}")


def test_a_cap_lowers_only_the_seeds() -> None:
    argv = ["paper", "--seeds", "64", "--id-seeds", "3"]
    assert capped(argv, 8) == ["paper", "--seeds", "8", "--id-seeds", "3"]
    assert capped(argv, 100) == argv and capped(argv, None) == argv
    assert capped(["paper"], 8) == ["paper"]
