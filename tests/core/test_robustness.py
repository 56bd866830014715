"""The scenario suite on fixed tables: each cell is the validation of those tables under its condition."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation import robustness
from msd_bench.core.evaluation.closed_loop import Conditions, greedy_under
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.learning.qconfig import QConfig, improved_config, packed
from msd_bench.core.learning.qtrain import greedy_rollouts, train
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs.qlearning import tables_policy

P = PlantParams()
CFG = improved_config(episodes=20, steps=3000)
SEEDS = [3, 4, 5]


def _policy(q: np.ndarray, cfg: QConfig = CFG, seeds: list[int] = SEEDS):
    """The tables as a policy whose observer predicts with the nominal plant."""
    return tables_policy(q, cfg, seeds, plant_model(P))


def _rollouts(q: np.ndarray, sid: str, steps: int, cfg: QConfig = CFG, seeds: list[int] = SEEDS):
    """True positions and commands of the tables under scenario ``sid``, as the one evaluator runs them."""
    return robustness.policy_rollouts(_policy(q, cfg, seeds), P, parse(sid), seeds, steps)


@pytest.fixture(scope="module")
def tables():
    return train(plant_model(P), CFG, SEEDS).q


@pytest.mark.parametrize("cfg", [QConfig(episodes=5), CFG])
def test_nominal_scenario_is_the_ordinary_validation_bit_for_bit(cfg):
    q = train(plant_model(P), cfg, SEEDS).q
    x_ref, u_ref = greedy_rollouts(plant_model(P), q, cfg, 1.0, 1500)
    x, u = _rollouts(q, "nominal", 1500, cfg)
    assert np.array_equal(x, x_ref) and np.array_equal(u, u_ref)


def test_each_cell_scores_its_own_condition(tables):
    scenarios = [parse("nominal"), parse("mass=2"), parse("setpoint=-1.5"), parse("noise=0.005")]
    rob = robustness.evaluate_policy(_policy(tables), P, SEEDS, scenarios, steps=1500, window=300)
    assert list(rob) == ["nominal", "mass=2", "setpoint=-1.5", "noise=0.005"]
    heavy_x, _ = _rollouts(tables, "mass=2", 1500)
    assert rob["mass=2"]["sse"] == [compute(x, 1.0, P.dt, 300).sse for x in heavy_x]
    assert rob["mass=2"]["sse"] != rob["nominal"]["sse"]
    assert rob["noise=0.005"]["sse"] != rob["nominal"]["sse"]
    for cell in rob.values():
        lo, hi = cell["ci95"]
        assert cell["n"] == 3 and lo <= cell["n_success"] / 3 <= hi


def test_cells_reproduce_and_noise_depends_on_seed_and_scenario(tables):
    a = robustness.evaluate_policy(_policy(tables), P, SEEDS, [parse("noise=0.002")], steps=800, window=200)
    b = robustness.evaluate_policy(_policy(tables), P, SEEDS, [parse("noise=0.002")], steps=800, window=200)
    assert a == b
    n1 = robustness.sensor_noise(parse("noise=0.002"), [3, 4], 100)
    n2 = robustness.sensor_noise(parse("noise=0.002,delay=0"), [3, 4], 100)
    assert not np.array_equal(n1, n2) and not np.array_equal(n1[0], n1[1])
    assert 0.0015 < n1.std() < 0.0025


def _hold(force_index: int) -> np.ndarray:
    q = np.zeros((1, packed(QConfig()).enc.n_states, 5))
    q[0, :, force_index] = 1.0
    return q


def test_delay_shifts_the_applied_command_and_load_and_friction_act_on_the_plant():
    lr = packed(QConfig())
    model = plant_model(P).kernel
    q = _hold(4)  # always +F
    base = Conditions(1.0, 0.0, 0, 0.0, 0, 0.0)
    x0, _ = greedy_under(model, lr, q, base, np.zeros((1, 50)), model)
    x2, _ = greedy_under(model, lr, q, base._replace(delay=2), np.zeros((1, 50)), model)
    assert np.array_equal(x2[0, 2:], x0[0, :-2]) and np.all(x2[0, :3] == 0.0)
    pushed, _ = greedy_under(model, lr, _hold(2), base._replace(load=3.0, load_step=10), np.zeros((1, 40)),
                             model)
    assert np.all(pushed[0, :11] == 0.0) and pushed[0, -1] > 0.0
    stuck, _ = greedy_under(model, lr, _hold(2), base._replace(load=3.0, friction=3.5), np.zeros((1, 40)),
                            model)
    assert np.all(stuck == 0.0)  # friction beyond the load holds the mass


def test_a_load_enters_an_arx_models_input_after_saturation():
    # An ARX-type surrogate standing in for the plant: a load of -2 N from sample 10 on is what the model
    # does under (saturated command - 2 N) from then on, and it is not clipped with the command.
    arx = StepModel(kernels.KIND_LINEAR, np.array([5.0, 5e-5, 5e-5, -1.975, 0.9802, 0.0, 0.0]), "arx")
    lr = packed(QConfig())
    cond = Conditions(1.0, 0.0, 0, -2.0, 10, 0.0)
    loaded, us = greedy_under(arx.kernel, lr, _hold(4), cond, np.zeros((1, 60)), arx.kernel)
    assert np.all(us == 10.0)
    forces = np.where(np.arange(60) >= 10, 8.0, 10.0)
    state = arx.initial_state()
    expected = [0.0] + [arx.step(state, f) for f in forces[:-1]]
    assert np.array_equal(loaded[0], expected)
    free, _ = greedy_under(arx.kernel, lr, _hold(4), cond._replace(load=0.0), np.zeros((1, 60)), arx.kernel)
    assert np.array_equal(free[0, :11], loaded[0, :11]) and np.all(free[0, 11:] > loaded[0, 11:])
    state = arx.initial_state()
    beyond = [kernels.advance_loaded(arx.kernel, state, 10.0, 2.0) for _ in range(5)]  # 12 N acts
    state = arx.initial_state()
    assert beyond[-1] == pytest.approx(1.2 * [arx.step(state, 10.0) for _ in range(5)][-1], rel=1e-12)


def test_quantisation_is_applied_to_what_the_agent_sees():
    from msd_bench.core.evaluation.closed_loop import quantise

    assert quantise(0.00049, 0.001) == 0.0 and quantise(0.0006, 0.001) == 0.001
    assert quantise(-0.0006, 0.001) == -0.001 and quantise(0.123, 0.0) == 0.123


def test_one_seed_per_table_is_required(tables):
    with pytest.raises(InvalidInputError, match="one learning seed per Q-table"):
        _rollouts(tables, "nominal", 100, seeds=[1])


def test_a_lag_slows_the_applied_force_and_lag_zero_changes_nothing(tables):
    from msd_bench.core.rigs.actuation import actuator_force
    from msd_bench.core.rigs.rig import Actuator

    x0, u0 = _rollouts(tables, "nominal", 800)
    xz, uz = _rollouts(tables, "lag=0", 800)
    assert np.array_equal(x0, xz) and np.array_equal(u0, uz)
    xl, _ = _rollouts(tables, "lag=0.04", 800)
    assert not np.array_equal(x0, xl)
    # the compiled actuator is the one actuation.py rebuilds forces with (same discretisation)
    u = np.where(np.arange(200) % 37 < 18, 5.0, -2.5)
    act = Actuator(delay=2, tau=0.03, dt=P.dt)
    assert np.allclose([act.apply(v) for v in u], actuator_force(u, 2, 0.03, P.dt), rtol=0, atol=1e-12)
