"""``scripts/deeprl_table1.py``: the saved deep-RL networks as Table 1 rows through the one assembly."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import train_and_validate, validate_policy
from msd_bench.core.evaluation.scenarios import suite
from msd_bench.core.physics.model import plant_model

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "deeprl_table1.py"
sys.path.insert(0, str(REPO / "scripts"))

import deeprl_table1  # noqa: E402


def test_the_deep_rows_agree_with_the_runs_own_scorer_and_carry_every_scenario() -> None:
    results, cells = deeprl_table1.build(RunConfig(seeds=1))
    rows = {r.kind: r for r in results}
    assert list(rows) == [*deeprl_table1.SAVED, *deeprl_table1.LEARNERS]
    own = {r["kind"]: r for r in json.loads((REPO / "docs/results/deeprl_table.json").read_text())["rows"]
           if r["steps_per_seed"] == deeprl_table1.PAPER_STEPS}
    for kind in deeprl_table1.SAVED:
        assert (rows[kind].n, rows[kind].n_success) == (own[kind]["n"], own[kind]["n_success"]), kind
        assert rows[kind].real_interactions == own[kind]["real_taken"], kind
        assert set(cells[kind]) == {s.id for s in suite(())}, kind
    assert "the plant gave 901,120 steps" in rows["plant+ppo"].notes
    assert rows["greybox+dqn"].real_interactions == 0 and rows["greybox+dqn"].fit_sim is not None


def test_a_loaded_policy_is_validated_as_a_made_one() -> None:
    cfg = RunConfig(seeds=1, validation_steps=1500, window=500)
    made = train_and_validate("plant", plant_model(cfg.plant), cfg, [0], 0)
    again = validate_policy(made.policy, cfg, [0], 0)
    assert (again.x == made.x).all() and again.metrics == made.metrics


def test_an_existing_out_is_refused_in_one_line_and_left_alone(tmp_path: Path) -> None:
    out = tmp_path / "t.json"
    out.write_text("mine")
    res = subprocess.run([sys.executable, str(SCRIPT), "--out", str(out)], capture_output=True, text=True,
                         cwd=REPO, timeout=300)
    assert res.returncode == 2 and "exists" in res.stderr.strip().splitlines()[-1]
    assert out.read_text() == "mine"
