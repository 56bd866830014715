"""The model contract, checked on the plant and on every stored surrogate kind.

What every plant-like model promises, wherever it is stepped (the ROS nodes,
Q-learning, Dyna-Q, identification checks):

* deterministic: the same forces from the same state give the same positions;
* on the stroke: the position stays in [-L/2, L/2] (the plant's hard stops) and
  finite, under random and extreme forces and from the stops themselves;
* a non-finite force raises :class:`InvalidInputError` on every path
  (``StepModel.step``, ``StepModel.simulate``, the compiled ``kernels.advance``
  and ``kernels.rollout``) and leaves the state untouched — nothing is moved;
  a non-finite state is refused the same way rather than parked anywhere;
* a force beyond ±F acts exactly as ±F. For a surrogate F is the force limit of
  the plant it stands for — the plant's F, which is also what the surrogate
  node saturates commands to — so surrogates and the plant saturate alike;
* batch equals scalar: a rollout equals stepping one force at a time, and a
  batch of learners or greedy rollouts equals each member run alone.

``CONTRACT_MODELS`` is the one list of what is checked (name -> model factory);
point it at the model registry to cover every registered kind.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.learning.qconfig import QConfig, improved_config
from msd_bench.core.learning.qtrain import greedy_rollout, greedy_rollouts, train
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, held, plant_model
from msd_bench.core.physics.plant import preset
from msd_bench.io.storage.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
PLANT = preset("default")


def _stored(name: str) -> Callable[[], StepModel]:
    return lambda: load_model(PINNED / f"{name}.json")


CONTRACT_MODELS: dict[str, Callable[[], StepModel]] = {
    "plant": lambda: plant_model(PLANT),
    "glm": _stored("glm"),
    "plm": _stored("plm"),
    "nlarx-paper": _stored("nlarx-paper"),
    "nlarx-improved": _stored("nlarx-improved"),
    "greybox": _stored("greybox"),
    "greybox-rig": lambda: StepModel(kernels.KIND_GREYBOX_RIG,
                                     np.concatenate([PLANT.as_array(), [0.2, 0.02, 2.0]]), "greybox-rig",
                                     dt=PLANT.dt, force_limit=PLANT.F),
    "greybox-rk4": lambda: StepModel(kernels.KIND_RK4,  # the plant's springs, ramped input, an offset
                                     np.array([PLANT.m, PLANT.c, 0.0, 0.0, PLANT.h, PLANT.L, PLANT.F,
                                               PLANT.dt, PLANT.k, PLANT.g, 0.1, 0.01, 0.05, 2.0, 1.0]),
                                     "greybox-rk4", dt=PLANT.dt, force_limit=PLANT.F),
    "held": lambda: held(load_model(PINNED / "glm.json"), 3),  # a decision held over 3 samples
}
"""Every model kind under contract: the true plant and one stored artifact per surrogate kind."""

F = PLANT.F
BAD_FORCES = (math.nan, math.inf, -math.inf)


@pytest.fixture(params=sorted(CONTRACT_MODELS), scope="module")
def model(request: pytest.FixtureRequest) -> StepModel:
    return CONTRACT_MODELS[request.param]()


def _start_states(m: StepModel) -> list[np.ndarray]:
    """Rest, and sitting at each stop (with the last force pushing outward), in the model's layout."""
    x = m.x_max
    if m.kind == kernels.KIND_PLANT:
        return [m.initial_state(), np.array([x, 0.0, 0.0, 0.0]), np.array([-x, 0.0, 0.0, 0.0])]
    if m.kind == kernels.KIND_GREYBOX_RIG:  # at a stop, the lag and the delay line pushing outward
        return [m.initial_state(), np.array([x, 0.0] + [F] * (kernels.RIG_STATE_SIZE - 2)),
                np.array([-x, 0.0] + [-F] * (kernels.RIG_STATE_SIZE - 2))]
    return [m.initial_state(), np.array([x, x, F, 0.0]), np.array([-x, -x, -F, 0.0])]


def _forces(seed: int, n: int = 4000) -> np.ndarray:
    """Random forces well beyond ±F, with bang-bang stretches and huge spikes mixed in."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-3 * F, 3 * F, n)
    pushes = n // 400
    u[: 100 * pushes] = np.repeat(rng.choice([-F, F], pushes), 100)  # long pushes either way
    u[rng.integers(0, n, n // 50)] = rng.choice([-1e12, 1e12], n // 50)
    return u


def test_every_model_kind_is_under_contract() -> None:
    kinds = {CONTRACT_MODELS[name]().kind for name in CONTRACT_MODELS}
    assert kinds == set(kernels.KIND_NAMES)


def test_model_stands_for_the_plant(model: StepModel) -> None:
    held_over = int(model.params[0]) if model.kind == kernels.KIND_HELD else 1  # its dt: the decision's
    assert (model.x_max, model.force_limit, model.dt) == (PLANT.L / 2, PLANT.F, PLANT.dt * held_over)


def test_deterministic(model: StepModel) -> None:
    u = _forces(0)
    first = model.simulate(u)
    assert np.array_equal(first, model.simulate(u))
    assert np.ptp(first) > 0.5  # the forces really move the model


def test_rollout_equals_scalar_steps(model: StepModel) -> None:
    u = _forces(1, 1500)
    for start in _start_states(model):
        sim = model.simulate(u, start)
        state = start.copy()
        stepped = [float(state[0])] + [model.step(state, float(uk)) for uk in u[:-1]]
        assert np.array_equal(sim, np.array(stepped))


def test_stays_on_the_stroke(model: StepModel) -> None:
    for seed in range(3):
        for start in _start_states(model):
            x = model.simulate(_forces(seed), start)
            assert np.all(np.isfinite(x))
            assert np.max(np.abs(x)) <= model.x_max
    for push in (1e9, -1e9):  # a sustained extreme push, from rest and from either stop
        for start in _start_states(model):
            x = model.simulate(np.full(3000, push), start)
            assert np.all(np.isfinite(x)) and np.max(np.abs(x)) <= model.x_max


@pytest.mark.parametrize("bad", BAD_FORCES)
def test_non_finite_force_is_rejected_on_every_path(model: StepModel, bad: float) -> None:
    state = model.initial_state()  # four floats, or the greybox-rig's longer state
    state[:3] = 0.7, 0.65, 3.0
    before = state.copy()
    calls: list[Callable[[], object]] = [
        lambda: model.step(state, bad),
        lambda: kernels.advance(model.kernel, state, bad),
        lambda: model.simulate(np.array([1.0, bad, 1.0])),
        lambda: kernels.rollout(model.kernel, np.array([1.0, bad, 1.0]), state.copy()),
    ]
    for call in calls:
        with pytest.raises(InvalidInputError, match="finite") as info:
            call()
        assert "\n" not in str(info.value)
    assert np.array_equal(state, before)  # a rejected force moved nothing


def test_non_finite_state_is_refused_not_parked(model: StepModel) -> None:
    state = model.initial_state()
    state[0] = math.nan
    with pytest.raises(InvalidInputError, match="non-finite position"):
        kernels.advance(model.kernel, state, 1.0)
    with pytest.raises(InvalidInputError, match="finite"):
        model.simulate(np.ones(3), state)


@pytest.mark.parametrize("factor", [1.0 + 1e-12, 1.5, 1e3, 1e250])
def test_force_beyond_the_limit_acts_as_the_limit(model: StepModel, factor: float) -> None:
    inside = model.initial_state()
    inside[:3] = 0.3, 0.28, -2.0
    for start in [*_start_states(model), inside]:
        for sign in (1.0, -1.0):
            a, b = start.copy(), start.copy()
            assert model.step(a, sign * factor * F) == model.step(b, sign * F)
            assert np.array_equal(a, b)  # the whole state, the remembered force included
    u = _forces(2, 1000)
    assert np.array_equal(model.simulate(u * factor), model.simulate(np.clip(u * factor, -F, F)))


def test_force_within_the_limit_is_not_saturated(model: StepModel) -> None:
    # the saturation bites only beyond F: just below it the response differs from at F (after a
    # model's input delay, when it has one: hence a few steps)
    a, b = model.initial_state(), model.initial_state()
    assert [model.step(a, 0.9 * F) for _ in range(4)][-1] != [model.step(b, F) for _ in range(4)][-1]


def test_limit_is_the_model_s_own(model: StepModel) -> None:
    if model.kind == kernels.KIND_PLANT:
        wider = plant_model(replace(PLANT, F=2 * F))
    elif model.kind in (kernels.KIND_GREYBOX_RIG, kernels.KIND_RK4):  # its F is a parameter, as the plant's
        params = model.params.copy()
        params[6] = 2 * F
        wider = replace(model, params=params, force_limit=2 * F)
    else:
        wider = replace(model, force_limit=2 * F)
    a, b = model.initial_state(), model.initial_state()
    assert [wider.step(a, 2 * F) for _ in range(4)][-1] != [model.step(b, 2 * F) for _ in range(4)][-1]


@pytest.mark.parametrize("cfg", [QConfig(episodes=2, steps=500),
                                 improved_config(episodes=2, steps=500)],
                         ids=["paper", "improved"])
def test_learner_batch_equals_single(model: StepModel, cfg: QConfig) -> None:
    batch = train(model, cfg, [4, 9])
    single = train(model, cfg, [9])
    assert np.array_equal(batch.q[1], single.q[0])
    assert np.array_equal(batch.returns[1], single.returns[0])
    assert not np.array_equal(batch.q[0], batch.q[1])
    xs, us = greedy_rollouts(model, batch.q, cfg, 1.0, 400)
    x1, u1 = greedy_rollout(model, batch.q[1], cfg, 1.0, 400)
    assert np.array_equal(xs[1], x1) and np.array_equal(us[1], u1)


def test_every_registered_model_kind_is_under_contract() -> None:
    from msd_bench.core.identification.model_kinds import MODEL_KINDS

    assert set(MODEL_KINDS) <= set(CONTRACT_MODELS), "store an artifact of the new kind in tests/data/pinned"
