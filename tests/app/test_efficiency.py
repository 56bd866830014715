"""The data-efficiency sweep on a tiny budget: bookkeeping that must hold at any size."""

from __future__ import annotations

import pytest

from msd_bench.app.config import RunConfig
from msd_bench.app.efficiency import EfficiencyConfig, crossings, efficiency, reaches, settle_for
from msd_bench.app.plan import paper_plan, real_samples
from msd_bench.core.errors import ConfigError

TINY = RunConfig(seeds=2, episodes=3, steps=300, dyna_episodes=2, planning_steps=2, validation_steps=400,
                 window=100, nlarx_scale=0.02)


def test_real_samples_count_training_records_settles_and_the_validation_record():
    plan = paper_plan(0, 1000, 1500, settle=200)
    assert real_samples(plan, "broad") == 1000 + 1500
    assert real_samples(plan, "bias") == 5 * (1000 + 200) + 1500


def test_sweep_points_and_intervals():
    cfg = EfficiencyConfig(TINY, surrogate_agents=("glm+improved",), plant_agents=("plant", "dyna-q"),
                           record_samples=(300, 900), episodes=(1, 2))
    doc = efficiency(cfg)
    by = {m["name"]: m["points"] for m in doc["methods"]}
    assert [p["real_samples"] for p in by["glm+improved"]] == [300 + 1000, 900 + 1000]
    assert [p["real_samples"] for p in by["plant"]] == [300, 600]  # per agent: episodes × steps
    for pts in by.values():
        for p in pts:
            assert p["n"] == 2 and 0 <= p["n_success"] <= 2
            assert 0.0 <= p["ci95"][0] <= p["n_success"] / p["n"] <= p["ci95"][1] <= 1.0
    assert any("reached by" in line for line in crossings(doc["methods"]))


def test_reaches_picks_the_fewest_samples_at_the_rate():
    pts = [{"real_samples": 10, "n": 4, "n_success": 1}, {"real_samples": 100, "n": 4, "n_success": 3},
           {"real_samples": 1000, "n": 4, "n_success": 4}]
    assert reaches(pts, 0.75) == 100 and reaches(pts, 1.0) == 1000 and reaches(pts, 0.0) == 10
    assert reaches(pts[:1], 0.5) is None


def test_settle_is_the_papers_for_paper_sized_records():
    assert settle_for(12_000) == 1_000 and settle_for(200) == 50


def test_route_kinds_are_checked():
    with pytest.raises(ConfigError):
        EfficiencyConfig(TINY, surrogate_agents=("plant",))
    with pytest.raises(ConfigError):
        EfficiencyConfig(TINY, plant_agents=("glm",))


def test_a_baseline_on_the_surrogate_route_counts_one_run_per_identified_model():
    """A deterministic design gives one run per model: n is the identification seeds, not copies."""
    from dataclasses import replace

    run = replace(TINY, id_seeds=2)
    cfg = EfficiencyConfig(run, surrogate_agents=("glm+pid", "glm+improved"), plant_agents=("plant",),
                           record_samples=(900,), episodes=(1,))
    by = {m["name"]: m["points"] for m in efficiency(cfg)["methods"]}
    assert by["glm+pid"][0]["n"] == 2 and by["glm+improved"][0]["n"] == 4
    assert by["glm+pid"][0]["real_samples"] == by["glm+improved"][0]["real_samples"]
