"""``dqn`` and ``ppo`` as registry entries: a row of ``msd-bench paper``, an artifact, opt-in kinds.

Tiny budgets (a few hundred environment steps): these tests check the plumbing
and the bit-for-bit agreement of the forms, not what the networks learn.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import run_paper, settings
from msd_bench.core.deeprl.hyper import CHOSEN, from_dict
from msd_bench.core.evaluation.closed_loop import nominal
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.storage.artifacts import ArtifactError

REPO = Path(__file__).resolve().parents[2]
TINY = RunConfig(seeds=2, id_seeds=1, episodes=1, dyna_episodes=1, steps=200, samples=600, val_samples=400,
                 validation_steps=400, window=100, agents=("plant+dqn",))


def test_the_designs_train_with_the_entries_the_design_grid_chose() -> None:
    doc = json.loads((REPO / "docs" / "results" / "deeprl_tune.json").read_text())
    for algo, entry in doc["algos"].items():
        assert from_dict(entry["chosen"]) == CHOSEN[algo]


def test_the_kinds_are_opt_in_baselines_over_every_surrogate_and_the_plant() -> None:
    from msd_bench.app.agents import DEFAULT_AGENTS

    kinds = designs.AGENT_KINDS
    for algo in ("dqn", "ppo"):
        assert {"plant+" + algo, "greybox+" + algo, "plm+" + algo} <= set(kinds)
        assert kinds["plant+" + algo].on_plant and kinds["greybox+" + algo].design.baseline
        assert kinds["plant+" + algo].design.model_free and not kinds["greybox+" + algo].design.model_free
    assert not any(k.endswith(("+dqn", "+ppo")) for k in DEFAULT_AGENTS)


def test_plant_dqn_is_a_row_of_run_paper_charged_its_real_samples() -> None:
    run = run_paper(TINY)
    (row,) = run.results
    assert row.kind == "plant+dqn" and row.n == 2
    assert row.real_interactions == 2 * 1 * 200  # seeds x plant episodes x steps, every one on the plant
    policy = run.policies["plant+dqn"][TINY.id_first_seed]
    x, _ = designs.nominal_runs(policy, TINY.plant, TINY.target, TINY.validation_steps)
    assert np.array_equal(x, run.responses["plant+dqn"])


def test_a_surrogate_kind_spends_no_real_sample_and_rolls_out_as_its_controller(tmp_path: Path) -> None:
    model = plant_model(PlantParams())  # any StepModel stands in for the surrogate here
    policy = designs.make("greybox+dqn", model, replace(settings(TINY), episodes=1, steps=300), [4, 5])
    assert policy.facts.real_interactions == 0 and policy.members == (4, 5)
    noise = np.random.default_rng(0).normal(0.0, 0.002, (2, 300))
    xs, us = policy.rollout(model.kernel, nominal(-0.5), noise)
    for j in range(2):
        ctl = policy.controller(j, -0.5)
        ctl.reset()
        assert np.array_equal([ctl.act(xs[j, k] + noise[j, k]) for k in range(300)], us[j])


def test_a_policy_saves_and_loads_back_without_retraining(tmp_path: Path) -> None:
    model = plant_model(PlantParams())
    policy = designs.make("plant+dqn", model, replace(settings(TINY), episodes=1, steps=300), [7])
    written = designs.save(policy, tmp_path, {"test": True}, root=tmp_path)
    assert {p.name for p in written} == {"policy.json", "deeprl.json", "deeprl.npz"}
    back = designs.load(tmp_path, model)
    assert back.members == (7,) and back.facts == policy.facts
    noise = np.zeros((1, 400))
    assert np.array_equal(back.rollout(model.kernel, nominal(1.0), noise)[1],
                          policy.rollout(model.kernel, nominal(1.0), noise)[1])
    doc = json.loads((tmp_path / "policy.json").read_text())
    doc["members"] = [8]
    (tmp_path / "policy.json").write_text(json.dumps(doc))
    with pytest.raises(ArtifactError, match="not the weights of this policy"):
        designs.load(tmp_path, model)
