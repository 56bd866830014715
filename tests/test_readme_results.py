"""Every number in the README is generated: the README agrees with docs/results, and drift is caught."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

import readme_results  # noqa: E402


def test_readme_agrees_with_the_stored_results():
    assert readme_results.main(["--check"]) == 0


def test_a_drifted_number_is_caught(tmp_path):
    results = tmp_path / "results"
    shutil.copytree(REPO / "docs" / "results", results)
    readme = tmp_path / "README.md"
    readme.write_text(
        "x\n<!-- results:demo:table -->\nstale\n<!-- /results -->\ny\n")
    (results / "demo.json").write_text(json.dumps({
        "command": "demo", "commit": "abc", "machine": {"cpu": "c", "cores": 2}, "seconds": 1,
        "table": [{"a": 1, "b": 2.5}]}))
    args = ["--readme", str(readme), "--results", str(results)]
    assert readme_results.main([*args, "--check"]) == 1
    assert readme_results.main(args) == 0
    assert "| 1 | 2.50 |" in readme.read_text()
    assert readme_results.main([*args, "--check"]) == 0


def test_performance_view_marks_each_floor_and_what_was_not_measured():
    doc = {"commands": ["python benchmarks/bench_lockstep.py"], "commit": "abc",
           "machine": {"cpu": "c", "cores": 2}, "loadavg_1min_before": 0.3,
           "benchmarks": {"bench_lockstep": {"lockstep_over_pingpong": 0.85},
                          "bench_bench": {"seconds": 120.0, "bench_over_inprocess": 3.0}}}
    rows = {ln.split(" | ")[0].lstrip("| "): ln for ln in
            readme_results.view_performance(doc, "performance").splitlines() if ln.startswith("| ")}
    assert rows["lock-step steps over bare rclpy ping-pong"].endswith("| 0.85 | >= 0.8 | yes |")
    assert rows["`bench.py` default run, seconds"].endswith("| 120.00 | <= 90 | **no** |")
    assert rows["`bench.py` over the same kinds in-process"].endswith("| yes |")
    assert "not measured" in rows["batched training, agent-steps/s"]


def _cell(k: int, n: int) -> dict[str, int]:
    return {"n": n, "n_success": k}


def test_robust_floors_view_judges_counts_and_the_interval_rule():
    """Count floors at their n (180 of 192 nominal: 179 fails), the interval rule elsewhere."""
    robust = {"nominal": _cell(179, 192), "delay=1": _cell(173, 192), "disturbance=-2@15": _cell(150, 192),
              "setpoint=1.5": _cell(170, 192)}
    improved = {"nominal": _cell(185, 192), "delay=1": _cell(183, 192),
                "disturbance=-2@15": _cell(175, 192), "setpoint=1.5": _cell(175, 192)}
    doc = {"command": "c", "commit": "abc", "machine": {"cpu": "c", "cores": 2}, "seconds": 1,
           "robustness": {"scenarios": list(robust), "agents": [
               {"kind": "plm+improved", "cells": improved}, {"kind": "plm+robust", "cells": robust}]}}
    rows = {ln.split(" | ")[1].strip("`"): ln for ln in
            readme_results.view_robust_floors(doc, "x").splitlines() if ln.startswith("| `plm+robust`")}
    assert rows["nominal"].endswith("| ≥ 180/192 | **no** |")
    assert rows["delay=1"].endswith("| ≥ 173/192 | yes |")
    assert rows["disturbance=-2@15"].endswith("| **no** |")  # 72-83 % against 85-94 %
    assert rows["setpoint=1.5"].endswith("| yes |")  # 83-92 % overlaps 86-94 %
