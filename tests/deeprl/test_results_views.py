"""The deep-RL views of ``scripts/readme_results.py``: Table 1's columns and the efficiency points."""

from __future__ import annotations

import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))

import readme_results  # noqa: E402


def _doc() -> dict[str, object]:
    rows = [
        {"file": "a.json", "kind": "plant+ppo", "label": "on the true plant (PPO baseline)", "baseline": True,
         "steps_per_seed": 900_000, "seeds": [0, 1], "id_seed": None, "identification_samples": 0,
         "fit_sim_percent": None, "fit_from": "run", "real_interactions": 1_800_000, "n": 2, "n_success": 1,
         "ci95": [0.0, 1.0], "median_sse": 0.5, "setpoints_held": 5},
        {"file": "b.json", "kind": "greybox+dqn", "label": "Grey-box (DQN baseline)", "baseline": True,
         "steps_per_seed": 90_000, "seeds": [0], "id_seed": 0, "identification_samples": 12000,
         "fit_sim_percent": 99.99, "fit_from": "recomputed", "real_interactions": 0, "n": 1, "n_success": 0,
         "ci95": [0.0, 0.79], "median_sse": 5.1, "setpoints_held": 0},
    ]
    methods = [{"name": "plant+ppo", "label": "on the true plant (PPO baseline), seed(s) 0, 1",
                "seeds": [0, 1],
                "points": [{"real_samples": 900_000, "n": 2, "n_success": 1, "ci95": [0.09, 0.91]}]}]
    return {"command": "scripts/deeprl_runs.py table", "commit": "0123456789ab", "machine": {}, "seconds": 1,
            "rows": rows, "efficiency_methods": methods,
            "figure": {"path": "docs/results/efficiency_deeprl.png",
                       "curves_from": "docs/results/efficiency.json"}}


def test_the_table_view_states_budget_seeds_interval_and_a_recomputed_fit() -> None:
    text = readme_results.view_deeprl(_doc(), "deeprl_table")
    rows = [ln for ln in text.splitlines() if ln.startswith("| ") and not ln.startswith("| Agent")]
    assert rows[0] == ("| on the true plant (PPO baseline) | 900,000 | 0, 1 | — | — | 1,800,000 | "
                       "1/2 (50 %; 9–91 %) | 0.5 |")
    assert rows[1].startswith("| Grey-box (DQN baseline) | 90,000 | 0 | 100.0* | 12000 | 0 | "
                              "0/1 (0 %; 0–79 %)")
    assert "recomputed" in text and "Baselines" in text and "`docs/results/deeprl_table.json`" in text


def test_a_row_whose_plant_gave_more_than_it_charged_says_both() -> None:
    doc = _doc()
    doc["rows"][0]["real_taken"] = 1_802_240  # type: ignore[index]
    text = readme_results.view_deeprl(doc, "deeprl_table")
    assert "| 1,802,240 (charged 1,800,000) † |" in text and "\n\n† run written before" in text


def test_the_efficiency_view_lists_each_point_and_names_the_figure() -> None:
    text = readme_results.view_deeprl_efficiency(_doc(), "deeprl_table")
    assert "| on the true plant (PPO baseline), seed(s) 0, 1 | 900,000 → 1/2 (9–91 %) |" in text
    assert "`efficiency_deeprl.png`" in text and "`efficiency.json`" in text


def test_the_committed_table_renders_every_run_it_collected() -> None:
    doc = json.loads((REPO / "docs" / "results" / "deeprl_table.json").read_text())
    text = readme_results.view_deeprl(doc, "deeprl_table")
    assert sum(ln.startswith("| ") for ln in text.splitlines()) == 1 + len(doc["rows"])  # header, rows
    assert {"plant+dqn", "plant+ppo"} <= {m["name"] for m in doc["efficiency_methods"]}
