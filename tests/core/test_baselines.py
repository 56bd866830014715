"""Baseline designs: tuning facts, parity of stepwise and compiled forms, the actuator, nominal success."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.baselines import base, designs, lqr, mpc, pid
from msd_bench.core.errors import ConfigError, InvalidInputError
from msd_bench.core.evaluation.closed_loop import Conditions, nominal, quantise
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.robustness import conditions, evaluate_policy
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.learning.qconfig import QConfig
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.designs.baselines import baseline_policy
from msd_bench.io.storage.artifacts import load_model

PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
P = PlantParams()
PLANT = plant_model(P).kernel
# The kinds of the brief: each design on the surrogate it is named for.
KINDS = ("glm+pid", "glm+pid-continuous", "greybox+lqr", "plm+mpc")
SCENARIO = parse("noise=0.002,delay=1,disturbance=2@5")


def _model(name: str) -> StepModel:
    return load_model(PINNED / f"{name}.json")


@pytest.fixture(scope="module")
def built() -> dict[str, designs.Design]:
    out = {}
    for kind in KINDS:
        surrogate, name = designs.parse_kind(kind)
        out[kind] = designs.make(name, _model(surrogate), 1.0, P.F, P.dt)
    return out


def _drive(ctrl: designs.StepwiseLaw, cond: Conditions, noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The stepwise controller on the plant, written from greedy_under's documented semantics."""
    n = noise.size
    xs, us = np.empty(n), np.empty(n)
    state = np.zeros(2)
    queue = [0.0] * (cond.delay + 1)
    plant = kernels.plant_of(PLANT.params)
    ctrl.reset()
    x = 0.0
    for k in range(n):
        u = ctrl.act(quantise(x + noise[k], cond.quant))
        xs[k], us[k] = x, u
        queue[k % (cond.delay + 1)] = u
        applied = queue[(k + 1) % (cond.delay + 1)]
        load = cond.load if k >= cond.load_step else 0.0
        state[0], state[1] = kernels.plant_step_loaded(plant, state[0], state[1], applied, load,
                                                       cond.friction)
        x = state[0]
    return xs, us


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("scenario", ["nominal", "perturbed"])
def test_stepwise_form_reproduces_the_compiled_rollout_bit_for_bit(built, kind, scenario):
    steps = 800
    if scenario == "nominal":
        cond, noise = nominal(1.0), np.zeros((1, steps))
    else:
        cond = conditions(SCENARIO, P.dt)
        noise = 0.002 * np.random.default_rng(3).standard_normal((1, steps))
    name = designs.parse_kind(kind)[1]
    d = built[kind]
    xs, us = designs.entry(name).rollout(PLANT, d, cond, noise)
    ctrl = designs.entry(name).controller(d)
    _drive(ctrl, cond, noise[0])  # a first run, so reset() must really reset
    x2, u2 = _drive(ctrl, cond, noise[0])
    np.testing.assert_array_equal(us[0], u2)
    np.testing.assert_array_equal(xs[0], x2)


@pytest.mark.parametrize("kind", KINDS)
def test_each_design_succeeds_nominally_at_one_metre_on_the_plant(built, kind):
    name = designs.parse_kind(kind)[1]
    xs, _ = designs.entry(name).rollout(PLANT, built[kind], nominal(1.0), np.zeros((1, 3000)))
    assert compute(xs[0], 1.0, P.dt).sse < SUCCESS_SSE


@pytest.mark.parametrize("setpoint", [1.5, -1.5])
def test_mpc_holds_setpoints_whose_force_is_not_in_the_alphabet(setpoint):
    """Without integral action on the reference this search settles 7.8 % and 8.7 % off (pinned PLM)."""
    d = mpc.design(_model("plm"), setpoint, P.F, P.dt)
    xs, _ = mpc.rollout(PLANT, d, nominal(setpoint), np.zeros((1, 3000)))
    assert compute(xs[0], setpoint, P.dt).sse < SUCCESS_SSE


@pytest.mark.parametrize("kind", ["glm+pid", "greybox+lqr", "plm+mpc"])
def test_quantised_designs_send_only_the_five_alphabet_forces(built, kind):
    name = designs.parse_kind(kind)[1]
    _, us = designs.entry(name).rollout(PLANT, built[kind], conditions(SCENARIO, P.dt),
                                        0.002 * np.random.default_rng(1).standard_normal((1, 1500)))
    assert set(np.unique(us)) <= set(QConfig().actions())
    assert len(np.unique(us)) >= 2


def test_continuous_pid_uses_forces_outside_the_alphabet(built):
    _, us = designs.DESIGNS["pid-continuous"].rollout(PLANT, built["glm+pid-continuous"], nominal(1.0),
                                                      np.zeros((1, 3000)))
    assert not set(np.unique(us)) <= set(QConfig().actions())
    assert np.all(np.abs(us) <= P.F)


@pytest.mark.parametrize("surrogate", ["glm", "plm"])
def test_pid_meets_its_phase_margin_at_its_crossover_and_is_stable(surrogate):
    opt = pid.PidOptions(crossover=4.0, phase_margin=55.0)
    d = pid.design(_model(surrogate), 1.0, P.F, P.dt, opt)
    assert d.facts["phase_margin"] == pytest.approx(55.0, abs=0.5)
    assert d.facts["crossover"] == pytest.approx(4.0, rel=0.02)
    assert d.facts["closed_loop_pole_radius"] < 1.0
    assert d.facts["bandwidth"] > 0.0
    assert d.gains.kp > 0 and d.gains.ki > 0 and d.gains.kd > 0
    assert d.as_dict()["phase_margin"] == d.facts["phase_margin"]


def test_glm_linearisation_is_the_glm_itself():
    """Numerical linearisation of a linear model gives its own coefficients back."""
    m = _model("glm")
    _, n1, n2, d1, d2, _, _ = m.params
    op = base.operating_point(m, 1.0)
    np.testing.assert_allclose(op.a[0], [-d1, -d2, n2], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(op.b[0], n1, rtol=1e-5)


def test_plant_equilibrium_force_is_the_spring_force():
    op = base.operating_point(plant_model(P), 1.0)
    assert op.u_eq == pytest.approx(P.k * np.sin(P.g) + P.h, rel=1e-9)


def test_pid_integral_does_not_wind_up_while_saturated():
    """Held far below an unreachable set-point the command saturates; the integral must not grow."""
    d = pid.design(_model("glm"), 1.0, P.F, P.dt)
    cs = pid.controller_state()
    pid.act(d.gains, cs, -2.0, True)
    for _ in range(2000):  # 20 s of a 3 m error, as if the mass were stuck at a stop
        pid.act(d.gains, cs, -2.0, False)
    assert cs[0] == pytest.approx(0.0, abs=1e-12)
    # Once free and at the set-point (derivative kick decayed), it asks for about the holding force, not +F.
    for _ in range(50):
        u = pid.act(d.gains, cs, 1.0, False)
    assert abs(u - d.gains.u_eq) <= P.F / 4


def test_lqr_integral_does_not_wind_up_while_saturated(built):
    d = built["greybox+lqr"]
    assert isinstance(d, lqr.LqrDesign)
    ost, cs = base.observer_state(d.observer), np.zeros(2)
    lqr.act(d.law, d.observer, ost, cs, -2.0, True)
    for _ in range(2000):
        lqr.act(d.law, d.observer, ost, cs, -2.0, False)
        assert cs[1] == P.F
    assert cs[0] == pytest.approx(0.0, abs=1e-12)


def test_lqr_closed_loop_of_the_design_is_stable(built):
    assert built["greybox+lqr"].facts["closed_loop_pole_radius"] < 1.0


def test_mpc_horizon_is_at_least_one_second_and_short_ones_are_refused(built):
    d = built["plm+mpc"]
    assert d.facts["horizon_s"] >= 1.0 and int(d.law.blocks.sum()) + d.law.tail >= 100
    with pytest.raises(ConfigError, match="shorter than"):
        mpc.design(_model("plm"), 1.0, P.F, P.dt, mpc.MpcOptions(blocks=(5, 10), tail=50))


def test_mpc_plan_is_the_exact_minimum_over_every_block_plan():
    """Branch and bound must return the first force of the best of all 5^depth plans."""
    m = _model("plm")
    d = mpc.design(m, 1.0, P.F, P.dt, mpc.MpcOptions(blocks=(10, 30, 60), tail=0))
    s0 = np.array([0.6, 0.59, 5.0, 0.0])
    forces = QConfig().actions()
    best, best_cost = 0.0, np.inf
    for i in range(5):
        for j in range(5):
            for k in range(5):
                s, cost, prev = s0.copy(), 0.0, 5.0
                for f, n in ((forces[i], 10), (forces[j], 30), (forces[k], 60)):
                    cost += d.law.move_weight * (f - prev) ** 2
                    prev = f
                    for _ in range(n):
                        cost += (kernels.advance_loaded(m.kernel, s, f, 0.3) - 0.9) ** 2
                if cost < best_cost:
                    best, best_cost = forces[i], cost
    assert mpc.plan(d.law, mpc.workspace(d.law), s0, 0.3, 5.0, 0.9) == best


def test_designs_are_deterministic_and_artifacts_are_plain(built):
    import json

    for kind, d in built.items():
        surrogate, name = designs.parse_kind(kind)
        again = designs.make(name, _model(surrogate), 1.0, P.F, P.dt)
        assert json.dumps(d.as_dict(), sort_keys=True) == json.dumps(again.as_dict(), sort_keys=True)


def test_bad_kinds_and_unholdable_setpoints_are_one_line_errors():
    with pytest.raises(ConfigError, match="unknown baseline design 'pd'"):
        designs.parse_kind("glm+pd")
    with pytest.raises(ConfigError, match="<surrogate>\\+<design>"):
        designs.parse_kind("pid")
    with pytest.raises(ConfigError, match="set-point"):
        pid.design(_model("glm"), 3.0, P.F, P.dt)
    with pytest.raises(ConfigError, match=r"unknown option\(s\) wc; known: alpha, crossover"):
        designs.make("pid", _model("glm"), 1.0, P.F, P.dt, wc=3.0)
    weak = plant_model(PlantParams(F=1.0))
    with pytest.raises(ConfigError, match="cannot hold the set-point"):
        lqr.design(weak, 1.5, 1.0, P.dt)


@pytest.mark.parametrize("kind", KINDS)
def test_stepwise_controllers_refuse_a_non_finite_measurement(built, kind):
    ctrl = designs.entry(designs.parse_kind(kind)[1]).controller(built[kind])
    ctrl.act(0.0)
    with pytest.raises(InvalidInputError, match="measured position must be finite"):
        ctrl.act(float("nan"))


def test_evaluate_counts_one_run_per_condition_and_one_per_noise_draw():
    cells = evaluate_policy(baseline_policy("pid", _model("glm"), P), P, seeds=[0, 1, 2],
                            scenarios=[parse("nominal"), parse("noise=0.002")], steps=1500)
    assert cells["nominal"]["n"] == 1
    assert cells["noise=0.002"]["n"] == 3


def test_a_design_study_options_reach_the_design_and_a_wrong_one_is_one_line():
    fast = baseline_policy("pid", _model("glm"), P, crossover=3.0).design_at(1.0).as_dict()
    default = baseline_policy("pid", _model("glm"), P).design_at(1.0).as_dict()
    assert fast != default
    with pytest.raises(ConfigError, match="unknown option"):
        baseline_policy("pid", _model("glm"), P, wc=3.0)
    with pytest.raises(ConfigError, match="unknown baseline design"):
        baseline_policy("pdi", _model("glm"), P)
