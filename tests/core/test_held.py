"""A held model: one command held over n samples of the model it wraps (issue 37 item 3, decision period).

The learner that decides every n rig samples trains on the rig's model stepped n times per decision;
every other model steps exactly as before (the held branch is a kind of its own).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, held, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.io.storage.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
P = replace(PlantParams(), dt=0.001)


def load_pinned(name: str) -> StepModel:
    """A pinned surrogate artifact (tests/data/pinned)."""
    return load_model(PINNED / f"{name}.json")


@pytest.mark.parametrize("name", ["plant", "glm", "plm", "nlarx-improved", "greybox"])
def test_held_steps_the_inner_model_n_times_per_command(name: str) -> None:
    model = plant_model(P) if name == "plant" else load_pinned(name)
    n = 10
    u = np.random.default_rng(1).choice([-10.0, -5.0, 0.0, 5.0, 10.0], size=200)
    fine = model.simulate(np.repeat(u, n))
    coarse = held(model, n).simulate(u)
    np.testing.assert_array_equal(coarse, fine[::n])  # the same arithmetic, sample for sample
    h = held(model, n)
    assert h.dt == pytest.approx(model.dt * n)
    assert h.x_max == model.x_max and h.force_limit == model.force_limit


def test_one_sample_per_decision_is_the_model_itself_and_bad_holds_are_one_line() -> None:
    model = plant_model(P)
    assert held(model, 1) is model
    for bad in (0, -3, 2.5, True, 10**6):
        with pytest.raises(InvalidInputError, match="samples per decision"):
            held(model, bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="held already"):
        held(held(model, 2), 2)
    with pytest.raises(InvalidInputError, match="unknown inner kind"):
        StepModel(kernels.KIND_HELD, np.array([2.0, 99.0, 1.0]), "x")
    with pytest.raises(InvalidInputError, match="one-step prediction"):
        held(load_pinned("glm"), 2).predict_one_step(np.zeros(5), np.zeros(5))


def test_a_non_finite_command_moves_nothing() -> None:
    h = held(plant_model(P), 5)
    s = h.initial_state()
    s[0] = 0.3
    with pytest.raises(InvalidInputError):
        h.step(s, float("nan"))
    assert s[0] == 0.3


def test_an_observer_converts_velocity_over_a_held_models_decision_not_its_head() -> None:
    """``kernels.step_period``: one advance of a velocity-holding model spans its sample time, n of them
    when held (read from the inner plant's slots; the held model's own params lead with its head, which
    the observer once read as a plant and so took a garbage sample time)."""
    plain = plant_model(P)
    assert kernels.step_period(plain.kernel) == P.dt
    assert kernels.step_period(held(plain, 4).kernel) == 4 * P.dt
