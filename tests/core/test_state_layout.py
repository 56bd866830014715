"""Model states of every layout: the robust observer and the baselines on a greybox-rig model.

The greybox-rig's state is eight floats (its actuator's lag and delay line
behind x and v); the robust observer used to keep its drift estimate in slot 3
and the baselines allocated four floats, so a rig model with a delay either
had its delay line overwritten or was refused. These tests drive both through
the greybox-rig kind and read no slot by a literal.
"""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.app.config import RunConfig
from msd_bench.app.pipeline import settings
from msd_bench.core.baselines import designs as baselines
from msd_bench.core.evaluation.metrics import compute
from msd_bench.core.evaluation.results import SUCCESS_SSE
from msd_bench.core.evaluation.robustness import conditions
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.learning import q_kernels as qlearning
from msd_bench.core.learning.qconfig import improved_config, packed
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, plant_model
from msd_bench.core.physics.plant import PlantParams
from tests.syntax import parse_source

ROOT = Path(__file__).resolve().parents[2]
P = PlantParams()


def rig_model(friction: float, tau: float, delay: int) -> StepModel:
    """A greybox-rig model with the nominal plant and the given actuator and friction."""
    return StepModel(kernels.KIND_GREYBOX_RIG, np.concatenate([P.as_array(), [friction, tau, delay]]),
                     "greybox-rig", dt=P.dt, force_limit=P.F)


@pytest.mark.parametrize("delay", [0, 1, 2, kernels.RIG_DELAY_MAX])
def test_every_kind_states_its_state_length_and_velocity_slot(delay: int) -> None:
    rig = rig_model(0.1, 0.02, delay)
    assert rig.initial_state().size == kernels.state_size(kernels.KIND_GREYBOX_RIG) == kernels.RIG_STATE_SIZE
    assert kernels.used_slots(rig.kernel) == 3 + delay
    assert kernels.holds_velocity(kernels.KIND_GREYBOX_RIG) and kernels.holds_velocity(kernels.KIND_PLANT)
    for kind in (kernels.KIND_LINEAR, kernels.KIND_PLM, kernels.KIND_NLARX):
        assert kernels.state_size(kind) == 4 and not kernels.holds_velocity(kind)
    assert max(kernels.state_size(k) for k in kernels.KIND_NAMES) == kernels.STATE_MAX


@pytest.mark.parametrize("delay", [1, 2])
def test_the_robust_observer_on_a_rig_model_with_a_delay_line_tracks_it_exactly(delay: int) -> None:
    """Noise-free measurements of the observer's own model: every innovation is zero, so the estimate
    is the measurement. With the drift estimate in slot 3 (the delay line) it drifted away."""
    model = rig_model(0.15, 0.02, delay)
    us = list(np.random.default_rng(4).choice([-10.0, -5.0, 0.0, 5.0, 10.0], size=400))
    state = model.initial_state()
    ys = [0.0] + [model.step(state, u) for u in us]
    lr = packed(improved_config(observer="model", obs_gain=0.3, obs_drift_gain=0.01))
    ost = qlearning.observer_state(lr)
    xh, dh = qlearning.observe(lr, model.kernel, ost, 0.0, ys[0], 0.0, 0.0, True)
    xs = [xh]
    for u, y in zip(us, ys[1:], strict=True):
        xh, dh = qlearning.observe(lr, model.kernel, ost, u, y, xh, dh, False)
        xs.append(xh)
    assert xs == ys
    assert ost[qlearning.OBS_DRIFT] == 0.0


TINY = RunConfig(seeds=2, id_seeds=1, samples=600, val_samples=400, validation_steps=600, window=100,
                 episodes=3, steps=600, agents=("greybox+robust",))


def test_greybox_rig_robust_with_the_plants_values_trains_as_greybox_robust_bit_for_bit() -> None:
    """A rig model without friction, lag or delay is the plant: the robust agent on it learns the
    same tables and validates the same runs as on the plant's model (the state layouts differ)."""
    s = settings(TINY)
    on_rig = designs.make("greybox-rig+robust", rig_model(0.0, 0.0, 0), s, [0, 1])
    on_plant = designs.make("greybox+robust", plant_model(P), s, [0, 1])
    x_rig, u_rig = designs.nominal_runs(on_rig, P, 1.0, TINY.validation_steps)
    x_plant, u_plant = designs.nominal_runs(on_plant, P, 1.0, TINY.validation_steps)
    np.testing.assert_array_equal(x_rig, x_plant)
    np.testing.assert_array_equal(u_rig, u_plant)


def test_greybox_rig_robust_trains_and_validates_on_a_rig_model_with_a_delay_and_lag() -> None:
    s = settings(replace(TINY, agents=("greybox-rig+robust",)))
    policy = designs.make("greybox-rig+robust", rig_model(0.1, 0.02, 2), s, [0, 1])
    x, u = designs.nominal_runs(policy, P, 1.0, TINY.validation_steps)
    assert x.shape == (2, TINY.validation_steps) and np.all(np.isfinite(x)) and np.all(np.abs(u) <= P.F)


RIG_SCENARIO = "delay=1,lag=0.02,friction=0.1"


@pytest.mark.parametrize("name", ["lqr", "mpc", "pid", "pid-continuous"])
def test_each_baseline_designed_on_a_rig_model_holds_that_rig(name: str) -> None:
    """Designed on a greybox-rig model with the rig's delay, lag and friction, each baseline reaches the
    set-point on the plant given that actuator and friction (the in-process loop of a rig)."""
    model = rig_model(0.1, 0.02, 1)
    policy = designs.make(f"greybox-rig+{name}", model, settings(replace(TINY, agents=(f"greybox+{name}",))),
                          [0])
    cond = conditions(replace(parse(RIG_SCENARIO), setpoint=1.0), P.dt)
    xs, _ = policy.rollout(plant_model(P).kernel, cond, np.zeros((1, 3000)))
    assert compute(xs[0], 1.0, P.dt).sse < SUCCESS_SSE


def test_a_baselines_linearisation_of_a_rig_model_sees_its_delay_line() -> None:
    """The command enters the newest delay slot, not the position: the input column says so."""
    from msd_bench.core.baselines import base

    op = base.operating_point(rig_model(0.1, 0.02, 2), 1.0)
    assert op.b.size == 5 and op.b[kernels.RIG_LAG + 1] == pytest.approx(1.0)
    assert op.b[kernels.POS] == 0.0 and op.b[kernels.MOTION] == 0.0
    assert op.load[kernels.MOTION] > 0.0
    assert op.u_eq == pytest.approx(baselines.make("lqr", plant_model(P), 1.0, P.F, P.dt).law.u_eq)


STATE_NAMES = {"state", "ost", "s", "s0", "s_eq", "plant", "queue_state", "ms"}
"""Names under which the scanned code holds a model state (or an observer state around one)."""
SCANNED = ("msd_bench/designs", "msd_bench/core/baselines", "msd_bench/core/learning/q_kernels.py")


def _literal_slots(path: Path) -> list[str]:
    """``name[<int literal>]`` or a slice with an int-literal bound, on a state-holding name."""
    out = []
    for node in ast.walk(parse_source(path.read_text())):
        if not (isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name)
                and node.value.id in STATE_NAMES):
            continue
        idx = node.slice
        parts = [idx] if not isinstance(idx, ast.Slice) else [idx.lower, idx.upper]
        if isinstance(idx, ast.Tuple):
            parts = list(idx.elts)
        if any(isinstance(p, ast.Constant) and isinstance(p.value, int) for p in parts):
            out.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    return out


def test_no_design_or_observer_indexes_a_model_state_by_a_literal_slot() -> None:
    files = [p for s in SCANNED for p in ((ROOT / s).rglob("*.py") if (ROOT / s).is_dir() else [ROOT / s])]
    assert len(files) > 5
    assert [hit for f in files for hit in _literal_slots(f)] == []
