"""The protocol from outside: a design registered only here runs in-process; unknown kinds are one line."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import run_paper, settings
from msd_bench.core.errors import ConfigError
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.storage.artifacts import ArtifactError
from tests.designs.relay import RelayDesign

TINY = RunConfig(seeds=2, id_seeds=2, samples=600, val_samples=400, validation_steps=400, window=100,
                 agents=("glm+pid",))
"""The budgets; each test names its kinds (``glm+relay`` exists only while registered)."""


@pytest.fixture
def relay() -> Iterator[RelayDesign]:
    d = RelayDesign()
    designs.register(d)
    yield d
    designs.unregister(d.name)


def test_a_design_registered_here_is_a_row_of_run_paper(relay):
    run = run_paper(replace(TINY, agents=("glm+relay",)))
    (row,) = run.results
    assert row.kind == "glm+relay" and row.label == "GLM (relay baseline)"
    assert row.n == 2  # deterministic: one run per identification seed, not one per learning seed
    assert [s["id_seed"] for s in row.per_seed] == [0, 1]
    nominal = run.robustness["glm+relay"]["nominal"]
    assert nominal["n"] == 2 and run.robustness["glm+relay"]["noise=0.001"]["n"] == 4  # 2 id x 2 draws
    for id_seed, policy in run.policies["glm+relay"].items():
        x, _ = designs.nominal_runs(policy, TINY.plant, TINY.target, TINY.validation_steps)
        assert np.array_equal(x[0], run.responses["glm+relay"][id_seed])


def test_a_policy_saves_and_loads_back(relay, tmp_path):
    model = plant_model(PlantParams())
    policy = designs.make("glm+relay", model, settings(TINY), [3])
    designs.save(policy, tmp_path, {"test": True}, root=tmp_path)
    back = designs.load(tmp_path, model)
    assert back.members == (3,) and back.facts == policy.facts


def test_unregistered_the_kind_is_one_line_everywhere(relay, tmp_path):
    model = plant_model(PlantParams())
    designs.save(designs.make("glm+relay", model, settings(TINY), [0]), tmp_path, {}, root=tmp_path)
    designs.unregister("relay")
    with pytest.raises(ConfigError, match=r"^unknown agent kind 'glm\+relay'; choose from glm, "):
        RunConfig(agents=("glm+relay",))
    with pytest.raises(ConfigError, match=r"^unknown agent kind 'glm\+relay'"):
        designs.make("glm+relay", model, settings(TINY), [0])
    with pytest.raises(ConfigError, match=r"^unknown design 'relay'; choose from paper, "):
        designs.design("relay")
    with pytest.raises(ConfigError, match=r"unknown agent kind 'glm\+relay'"):
        designs.load(tmp_path, model)
    designs.register(relay)  # the fixture unregisters it


def test_a_policy_of_another_design_is_refused(tmp_path):
    model = plant_model(PlantParams())
    policy = designs.make("greybox+pid", model, settings(TINY), [0])
    designs.save(policy, tmp_path, {}, root=tmp_path)
    text = (tmp_path / "policy.json").read_text().replace('"design": "pid"', '"design": "lqr"', 1)
    (tmp_path / "policy.json").write_text(text)
    with pytest.raises(ArtifactError, match="is made by 'pid', not 'lqr'"):
        designs.load(tmp_path, model)


def test_every_kind_names_its_design_and_the_baselines_are_opt_in():
    from msd_bench.app.agents import DEFAULT_AGENTS

    kinds = designs.AGENT_KINDS
    assert {kinds[k].agent for k in ("glm+pid", "glm+pid-continuous", "greybox+lqr", "plm+mpc")} == {
        "pid", "pid-continuous", "lqr", "mpc"}
    assert all(kinds[k].design.baseline for k in kinds if k.endswith(("+pid", "+lqr", "+mpc")))
    assert not any(kinds[k].design.baseline for k in DEFAULT_AGENTS)
    assert kinds["dyna-q"].design.model_free and kinds["dyna-q"].on_plant
    assert kinds["plm"].agent == "paper" and kinds["plm@away"].shaping == "away"
