"""``scripts/deeprl_runs.py`` from outside: a tiny real run, and every usage mistake one line, exit 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from msd_bench.core.evaluation.scenarios import suite
from msd_bench.io.storage.deeprl_artifact import load_policy

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "deeprl_runs.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, env=env,
                          cwd=REPO, timeout=600)


def test_a_tiny_run_writes_its_seeds_budget_cells_and_artifact(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    res = _run("run", "--kinds", "plant+dqn", "--seeds", "3", "--steps", "64", "--out", str(out),
               "--artifacts", str(tmp_path))
    assert res.returncode == 0, res.stderr
    doc = json.loads(out.read_text())
    row = doc["kinds"]["plant+dqn"]
    assert doc["seeds"] == [3] and doc["steps"] == 64 and doc["command"].startswith("scripts/deeprl_runs.py")
    assert row["real_interactions"] == 64 and row["id_seed"] is None
    assert len(row["cells"]) == len(suite()) and row["nominal"]["n"] == 1
    net, meta = load_policy(tmp_path / "plant_dqn")
    assert meta["seeds"] == [3] and meta["stable_baselines3"] == "2.9.0" and net.w1.shape[0] == 1
    again = tmp_path / "v.json"
    res = _run("validate", "--policy", str(tmp_path / "plant_dqn"), "--out", str(again))
    assert res.returncode == 0, res.stderr
    assert json.loads(again.read_text())["cells"] == row["cells"]  # the artifact is the policy that ran


@pytest.mark.parametrize(("args", "message"), [
    (["run", "--kinds", "plant+sac"], "must be <plant|model>+<dqn|ppo>"),
    (["run", "--kinds", "nosuch+dqn"], "nosuch"),
    (["run", "--kinds", "plant+dqn", "--seeds", "95000"], "design seeds"),
    (["tune", "--algos", "a2c"], "unknown algorithm 'a2c'"),
    (["tune", "--seeds", "0"], "design seeds only"),
])
def test_a_usage_mistake_is_one_line_and_exit_2(tmp_path: Path, args: list[str], message: str) -> None:
    res = _run(*args, "--out", str(tmp_path / "o.json"))
    assert res.returncode == 2
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o.json").exists()


def test_an_existing_out_is_refused_before_any_work_and_left_intact(tmp_path: Path) -> None:
    out = tmp_path / "o.json"
    out.write_text("mine")
    res = _run("run", "--kinds", "plant+dqn", "--out", str(out))
    assert res.returncode == 2 and "exists; not overwriting it" in res.stderr
    assert out.read_text() == "mine"


def test_a_tune_document_without_the_chosen_entry_is_one_line(tmp_path: Path) -> None:
    tune = tmp_path / "tune.json"
    tune.write_text(json.dumps({"algos": {"ppo": {"chosen": {"algo": "ppo", "learning_rate": 3e-4}}}}))
    res = _run("run", "--kinds", "plant+dqn", "--hyper-from", str(tune), "--out", str(tmp_path / "o.json"))
    assert res.returncode == 2 and "no chosen hyper-parameters for dqn" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_a_symlink_as_out_is_refused(tmp_path: Path) -> None:
    target = tmp_path / "elsewhere.json"
    (tmp_path / "o.json").symlink_to(target)
    res = _run("run", "--kinds", "plant+dqn", "--out", str(tmp_path / "o.json"))
    assert res.returncode == 2 and "exists; not overwriting it" in res.stderr
    assert not target.exists()


def _doc(kinds: dict[str, dict[str, object]], steps: int, seeds: list[int]) -> dict[str, object]:
    return {"command": "scripts/deeprl_runs.py run", "commit": "abc", "machine": {}, "seeds": seeds,
            "steps": steps, "kinds": kinds}


def _row(n_success: int, n: int, real: int, **extra: object) -> dict[str, object]:
    return {"nominal": {"n": n, "n_success": n_success, "median_sse": 1.25}, "real_interactions": real,
            "setpoints_held": 5, **extra}


def test_table_collects_the_runs_in_table1_columns_and_draws_the_plant_points(tmp_path: Path) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(_doc({"plant+dqn": _row(1, 2, 2000, id_seed=None)}, 1000, [0, 1])))
    b.write_text(json.dumps(_doc({"plant+dqn": _row(2, 2, 20000, id_seed=None),
                                  "plm+ppo": _row(0, 2, 0, id_seed=0, identification_samples=600,
                                                  fit_sim_percent=91.5)}, 10000, [0, 1])))
    curve = tmp_path / "eff.json"
    curve.write_text(json.dumps({"efficiency": {"methods": [
        {"name": "plant", "label": "Q", "points": [{"real_samples": 300, "n": 2, "n_success": 1,
                                                    "ci95": [0.1, 0.9]}]}]}}))
    out, fig = tmp_path / "t.json", tmp_path / "f.png"
    res = _run("table", "--runs", f"{a},{b}", "--efficiency", str(curve), "--figure", str(fig),
               "--out", str(out))
    assert res.returncode == 0, res.stderr
    doc = json.loads(out.read_text())
    rows = {(r["file"], r["kind"]): r for r in doc["rows"]}
    plm = rows[("b.json", "plm+ppo")]
    assert plm["identification_samples"] == 600 and plm["fit_sim_percent"] == 91.5
    assert plm["fit_from"] == "run"
    assert plm["real_interactions"] == 0 and plm["baseline"] and plm["steps_per_seed"] == 10000
    (method,) = doc["efficiency_methods"]  # the surrogate kind spent no real sample: no point
    assert method["name"] == "plant+dqn" and method["seeds"] == [0, 1]
    assert [(p["real_samples"], p["n_success"]) for p in method["points"]] == [(1000, 1), (10000, 2)]
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_table_counts_the_steps_a_run_before_the_budget_cap_really_took(tmp_path: Path) -> None:
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    ppo = {"algo": "ppo", "extra": {}}
    old.write_text(json.dumps(_doc({"plant+ppo": _row(1, 1, 3000, hyper=ppo)}, 3000, [0])))
    capped = _row(1, 1, 3000, hyper=ppo, steps_taken=[3000])
    new.write_text(json.dumps(_doc({"plant+ppo": capped}, 3000, [0])))
    out = tmp_path / "t.json"
    res = _run("table", "--runs", f"{old},{new}", "--out", str(out))
    assert res.returncode == 0, res.stderr
    rows = json.loads(out.read_text())["rows"]
    assert [(r["real_interactions"], r["real_taken"]) for r in rows] == [(3000, 4096), (3000, 3000)]


@pytest.mark.parametrize(("text", "message"), [
    ("[1, 2]", "not a deeprl_runs.py run document"),
    (json.dumps(_doc({"plant+dqn": {"real_interactions": 5}}, 10, [0])), "lacks its nominal cell"),
    (json.dumps(_doc({"plant+dqn": _row(3, 2, 5)}, 10, [0])), "lacks its nominal cell"),
    (json.dumps(_doc({"plant+sac": _row(1, 1, 5)}, 10, [0])), "must be <plant|model>+<dqn|ppo>"),
    (json.dumps(_doc({"plant+dqn": _row(1, 1, 5)}, 0, [0])), "positive steps"),
    ("{" * 5000, "JSON"),
])
def test_table_refuses_a_bad_run_document_in_one_line(tmp_path: Path, text: str, message: str) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(text)
    res = _run("table", "--runs", str(bad), "--out", str(tmp_path / "t.json"))
    assert res.returncode == 2 and message in res.stderr, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and not (tmp_path / "t.json").exists()


def test_table_never_draws_over_an_existing_figure(tmp_path: Path) -> None:
    a = tmp_path / "a.json"
    a.write_text(json.dumps(_doc({"plant+dqn": _row(1, 1, 5)}, 5, [0])))
    fig = tmp_path / "f.png"
    fig.write_text("mine")
    res = _run("table", "--runs", str(a), "--figure", str(fig), "--out", str(tmp_path / "t.json"))
    assert res.returncode == 2 and "exists; not overwriting it" in res.stderr
    assert fig.read_text() == "mine" and not (tmp_path / "t.json").exists()
