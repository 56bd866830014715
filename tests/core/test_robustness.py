"""Robustness scenarios: nominal equals the validation, perturbations really perturb, bad input."""

from __future__ import annotations

from dataclasses import replace

import pytest

from msd_bench.core import robustness
from msd_bench.core.errors import ConfigError
from msd_bench.core.metrics import compute
from msd_bench.core.model import plant_model
from msd_bench.core.plant import PlantParams
from msd_bench.core.qconfig import QConfig
from msd_bench.core.qtrain import greedy_rollouts, train

P = PlantParams()
CFG = QConfig(episodes=20, steps=1000)


@pytest.fixture(scope="module")
def tables():
    return train(plant_model(P), CFG, [0, 1, 2, 3]).q


def test_nominal_scenario_is_the_ordinary_validation(tables) -> None:
    rob = robustness.evaluate(tables, CFG, P, [robustness.Scenario("nominal")], steps=1500, window=300)
    xs, _ = greedy_rollouts(plant_model(P), tables, CFG, 1.0, 1500)
    expected = [compute(x, 1.0, P.dt, 300).sse for x in xs]
    assert rob["nominal"]["sse"] == expected
    assert rob["nominal"]["n_success"] == sum(s < 5.0 for s in expected)


def _sse(model, tables, target):
    xs, _ = greedy_rollouts(model, tables, CFG, target, 1500)
    return [compute(x, target, P.dt, 300).sse for x in xs]


def test_perturbations_change_the_closed_loop(tables) -> None:
    scenarios = [robustness.Scenario("nominal"), robustness.Scenario("heavy", {"m": 2.0}),
                 robustness.Scenario("far", target=1.5)]
    rob = robustness.evaluate(tables, CFG, P, scenarios, steps=1500, window=300)
    # each scenario is the validation of the same tables on its own plant and set-point ...
    heavy = _sse(plant_model(replace(P, m=2.0)), tables, 1.0)
    far = _sse(plant_model(P), tables, 1.5)
    assert rob["heavy"]["sse"] == heavy and rob["far"]["sse"] == far
    assert rob["far"]["target"] == 1.5 and rob["heavy"]["scale"] == {"m": 2.0}
    # ... and those really differ from the nominal run (a table that parks the mass at rest
    # scores 100 % whatever the mass, so not every table need change)
    for changed in (heavy, far):
        assert any(abs(a - b) > 1.0 for a, b in zip(changed, rob["nominal"]["sse"], strict=True))


def test_scenario_scales_parameters_by_hand() -> None:
    plant = robustness.Scenario("s", {"m": 1.2, "c": 0.5}).plant(P)
    assert (plant.m, plant.c, plant.k) == (pytest.approx(1.2), pytest.approx(0.5), P.k)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"scale": {"dt": 2.0}}, "cannot scale 'dt'"), ({"scale": {"m": -1.0}}, "finite and > 0"),
     ({"target": 0.0}, "set-point")],
)
def test_bad_scenarios_are_one_line(kwargs, message) -> None:
    with pytest.raises(ConfigError, match=message):
        robustness.Scenario("bad", **kwargs)
