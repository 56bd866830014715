"""``msd-bench paper`` as a user runs it: a real process, a tiny budget, every file it writes.

One smoke run (CleanRL-style tiny budget) is shared by the module; the checks
read what the process left on disk and printed. Bad inputs each start their own
process and must end with exit status 2 and one line on stderr.
"""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg
import numpy as np
import pytest

pytestmark = pytest.mark.e2e

AGENTS = ("plant", "glm", "plm", "nlarx-paper", "dyna-q", "plm+improved")
"""Requested out of the default order, so the table's order is checked too."""
SEEDS, ID_SEEDS, SAMPLES = 3, 2, 2000
TINY = ["--seeds", str(SEEDS), "--id-seeds", str(ID_SEEDS), "--episodes", "20", "--dyna-episodes", "2",
        "--nlarx-scale", "0.05", "--samples", str(SAMPLES), "--val-samples", "800"]
SUMMARY_KEYS = {"mae", "std", "po", "ts", "ts5", "sse"}
STAT_KEYS = {"n", "n_defined", "mean", "sd", "median", "min", "max"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _paper(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "msd_bench.cli", "paper", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300, env=dict(os.environ))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One tiny run; its exit status is asserted by the first test, not here."""
    base = tmp_path_factory.mktemp("paper")
    proc = _paper(*TINY, "--agents", ",".join(AGENTS), "--out", str(base / "out"), cwd=base)
    return proc, base / "out"


@pytest.fixture(scope="module")
def table(run):
    proc, out = run
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads((out / "table1.json").read_text())


def _expected_n(kind: str) -> int:
    """Surrogate kinds run per identification seed; on-plant learners once."""
    return SEEDS if kind in ("plant", "dyna-q") else SEEDS * ID_SEEDS


def test_exits_zero_without_a_traceback(run):
    proc, out = run
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    assert f"report: {out.resolve()}" in proc.stderr


def test_json_schema_and_one_object_per_requested_kind(table):
    assert table["schema"] == "msd-bench/table1"
    assert table["schema_version"] == 1
    assert [a["kind"] for a in table["agents"]] == list(AGENTS)
    assert table["run"]["seeds"] == SEEDS and table["run"]["mode"] == "in-process"
    assert table["run"]["agents"] == list(AGENTS)


def test_json_per_seed_and_summary(table):
    for a in table["agents"]:
        n = _expected_n(a["kind"])
        assert a["n"] == n and len(a["per_seed"]) == n
        assert set(a["summary"]) == SUMMARY_KEYS
        for key, stats in a["summary"].items():
            assert set(stats) == STAT_KEYS, key
            assert stats["n"] == n and 0 <= stats["n_defined"] <= n
            values = [s[key] for s in a["per_seed"] if s[key] is not None and math.isfinite(s[key])]
            assert stats["n_defined"] == len(values)
            if values:
                assert stats["min"] == min(values) and stats["max"] == max(values)
                assert stats["median"] == pytest.approx(float(np.median(values)))
                assert stats["mean"] == pytest.approx(float(np.mean(values)))
        sse = [s["sse"] for s in a["per_seed"]]
        assert a["n_success"] == sum(v < 5.0 for v in sse)
        assert a["success_rate"] == pytest.approx(a["n_success"] / n)


def test_json_identification_facts(table):
    rows = {a["kind"]: a for a in table["agents"]}
    assert rows["plm"]["identification_samples"] == 5 * SAMPLES
    assert rows["glm"]["identification_samples"] == SAMPLES
    for kind in ("plant", "dyna-q"):
        assert rows[kind]["fit_sim_percent"] is None and rows[kind]["identification_samples"] == 0
    assert len(rows["glm"]["fit_by_id_seed"]) == ID_SEEDS
    assert "reduced budget" in rows["dyna-q"]["notes"]


def test_csv_has_one_row_per_kind_and_seed_with_the_json_sse(run, table):
    _, out = run
    with (out / "table1.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == sum(_expected_n(k) for k in AGENTS)
    keys = [(r["kind"], int(r["id_seed"]), int(r["seed"])) for r in rows]
    assert len(set(keys)) == len(keys)
    by_key = {k: r for k, r in zip(keys, rows, strict=True)}
    for a in table["agents"]:
        for s in a["per_seed"]:
            row = by_key[(a["kind"], s["id_seed"], s["seed"])]
            assert float(row["sse"]) == s["sse"]
            assert row["success"] == str(int(s["success"]))


def test_markdown_table_is_printed_on_stdout(run, table):
    proc, out = run
    md = (out / "table1.md").read_text()
    assert md.strip() in proc.stdout
    for a in table["agents"]:
        assert f"| {a['label']} |" in proc.stdout
        assert f"{a['n_success']}/{a['n']}" in proc.stdout


def test_figures_are_readable_pngs(run):
    _, out = run
    names = {"step_responses.png", "fit_plm.png", "fit_glm.png", "fit_nlarx-paper.png",
             *(f"qtable_{k}.png" for k in AGENTS)}
    found = {p.name for p in (out / "figures").glob("*.png")}
    assert names <= found
    for name in sorted(names):
        path = out / "figures" / name
        assert path.read_bytes()[:8] == PNG_MAGIC, name
        img = mpimg.imread(path)
        assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100, name
        assert float(np.ptp(img[..., :3])) > 0, f"{name} is blank"


def test_models_and_qtables_are_written(run, table):
    _, out = run
    for i in range(ID_SEEDS):
        for name in ("glm", "plm", "nlarx-paper"):
            doc = json.loads((out / "models" / f"id{i}" / f"{name}.json").read_text())
            assert doc  # a non-empty artifact
    for a in table["agents"]:
        tables = 0
        made = sorted((out / "policies" / a["kind"]).iterdir())  # one artifact per model it was made on
        assert len(made) == (1 if a["kind"] in ("plant", "dyna-q") else ID_SEEDS)
        for d in made:
            assert json.loads((d / "policy.json").read_text())["kind"] == a["kind"]
            with np.load(d / "qtables.npz") as npz:
                tables += npz["q"].shape[0]
        assert tables == a["n"]


def _assert_one_line_error(proc: subprocess.CompletedProcess[str], *fragments: str) -> str:
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("msd-bench paper: error: ")
    for f in fragments:
        assert f in lines[0]
    return lines[0]


def test_unknown_agent_kind_is_one_line(tmp_path):
    proc = _paper("--agents", "glm,plm-turbo", "--out", str(tmp_path / "o"), cwd=tmp_path)
    _assert_one_line_error(proc, "'plm-turbo'", "nlarx-improved+improved")
    assert not (tmp_path / "o").exists()


def test_unknown_preset_is_one_line(tmp_path):
    proc = _paper("--preset", "stiff", "--out", str(tmp_path / "o"), cwd=tmp_path)
    _assert_one_line_error(proc, "'stiff'", "mild")


def test_zero_seeds_is_one_line(tmp_path):
    proc = _paper("--seeds", "0", "--out", str(tmp_path / "o"), cwd=tmp_path)
    _assert_one_line_error(proc, "seeds must be >= 1")


def test_existing_table_is_not_overwritten(run, table):
    _, out = run
    before = (out / "table1.json").read_bytes()
    proc = _paper(*TINY, "--agents", "plant", "--out", str(out), cwd=out.parent)
    _assert_one_line_error(proc, "already holds a complete paper run")
    assert (out / "table1.json").read_bytes() == before


def test_repeated_agent_kind_is_one_line(tmp_path):
    proc = _paper("--agents", "plant,plant", "--out", str(tmp_path / "o"), cwd=tmp_path)
    _assert_one_line_error(proc, "once each", "'plant', 'plant'")


def test_out_that_is_a_file_is_refused_before_running(tmp_path):
    target = tmp_path / "a-file"
    target.write_text("keep me")
    proc = _paper(*TINY, "--agents", "plant", "--out", str(target), cwd=tmp_path)
    _assert_one_line_error(proc, "is a file")
    assert target.read_text() == "keep me"


def test_robustness_is_written_and_printed(run, table):
    proc, out = run
    doc = json.loads((out / "robustness.json").read_text())
    assert (doc["schema"], doc["schema_version"]) == ("msd-bench/robustness", 2)
    assert doc["scenarios"][:3] == ["nominal", "setpoint=-1.5", "setpoint=-0.5"]
    assert len(doc["scenarios"]) == 14
    cells = {a["kind"]: a["cells"] for a in doc["agents"]}
    assert set(cells) == {a["kind"] for a in table["agents"]}
    for a in table["agents"]:
        nominal = cells[a["kind"]]["nominal"]
        assert nominal["sse"] == [s["sse"] for s in a["per_seed"]]  # nominal is the validation itself
        lo, hi = nominal["ci95"]
        assert lo <= nominal["n_success"] / nominal["n"] <= hi
    assert "Robustness" in proc.stdout and "`noise=0.005`" in proc.stdout
