"""A new baseline is one module and one catalogue line: nothing else names it.

The planted baseline (``tests/core/hold_baseline.py``) joins the catalogue for one test; its kinds
appear in the design registry, are made, rolled out and driven stepwise through the protocol, and
they are gone again once the catalogue is restored.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.core.baselines import catalogue
from msd_bench.core.evaluation.closed_loop import nominal
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs import registry


def _reload() -> None:
    """Rebuild the tables that read the catalogue, and the registry over them."""
    importlib.reload(importlib.import_module("msd_bench.core.baselines.designs"))
    importlib.reload(importlib.import_module("msd_bench.designs.baselines"))
    registry.DESIGNS._designs.clear()
    registry.DESIGNS._loaded = False
    registry.AGENT_KINDS.refresh()


@pytest.fixture
def planted(monkeypatch: pytest.MonkeyPatch):  # type: ignore[no-untyped-def]
    line = catalogue.Listing("hold", "tests.core.hold_baseline", "hold the set-point's equilibrium force",
                             "hold baseline")
    monkeypatch.setattr(catalogue, "CATALOGUE", (*catalogue.CATALOGUE, line))
    _reload()
    yield
    monkeypatch.undo()
    _reload()


def test_every_classical_baseline_of_the_registry_is_a_catalogue_line():
    from msd_bench.designs.baselines import BaselineDesign

    classical = [d for d in registry.DESIGNS if isinstance(registry.DESIGNS[d], BaselineDesign)]
    assert classical == [c.name for c in catalogue.CATALOGUE] == ["pid", "pid-continuous", "lqr", "mpc"]


def test_a_planted_module_and_line_make_a_baseline_everywhere(planted):
    assert "glm+hold" in designs.AGENT_KINDS and "hold" in registry.DESIGNS
    model = plant_model(PlantParams())
    policy = designs.make("greybox+hold", model, designs.Settings(), [3])
    assert policy.facts.deterministic and policy.members == (3,)
    xs, us = policy.rollout(model.kernel, nominal(1.0), np.zeros((1, 400)))
    assert np.all(us == us[0, 0]) and abs(xs[0, -1] - 1.0) < 0.05  # the true plant's own equilibrium
    assert policy.controller(0, 1.0).act(0.3) == us[0, 0]


def test_the_planted_baseline_is_gone_with_its_line():
    assert "glm+hold" not in designs.AGENT_KINDS
