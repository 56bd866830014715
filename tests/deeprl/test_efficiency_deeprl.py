"""Deep RL on the data-efficiency curve: ``plant+dqn`` is an on-plant method at any budget."""

from __future__ import annotations

from msd_bench.app.config import RunConfig
from msd_bench.app.efficiency import EfficiencyConfig, crossings, efficiency, plant_tasks, surrogate_tasks

TINY = RunConfig(seeds=2, id_seeds=1, steps=200, validation_steps=400, window=100)


def test_plant_dqn_at_a_tiny_budget_is_a_point_charged_its_real_steps() -> None:
    cfg = EfficiencyConfig(TINY, surrogate_agents=(), plant_agents=("plant+dqn",), episodes=(1,))
    assert surrogate_tasks(cfg) == []  # no surrogate kind: no identification at all
    assert [t[0] for t in plant_tasks(cfg)] == ["plant-e1-plant_dqn"]
    doc = efficiency(cfg)
    (method,) = doc["methods"]
    (point,) = method["points"]
    assert method["name"] == "plant+dqn" and point["n"] == 2
    assert point["real_samples"] == 200  # one episode of 200 steps per agent, every one on the plant
    lo, hi = point["ci95"]
    assert 0.0 <= lo <= point["n_success"] / 2 <= hi <= 1.0


def test_a_deep_baseline_is_a_method_but_never_the_reference() -> None:
    pts = [{"real_samples": 1000, "n": 4, "n_success": 2, "ci95": [0.1, 0.9]}]
    methods = [{"name": "plant", "label": "Q", "points": pts},
               {"name": "plant+dqn", "label": "DQN", "points": pts}]
    lines = crossings(methods)
    assert lines[0].startswith("Q at 1,000 real steps") and sum("reached by" in ln for ln in lines) == 1
    assert "  DQN: 1,000 real samples" in lines
