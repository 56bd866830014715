"""The plant against hand-computed Euler steps, at the stops, and on bad input."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import fields

import numpy as np
import pytest

from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.physics import kernels, plant
from msd_bench.core.physics.model import plant_model

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
def test_non_finite_force_raises_one_line_error_on_every_plant_path(bad: float) -> None:
    calls: list[Callable[[], object]] = [
        lambda: plant.step(0.0, 0.0, bad, P),
        lambda: plant.step_batch(np.zeros(3), np.zeros(3), np.array([0.0, bad, 1.0]), P),
        lambda: plant.simulate(np.array([1.0, bad]), P),
        lambda: plant.check_force(bad, P),
        lambda: plant.equilibrium(bad, P),
    ]
    for call in calls:
        with pytest.raises(InvalidInputError, match="force must be finite") as info:
            call()
        assert "\n" not in str(info.value)


def _reference_step(x: np.ndarray, v: np.ndarray, u: np.ndarray,
                    p: plant.PlantParams) -> tuple[np.ndarray, np.ndarray]:
    """The plant written independently of the kernel (numpy, acceleration first)."""
    u = np.clip(u, -p.F, p.F)
    acc = (u - p.c * v - p.k * np.sin(p.g * x) - p.h * x**3) / p.m
    v_new = v + p.dt * acc
    x_free = x + p.dt * v_new
    x_new = np.clip(x_free, -p.L / 2, p.L / 2)
    return x_new, np.where(x_new != x_free, 0.0, v_new)


def test_compiled_step_matches_an_independent_implementation() -> None:
    # non-default parameters, so a wrong field order in the packed layout would show
    p = plant.PlantParams(m=1.7, c=0.6, k=3.1, g=0.8, h=0.4, L=4.0, F=7.0, dt=0.004)
    rng = np.random.default_rng(1)
    x = rng.uniform(-2.0, 2.0, 400)
    v = rng.uniform(-200, 200, 400)  # up to 0.8 m per step: many steps hit a stop
    u = rng.uniform(-12, 12, 400)
    xb, vb = plant.step_batch(x, v, u, p)
    xr, vr = _reference_step(x, v, u, p)
    np.testing.assert_allclose(xb, xr, rtol=0, atol=1e-13)
    np.testing.assert_allclose(vb, vr, rtol=0, atol=1e-11)
    assert 20 < np.sum(np.abs(xb) == 2.0) < 350  # both the stops and the interior exercised


def test_batch_scalar_and_simulate_are_one_transition() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-2.5, 2.5, 64)
    v = rng.uniform(-3, 3, 64)
    u = rng.uniform(-15, 15, 64)
    xb, vb = plant.step_batch(x, v, u, P)
    assert [(xb[i], vb[i]) for i in range(64)] == [plant.step(x[i], v[i], u[i], P)
                                                   for i in range(64)]
    u_seq = rng.uniform(-12, 12, 500)
    x_k, v_k, u_applied = plant.simulate(u_seq, P)
    xs, vs = 0.0, 0.0
    for k in range(u_seq.size):
        assert (x_k[k], v_k[k]) == (xs, vs)
        xs, vs = plant.step(xs, vs, float(u_seq[k]), P)
    assert np.array_equal(u_applied, np.clip(u_seq, -P.F, P.F))


def test_plant_model_steps_like_the_plant() -> None:
    p = plant.PlantParams(m=1.7, c=0.6, k=3.1, g=0.8, h=0.4, L=4.0, F=7.0, dt=0.004)
    model = plant_model(p)
    s = model.initial_state()
    x, v = 0.0, 0.0
    for u in (9.0, -3.0, 6.5, 100.0):
        x, v = plant.step(x, v, u, p)
        assert model.step(s, u) == x and s[1] == v
    assert model.kind == kernels.KIND_PLANT
    assert (model.dt, model.force_limit, model.x_max) == (0.004, 7.0, 2.0)


def test_packed_layout_is_the_kernel_named_tuple() -> None:
    assert tuple(f.name for f in fields(plant.PlantParams)) == kernels.Plant._fields
    p = plant.PlantParams(m=1.7, c=0.6, k=3.1, g=0.8, h=0.4, L=4.0, F=7.0, dt=0.004)
    assert tuple(p.as_array()) == (1.7, 0.6, 3.1, 0.8, 0.4, 4.0, 7.0, 0.004)
    assert kernels.plant_of(p.as_array()) == p.kernel()


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
    with pytest.raises(InvalidInputError, match="1-D"):
        plant.simulate(np.zeros((2, 2)), P)
    with pytest.raises(InvalidInputError, match="one length"):
        plant.step_batch(np.zeros(2), np.zeros(3), np.zeros(2), P)
