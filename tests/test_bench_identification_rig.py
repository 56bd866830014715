"""benchmarks/bench_identification_rig.py through its command line: a results file that exists,
or an --out without a directory, is one line and exit 2 before any work, and the file is intact."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCRIPT = "benchmarks/bench_identification_rig.py"


def _exit(monkeypatch: pytest.MonkeyPatch, *args: str) -> int:
    """Run the script's ``main`` in-process; its import-time ``OMP_NUM_THREADS`` default is undone."""
    monkeypatch.setenv("OMP_NUM_THREADS", os.environ.get("OMP_NUM_THREADS", "1"))
    spec = importlib.util.spec_from_file_location("bench_identification_rig", REPO / SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(sys, "argv", [SCRIPT, *args])
    try:
        module.main()
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def test_an_existing_out_is_refused_before_any_work_and_left_intact(tmp_path, monkeypatch, capsys):
    out = tmp_path / "speed.json"
    out.write_text("what an earlier run wrote\n")
    assert _exit(monkeypatch, "--out", str(out)) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"bench_identification_rig: error: {out} exists; not overwriting it"
    assert out.read_text() == "what an earlier run wrote\n"


def test_an_out_in_a_missing_directory_is_one_line(tmp_path, monkeypatch, capsys):
    out = tmp_path / "nowhere" / "speed.json"
    assert _exit(monkeypatch, "--out", str(out)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not exist" in err[0]


def test_zero_repeats_is_one_line(monkeypatch, capsys):
    assert _exit(monkeypatch, "--repeats", "0") == 2
    assert capsys.readouterr().err.strip() == "bench_identification_rig: error: --repeats must be >= 1, got 0"


def test_a_rig_outside_the_population_is_one_line(monkeypatch, capsys):
    assert _exit(monkeypatch, "--rig", "-3") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--rig must be a population seed" in err[0]
