"""The commands that write docs/results for docs/baselines.md, driven through their command lines:
a bad input is one line and exit 2, and a results file that exists is never overwritten."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[1]


def _script(monkeypatch: pytest.MonkeyPatch, rel: str) -> ModuleType:
    """Load a script as a module; bench_mpc's import-time ``NUMBA_NUM_THREADS`` default is undone."""
    monkeypatch.setenv("NUMBA_NUM_THREADS", os.environ.get("NUMBA_NUM_THREADS", "1"))
    spec = importlib.util.spec_from_file_location(Path(rel).stem, REPO / rel)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _exit(monkeypatch: pytest.MonkeyPatch, rel: str, *args: str) -> int:
    module = _script(monkeypatch, rel)
    monkeypatch.setattr(sys, "argv", [rel, *args])
    try:
        return int(module.main() or 0)
    except SystemExit as e:
        return int(e.code or 0)


def test_bench_mpc_on_a_file_that_is_no_model_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    bad = tmp_path / "plm.json"
    bad.write_text('{"kind": "nope"}')
    assert _exit(monkeypatch, "benchmarks/bench_mpc.py", "--model", str(bad)) == 2
    err = capsys.readouterr()
    assert err.err.splitlines() == [f"bench_mpc: error: {bad}: not a msd-bench/model artifact"]
    assert err.out == ""


def test_bench_mpc_refuses_to_overwrite_its_out_file_before_any_work(tmp_path, monkeypatch, capsys):
    out = tmp_path / "bench_mpc.json"
    out.write_text("kept\n")
    assert _exit(monkeypatch, "benchmarks/bench_mpc.py", "--out", str(out)) == 2
    assert capsys.readouterr().err.splitlines() == [f"bench_mpc: error: {out} exists; not overwriting it"]
    assert out.read_text() == "kept\n"


def test_baselines_check_refuses_to_overwrite_its_out_file_before_any_work(tmp_path, monkeypatch, capsys):
    out = tmp_path / "baselines_design.json"
    out.write_text("kept\n")
    assert _exit(monkeypatch, "scripts/baselines_check.py", "--out", str(out)) == 2
    assert capsys.readouterr().err.splitlines() == [f"baselines_check: {out} exists; not overwriting it"]
    assert out.read_text() == "kept\n"


def test_make_results_stores_a_finished_run_with_the_commit_it_ran_at(monkeypatch: pytest.MonkeyPatch,
                                                                      tmp_path: Path) -> None:
    module = _script(monkeypatch, "scripts/make_results.py")
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text("{}")
    (run / "efficiency.json").write_text('{"methods": [], "seconds": {"total": 1.0}}')
    (run / "efficiency.png").write_bytes(b"png")
    monkeypatch.setattr(module, "RESULTS", tmp_path / "results")
    monkeypatch.setattr(sys, "argv", ["make_results.py", "rigs_efficiency_refine", "--from-run", str(run),
                                      "--ran-at", "abc1234"])
    assert module.main() == 2  # no completion marker: not a finished run, nothing stored
    assert not (tmp_path / "results").exists()
    (run / "complete").write_text("{}")
    assert module.main() == 0
    import json

    doc = json.loads((tmp_path / "results" / "rigs_efficiency_refine.json").read_text())
    assert doc["commit"] == "abc1234" and doc["efficiency"] == {"methods": [], "seconds": {"total": 1.0}}
    assert doc["command"].startswith("msd-bench efficiency --rigs 100") and "--refine 2" in doc["command"]
    assert (tmp_path / "results" / "rigs_efficiency_refine.png").read_bytes() == b"png"
    monkeypatch.setattr(sys, "argv", ["make_results.py", "rigs_efficiency", "table1_default", "--from-run",
                                      str(run), "--ran-at", "abc1234"])
    assert module.main() == 2  # one named command per stored run
