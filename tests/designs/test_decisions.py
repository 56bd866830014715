"""A decision period of n rig samples (issue 37 item 3): a design learns on the model held over them.

:func:`msd_bench.designs.request` is the one place: at one sample per decision nothing changes (the
same objects); at n > 1 the design sees the held model, the decision period as its dt and episodes
of decisions, and a design that has not opted in is one line.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from msd_bench import designs
from msd_bench.core.errors import ConfigError
from msd_bench.core.learning.qconfig import improved_config
from msd_bench.core.physics import kernels
from msd_bench.core.physics.model import StepModel, held, plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.rigs.description import parse_description
from msd_bench.designs import Drive, Settings
from msd_bench.designs.qlearning import QPolicy

STAGE = parse_description({"rate": 1000.0, "stroke": 0.25, "force_limit": 350.0})
"""The stage of config/rigs/stage_1khz.yaml: 10 ms decisions are 10 samples."""


def _stage_settings(**kw: object) -> Settings:
    p = STAGE.emulated_plant()
    return replace(Settings(episodes=3, steps=2000, force=p.F, dt=p.dt, stroke=p.L, target=0.05,
                            decision_samples=STAGE.samples_per_decision), **kw)  # type: ignore[arg-type]


def test_one_sample_per_decision_changes_nothing() -> None:
    model, s, drive = plant_model(PlantParams()), Settings(), Drive(2, 0.02)
    got = designs.at_decisions("glm+improved", model, s, drive)
    assert got[0] is model and got[1] is s and got[2] is drive


def test_the_design_sees_the_held_model_and_the_decision_period() -> None:
    p = STAGE.emulated_plant()
    model, s, drive = designs.at_decisions("plant+improved", plant_model(p), _stage_settings(),
                                           Drive(20, 0.02))
    assert model is not None and model.kind == kernels.KIND_HELD and model.dt == pytest.approx(0.01)
    assert s.dt == pytest.approx(0.01) and (s.steps, s.decision_samples) == (200, 1)
    assert drive == Drive(2, 0.02)  # 20 rig samples of dead time are 2 decisions


def test_learning_at_decisions_is_learning_on_the_held_model() -> None:
    """In-process training with 10 samples per decision gives the tables of training, one sample per
    decision, on the held model itself at the decision period: bit for bit."""
    p = STAGE.emulated_plant()
    s = _stage_settings()
    via = designs.make("plant+improved", plant_model(p), s, [1, 2])
    direct = designs.make("plant+improved", held(plant_model(p), 10),
                          replace(s, dt=0.01, steps=200, decision_samples=1), [1, 2])
    assert isinstance(via, QPolicy) and isinstance(direct, QPolicy)
    np.testing.assert_array_equal(via.q, direct.q)
    # at 10 ms decisions the learner is the paper's time base: only lengths and forces are scaled
    expected = improved_config(STAGE.scales().__class__(length=0.05, force=35.0))
    assert via.learner.e_max == pytest.approx(expected.e_max)
    assert via.learner.lead_steps == expected.lead_steps
    assert via.learner.steps == 200


def test_a_design_that_does_not_hold_is_one_line() -> None:
    with pytest.raises(ConfigError, match=r"glm\+ppo: a decision period of 10 rig samples is not supported"):
        designs.check_decisions("glm+ppo", 10)
    designs.check_decisions("glm+ppo", 1)
    designs.check_decisions("dyna-q", 10)
    designs.check_decisions("glm+pid", 10)


@pytest.mark.parametrize("kind", ["glm+pid", "greybox+lqr", "nlarx-improved+lqr", "greybox-rig+mpc"])
def test_a_baseline_is_designed_on_the_held_model(kind: str) -> None:
    """A baseline deciding every 4 samples is designed on the surrogate held over them: its operating
    point is the held model's (the inner model's rest state, A and B over a decision; an ARX-type state's
    velocity over one *sample*), so its design is the one made directly on the held model at the decision
    period, and its controller gives finite forces."""
    from msd_bench.core.baselines import base

    p = PlantParams()
    model = _surrogate(kind.split("+")[0], p)
    s = Settings(episodes=3, steps=2000, force=p.F, dt=p.dt, stroke=p.L, target=1.0, decision_samples=4)
    via = designs.make(kind, model, s, [0])
    direct = designs.make(kind, held(model, 4), replace(s, dt=4 * p.dt, steps=500, decision_samples=1), [0])
    assert via.artifact() == direct.artifact()  # type: ignore[attr-defined]
    op = base.operating_point(held(model, 4), 1.0)
    assert op.s_eq.size == base.slots(model)
    if not kernels.holds_velocity(model.kind):  # slots [x_k, x_{k-1}, u]: one sample apart
        assert tuple(op.velocity[:2]) == pytest.approx((1.0 / p.dt, -1.0 / p.dt))
    ctl = via.controller(0, 1.0)
    ctl.reset()
    assert all(np.isfinite(ctl.act(0.1 * i)) for i in range(5))


def _surrogate(kind: str, p: PlantParams) -> StepModel:
    """A surrogate of ``kind`` at the default plant's rate: a pinned identified ARX-type model, the plant
    itself, or the plant behind a drive of 2 samples' dead time and a 20 ms lag."""
    from pathlib import Path

    from msd_bench.io.storage import artifacts

    if kind == "greybox":
        return plant_model(p)
    if kind == "greybox-rig":
        return StepModel(kernels.KIND_GREYBOX_RIG, np.concatenate([p.as_array(), [0.0, 0.02, 2.0]]), kind)
    return artifacts.load_model(Path(__file__).resolve().parents[1] / "data" / "pinned" / f"{kind}.json")


def test_the_robust_learner_on_the_stage_keeps_its_gains_in_the_rigs_units() -> None:
    """The robust agent's observer bias gain (8 N/m on the paper's plant) is 5,600 N/m on the stage: the
    bound it is checked against (1000 N/m on the paper's plant) is in the rig's units too."""
    from msd_bench.core.rigs.scales import Scales
    from msd_bench.designs.qlearning import ROBUST

    cfg = improved_config(Scales.of(0.25, 350.0, 0.01), **ROBUST)
    assert cfg.obs_bias_gain == pytest.approx(8.0 * 35 / 0.05)
    with pytest.raises(ConfigError, match=r"obs_bias_gain must be in \[0, 1000\] N/m"):
        improved_config(**{**ROBUST, "obs_bias_gain": 1001.0})


def test_the_robust_agent_learns_and_rehearses_on_the_held_model() -> None:
    """The robust agent's observer predicts with the held model and its table selection rehearses in the
    closed loop on it: both step the held kind (a stale compiled loop once raised 'unknown model kind')."""
    p = STAGE.emulated_plant()
    policy = designs.make("greybox+robust", plant_model(p), _stage_settings(), [1])
    assert isinstance(policy, QPolicy) and policy.observer is not None
    assert policy.observer.kind == kernels.KIND_HELD
    ctl = policy.controller(0, 0.05)
    assert all(np.isfinite(ctl.act(0.0)) for _ in range(5))
