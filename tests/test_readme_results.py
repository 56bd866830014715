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


def _design_doc() -> dict[str, object]:
    """A small ``baselines_check.py --out`` document: two kinds, four scenarios, one lost run."""
    def c(k: int, n: int, mae: float, sse: float) -> dict[str, float]:
        return {"n": n, "n_success": k, "median_mae": mae, "median_sse": sse}
    cells = {"nominal": {"glm+pid": c(3, 3, 0.029, 0.1), "plm+lqr": c(3, 3, 0.012, 0.0)},
             "setpoint=1.5": {"glm+pid": c(3, 3, 0.040, 0.2), "plm+lqr": c(2, 3, 0.021, 0.3)},
             "setpoint=-1.5": {"glm+pid": c(3, 3, 0.041, 0.2), "plm+lqr": c(3, 3, 0.022, 0.1)},
             "disturbance=2@15": {"glm+pid": c(3, 3, 0.031, 1.95), "plm+lqr": c(3, 3, 0.013, 0.0)}}
    pid = {"design": "pid", "target_phase_margin": 60.0, "target_crossover": 4.0, "gain_margin": 5.4,
           "bandwidth": 6.4}
    return {"command": "scripts/baselines_check.py", "commit": "abc", "machine": {"cpu": "c", "cores": 2},
            "seconds": 9.0, "kinds": ["glm+pid", "plm+lqr"], "id_seeds": [90, 91], "draws": 4,
            "scenarios": list(cells), "cells": cells,
            "designs": {"glm+pid": [{**pid, "id_seed": 90, "phase_margin": 60.0, "crossover": 3.99},
                                    {**pid, "id_seed": 91, "phase_margin": 60.0, "crossover": 4.01,
                                     "gain_margin": -1.0}],
                        "plm+lqr": [{"design": "lqr", "id_seed": 90, "closed_loop_pole_radius": 0.99}]}}


def test_baselines_design_view_renders_cells_and_the_sentences_drawn_from_them():
    text = readme_results.view_baselines_design(_design_doc(), "baselines_design")
    rows = [ln for ln in text.splitlines() if ln.startswith("| `")]
    assert rows[0] == "| `nominal` | 3/3, 29 mm | 3/3, 12 mm |"
    assert rows[1] == "| `setpoint=-1.5` | 3/3, 41 mm | 3/3, 22 mm |"  # set-points sorted by value
    assert rows[2] == "| `setpoint=1.5` | 3/3, 40 mm | 2/3, 21 mm |"
    assert "per kind: `glm+pid` 9/9, `plm+lqr` 8/9." in text
    assert "Cells that lost a run: `plm+lqr` `setpoint=1.5` 2/3." in text
    assert "Median MAE at 1 m, lowest first: `plm+lqr` 12 mm, `glm+pid` 29 mm." in text
    assert "`glm+pid` 40–41 mm, `plm+lqr` 21–22 mm." in text
    assert "Largest median SSE of any cell: `glm+pid` under `disturbance=2@15`, 1.95 %." in text
    assert "phase margin 60.0° at crossover 3.99–4.01 rad/s (targets 60°, 4 rad/s)" in text
    assert "gain margin 5.40 (infinite on 1 of 2 seeds)" in text  # the -1 sentinel is no number
    assert "never reported as results" in text and "`docs/results/baselines_design.json`" in text


def test_bench_mpc_view_judges_each_clock_against_the_floor_and_names_the_load():
    doc = {"command": "benchmarks/bench_mpc.py", "commit": "abc", "machine": {"cpu": "c", "cores": 2},
           "seconds": 3.0, "model": "tests/data/pinned/plm.json", "blocks": [4, 12, 24, 60], "tail": 0,
           "steps": 9000, "setpoints": [1.0, -1.0, 1.5], "load1_at_start": 4.9, "threads": "1",
           "wall": {"mean_ms": 0.4, "p50_ms": 0.21, "p99_ms": 6.1, "max_ms": 14.8},
           "thread_cpu": {"mean_ms": 0.2, "p50_ms": 0.2, "p99_ms": 0.36, "max_ms": 0.55},
           "floor": {"mean_ms": 2.0, "p99_ms": 4.0}}
    text = readme_results.view_bench_mpc(doc, "bench_mpc")
    assert "| wall-clock | 0.40 | 0.21 | 6.10 | 14.80 | **no** |" in text
    assert "| thread CPU | 0.20 | 0.20 | 0.36 | 0.55 | yes |" in text
    assert "load average 4.90 on 2 cores at the start (loaded" in text
    assert "wall-clock 0.7×, thread CPU 11.1×" in text
    quiet = readme_results.view_bench_mpc({**doc, "load1_at_start": 0.3}, "bench_mpc")
    assert "(quiet)" in quiet


def test_a_drifted_number_in_a_docs_page_is_caught(tmp_path, monkeypatch):
    """The multi-page path: with no ``--readme``, every docs/*.md holding a block is checked and
    rewritten; a page without one and the README are left as they are."""
    (tmp_path / "docs" / "results").mkdir(parents=True)
    (tmp_path / "README.md").write_text("no blocks here\n")
    (tmp_path / "docs" / "plain.md").write_text("12 mm, typed\n")
    page = tmp_path / "docs" / "page.md"
    page.write_text("x\n<!-- results:demo:table -->\n| a | b |\n|---|---|\n| 1 | 9.99 |\n<!-- /results -->\n")
    (tmp_path / "docs" / "results" / "demo.json").write_text(json.dumps({
        "command": "demo", "commit": "abc", "machine": {"cpu": "c", "cores": 2}, "seconds": 1,
        "table": [{"a": 1, "b": 2.5}]}))
    monkeypatch.setattr(readme_results, "REPO", tmp_path)
    assert readme_results.documents(None) == [tmp_path / "README.md", page]
    assert readme_results.main(["--check"]) == 1
    assert readme_results.main([]) == 0
    assert "| 1 | 2.50 |" in page.read_text() and "9.99" not in page.read_text()
    assert readme_results.main(["--check"]) == 0
    assert (tmp_path / "README.md").read_text() == "no blocks here\n"
    assert (tmp_path / "docs" / "plain.md").read_text() == "12 mm, typed\n"


def test_fuzzlong_view_lists_each_property_and_the_runs_behind_the_counts():
    run = {"command": "MSD_FUZZ_PROFILE=long python -m pytest tests/fuzz/test_a.py",
           "commit": "abcdef0123456",
           "machine": {"cpu": "c", "cores": 2}, "loadavg_1min_before": 1.5, "wall_seconds": 12.0,
           "total_examples": 10_000,
           "tests": {"tests/fuzz/test_a.py::test_prop": {"outcome": "passed", "examples": 10_000},
                     "tests/fuzz/test_a.py::test_plain": {"outcome": "passed", "examples": None}}}
    one = readme_results.view_fuzzlong(run, "fuzz_a")
    assert "| `test_a.py::test_prop` | 10,000 | passed |" in one
    assert "test_plain" not in one  # a plain test draws no random cases
    assert "commit `abcdef0123`" in one and "load 1.5 at the start" in one
    merged = readme_results.view_fuzzlong({"runs": {"a": run, "b": {**run, "total_examples": 5}}}, "m")
    assert "10,005 random cases in all" in merged


def test_bench_executor_view_judges_the_speedup_and_scales_the_task_cost():
    doc = json.loads((REPO / "docs" / "results" / "bench_executor.json").read_text())
    text = readme_results.view_bench_executor(doc, "bench_executor")
    assert f"**{doc['speedup']:.2f}x** (floor 1.5x: holds)" in text
    slow = {**doc, "speedup": 1.1, "within_floor": False}
    assert "(floor 1.5x: does not hold)" in readme_results.view_bench_executor(slow, "bench_executor")
    med = doc["per_task"]["median_seconds"]
    per_rig = med["play"] + med["identify"] + 16 * (med["train"] + med["validate"])
    assert f"about {per_rig:.1f} s per rig" in text
    assert readme_results._sweep_hours(3.6, 1000, 1, 1.0) == "1.0 h"
    assert readme_results._sweep_hours(3.6, 1000, 4, 2.0) == "8 min"


def _rigs_doc(rates: dict[str, tuple[int, int]], wall: float | None) -> dict:
    kinds = [{"kind": k, "label": k, "n": n, "successes": s, "rate": s / n, "wilson95": [0.1, 0.9],
              "bootstrap95": [0.05, 0.95], "measured_successes": s} for k, (s, n) in rates.items()]
    rigs = [{"rig": 1000, "outcomes": [{"success": True}]}, {"rig": 1001, "outcomes": [{"success": False}]}]
    doc = {"kinds": kinds, "rigs": rigs, "rig_set": "held-out", "learning_seeds": [0, 1]}
    if wall is not None:
        doc["sweep"] = {"wall_seconds": wall, "rigs_computed": 2, "workers": 2, "executor": "local",
                        "cpus": 2}
    return doc


def test_rigs_floors_view_judges_each_floor_the_wall_time_and_names_the_dead_rigs():
    good = readme_results.view_rigs_floors(_rigs_doc(
        {"greybox": (19, 20), "plm+robust": (18, 20), "nlarx-improved+robust": (17, 20)}, 1700.0), "r")
    assert good.count("| yes |") == 3 and "floor 30 min: holds" in good
    assert "greybox | 95.0 % (19/20)" in good and "1001 (1 of 2)" in good
    bad = readme_results.view_rigs_floors(
        _rigs_doc({"greybox": (17, 20), "plm+robust": (16, 20)}, 1900.0), "r")
    assert bad.count("**no**") == 2 and "| not run |" in bad and "**does not hold**" in bad
    assert "Wall time" not in readme_results.view_rigs_floors(_rigs_doc({"plm+robust": (1, 2)}, None), "r")


def test_stage_floors_view_takes_the_best_learned_kind_never_a_baseline():
    """Issue 38: the best *learned* kind against 85 %, the robust NLARX against 80 %, two hours of wall."""
    doc = _rigs_doc({"glm+pid": (20, 20), "greybox+robust": (17, 20), "nlarx-improved+robust": (15, 20)},
                    7300.0)
    text = readme_results.view_stage_floors(doc, "r")
    assert "| the best learned kind | greybox+robust | 85.0 % (17/20)" in text and "glm+pid" not in text
    assert "| 75.0 % (15/20) |" in text and text.count("| yes |") == 1 and text.count("**no**") == 1
    assert "floor 120 min: **does not hold**" in text


def test_stage_stalls_view_counts_the_failed_runs_that_stopped_short():
    runs = [{"kind": "a", "identified": True, "success": False, "sse": 6.0, "po": 0.0},
            {"kind": "a", "identified": True, "success": False, "sse": 10.0, "po": 0.0},
            {"kind": "a", "identified": True, "success": False, "sse": 30.0, "po": 12.0},
            {"kind": "a", "identified": True, "success": True, "sse": 1.0, "po": 3.0},
            {"kind": "b", "identified": False, "success": False}]
    doc = {"agents": ["a", "b"], "kinds": [{"kind": "a", "label": "A"}, {"kind": "b", "label": "B"}],
           "rigs": [{"rig": 1000, "outcomes": runs, "design_failed": {"b": "no gains"}}],
           "rig_set": "held-out"}
    text = readme_results.view_stage_stalls(doc, "r")
    assert "| A | 3 of 4 | 2 | 8.0 % | 1 | 0 |" in text and "| B | 0 of 0 | 0 | – | 0 | 1 |" in text


def _worst(rig: int, units: bool) -> dict:
    params = {"mass": 1.0, "damping": 1.0, "spring": 1.0, "hardening": 1.0, "friction": 0.1, "delay": 2,
              "lag": 0.03, "noise": 0.001, "quant": 0.0}
    if units:
        params.update(length_unit=0.5, mass_unit=8.0, time_unit=2.0)
    return {"rig": rig, "successes": 3, "runs": 32, "parameters": params, "identification_failed": ["plm"]}


def test_rigs_worst_view_lists_the_worst_rigs_their_units_and_the_family_bar():
    doc = {**_rigs_doc({"greybox": (19, 20)}, 3 * 3600.0), "worst": [_worst(1064, True)],
           "population": {"family": "scaled"}}
    text = readme_results.view_rigs_worst(doc, "r")
    assert "| 1064 | 3 / 32 |" in text and "| plm |" in text
    assert "rig 1064 ×0.5, ×8, ×2" in text and "**does not hold**" in text and "`scaled` family" in text
    plain = readme_results.view_rigs_worst({**_rigs_doc({"greybox": (1, 2)}, 600.0),
                                            "worst": [_worst(1000, False)]}, "r")
    assert "units against" not in plain and "2 h; holds" in plain and "`default` family" in plain


def test_identification_speed_view_totals_and_judges_the_target():
    kinds = {k: {"median_seconds": t, "sim_fit": 97.0} for k, t in
             [("glm", 0.1), ("plm", 0.5), ("nlarx-improved", 2.0), ("greybox", 0.2), ("greybox-rig", 1.5)]}
    kinds["plm"]["bias_sim_fit"] = 99.5
    doc = {"new": {"kinds": kinds, "total_seconds": 4.3}, "old": {"kinds": kinds, "total_seconds": 12.9},
           "ratio_old_over_new": 3.0, "target_seconds": 5.0, "rig_kinds": ["plm", "nlarx-improved"],
           "rig_kinds_seconds": 2.5, "rig": None, "preset": "default", "seed": 0, "repeats": 3,
           "load_at_start": {"1min": 0.5}, "per_rig_seconds": 6.0, "command": "bench", "commit": "abc",
           "machine": {"cpu": "x", "cores": 2}, "seconds": 60}
    text = readme_results.view_identification_speed(doc, "idspeed")
    assert "| plm | 0.50 | 0.50 | 97.0000 (99.5000 on its bias records) | 97.0000 (99.5000) |" in text
    assert "target of 5 s is met" in text and "2.50 s (met)" in text
    doc["new"]["total_seconds"] = 6.2
    assert "target of 5 s is **not met**" in readme_results.view_identification_speed(doc, "idspeed")


def test_coverage_view_lists_every_tier_and_the_default_tiers_shortfall():
    tier = {"marker": "m", "exit": 0, "tests": 10, "failures": 1, "errors": 0, "skipped": 2}
    doc = {"command": "python scripts/coverage_tiers.py", "commit": "abc",
           "machine": {"cpu": "c", "cores": 2},
           "package": "msd_bench", "full": {"line_percent": 90.25, "statements": 1000, "missed": 97},
           "tiers": {"default": {**tier, "seconds": 600, "line_percent": 88.0},
                     "slow": {**tier, "seconds": 60, "line_percent": 40.0}}}
    text = readme_results.view_coverage(doc, "coverage")
    assert "| default | `m` | 10 (1, 2) | 10.0 min | 88.0 % |" in text
    assert "| **full suite** (every tier) | — | 20 | 11.0 min | 90.2 % |" in text
    assert "covers 88.0 %, 2.2 points below the full suite" in text and "97 never run" in text
