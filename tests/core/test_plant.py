"""The plant against hand-computed Euler steps, at the stops, and on bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msd_bench.core import kernels, plant
from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.model import plant_model

P = plant.PlantParams()


def test_one_step_matches_hand_computed_euler() -> None:
    # From x = 0.5, v = 0.2 under u = 3 N with the defaults (m=1, c=1, k=2.4, g=1, h=1, dt=0.01):
    acc = 3.0 - 1.0 * 0.2 - 2.4 * math.sin(0.5) - 0.5**3
    v_expected = 0.2 + 0.01 * acc
    x_expected = 0.5 + 0.01 * v_expected  # position uses the *new* velocity
    x, v = plant.step(0.5, 0.2, 3.0, P)
    assert v == pytest.approx(v_expected, abs=1e-15)
    assert x == pytest.approx(x_expected, abs=1e-15)


def test_hard_stop_projects_position_and_zeroes_velocity() -> None:
    x, v = plant.step(2.499, 5.0, 10.0, P)
    assert x == 2.5
    assert v == 0.0
    x, v = plant.step(-2.499, -5.0, -10.0, P)
    assert x == -2.5
    assert v == 0.0


def test_velocity_kept_when_moving_inward_from_the_stop() -> None:
    x, v = plant.step(2.5, 0.0, -10.0, P)
    assert x < 2.5
    assert v < 0.0


def test_out_of_range_force_acts_exactly_like_the_bound() -> None:
    assert plant.step(0.3, -0.1, 1e6, P) == plant.step(0.3, -0.1, P.F, P)
    assert plant.step(0.3, -0.1, -1e6, P) == plant.step(0.3, -0.1, -P.F, P)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_force_raises_one_line_error(bad: float) -> None:
    with pytest.raises(InvalidInputError, match="finite") as info:
        plant.step(0.0, 0.0, bad, P)
    assert "\n" not in str(info.value)


def test_batch_step_equals_scalar_step() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-2.5, 2.5, 64)
    v = rng.uniform(-3, 3, 64)
    u = rng.uniform(-15, 15, 64)
    xb, vb = plant.step_batch(x, v, u, P)
    for i in range(64):
        assert (xb[i], vb[i]) == pytest.approx(plant.step(x[i], v[i], u[i], P), abs=1e-15)


def test_compiled_kernel_equals_python_step() -> None:
    u = np.random.default_rng(1).uniform(-12, 12, 500)
    x_k, v_k, _ = plant.simulate(u, P)
    x, v = 0.0, 0.0
    for k in range(u.size):
        assert x_k[k] == x and v_k[k] == v
        x, v = plant.step(x, v, float(u[k]), P)


def test_plant_model_steps_like_the_plant() -> None:
    model = plant_model(P)
    s = model.initial_state()
    assert model.step(s, 10.0) == plant.step(0.0, 0.0, 10.0, P)[0]
    assert model.kind == kernels.KIND_PLANT


def test_bias_forces_hold_the_mass_near_the_membership_centres() -> None:
    # docs/design.md §Plant: ±10 N holds the mass near ±2 m, ±5 N near ±1.4 m, 1 m needs ~3 N.
    assert plant.equilibrium(10.0, P) == pytest.approx(1.98, abs=0.02)
    assert plant.equilibrium(-5.0, P) == pytest.approx(-1.38, abs=0.02)
    assert float(plant.spring_force(1.0, P)) == pytest.approx(3.02, abs=0.01)


def test_presets_and_bad_parameters() -> None:
    assert plant.preset("mild").k == 5.0
    with pytest.raises(ConfigError, match="unknown plant preset"):
        plant.preset("stiff")
    with pytest.raises(ConfigError, match="m must be finite and > 0"):
        plant.PlantParams(m=0.0)


def test_simulate_rejects_bad_sequences() -> None:
    with pytest.raises(InvalidInputError, match="non-empty"):
        plant.simulate(np.array([]), P)
    with pytest.raises(InvalidInputError, match="non-finite"):
        plant.simulate(np.array([0.0, np.nan]), P)
