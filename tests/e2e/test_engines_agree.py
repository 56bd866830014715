"""Both engines, one table: ``msd-bench paper`` and bench.py give the same rows for the same kinds.

The baselines and a Q-learner run in-process and as node processes over DDS
(lock-step); every validation metric, every robustness cell and every count of
real interactions must agree exactly, because both engines hand the same
trained-policy records to one assembly (:func:`msd_bench.app.scoring.assemble`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e
REPO = Path(__file__).resolve().parents[2]
KINDS = "glm+pid,glm+pid-continuous,greybox+lqr,greybox+mpc,glm+improved,plant"
"""No PLM: bench.py then records only the two broad bags (the PLM+MPC parity is tests/nodes/)."""
BUDGET = ["--seeds", "2", "--episodes", "3", "--steps", "200", "--samples", "600", "--val-samples", "400",
          "--validation-steps", "400", "--agents", KINDS]


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The two run directories: in-process, and bench.py's."""
    root = tmp_path_factory.mktemp("engines")
    paper = [sys.executable, "-m", "msd_bench.cli", "paper", "--no-figures", *BUDGET,
             "--out", str(root / "p")]
    bench = [sys.executable, "launch_scripts/bench.py", *BUDGET, "--out", str(root / "b"),
             "--domain-id", os.environ["ROS_DOMAIN_ID"]]
    procs = [subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for argv in (paper, bench)]  # at once: bench.py waits on discovery and processes meanwhile
    for proc in procs:
        out, err = proc.communicate(timeout=900)
        assert proc.returncode == 0, err[-3000:]
        assert "Traceback" not in err and "GLM (PID baseline)" in out
    return root / "p", root / "b" / "report"


def _doc(runs: tuple[Path, Path], name: str) -> tuple[dict, dict]:
    return tuple(json.loads((d / name).read_text()) for d in runs)  # type: ignore[return-value]


def _rows(doc: dict) -> dict[str, dict]:
    return {a["kind"]: a for a in doc["agents"]}


def test_every_row_agrees_bit_for_bit(runs):
    paper, bench = (_rows(t) for t in _doc(runs, "table1.json"))
    assert list(paper) == list(bench) == KINDS.split(",")
    for kind, row in paper.items():
        assert row["per_seed"] == bench[kind]["per_seed"], kind
        assert row["real_interactions"] == bench[kind]["real_interactions"], kind
        assert row["label"] == bench[kind]["label"]
    assert paper["plant"]["real_interactions"] == 2 * 3 * 200  # what it really spent on the plant
    assert len(paper["glm+pid"]["per_seed"]) == 1  # deterministic: one run per identified model


def test_robustness_agrees_bit_for_bit(runs):
    paper, bench = _doc(runs, "robustness.json")
    assert paper["agents"] == bench["agents"]


def test_both_engines_write_the_same_trained_policy_artifact(runs):
    """The paper run's ``policies/<kind>/id0/`` and bench.py's ``agents/<kind>/`` hold the same policy."""
    import numpy as np

    paper, report = runs
    for kind in KINDS.split(","):
        a_dir, b_dir = paper / "policies" / kind / "id0", report.parent / "agents" / kind
        a, b = (json.loads((d / "policy.json").read_text()) for d in (a_dir, b_dir))
        assert {k: a[k] for k in ("schema", "kind", "design", "facts", "members", "files", "body")} == {
            k: b[k] for k in ("schema", "kind", "design", "facts", "members", "files", "body")}, kind
        if "tables" in a["files"]:
            with np.load(a_dir / "qtables.npz") as x, np.load(b_dir / "qtables.npz") as y:
                assert all(np.array_equal(x[k], y[k]) for k in ("q", "first", "last")), kind
