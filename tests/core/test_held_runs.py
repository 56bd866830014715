"""Runs of a rig under its operation (issue 38 item 3): a stage decided at the paper's pace and run
under its stated hold loop, through the one closed loop (``Conditions.every``, ``hold_kp``,
``hold_kd``); a bare rig runs exactly as before."""

from __future__ import annotations

import numpy as np
import pytest

from msd_bench.core.evaluation.closed_loop import stepwise
from msd_bench.core.physics.model import plant_model
from msd_bench.core.rigs.hold import BARE, Operation
from msd_bench.core.rigs.rig import Rig
from msd_bench.core.rigs.rig_loop import conditions, run_controller_on_rig
from msd_bench.core.rigs.stage_family import draw


class Counting:
    """A controller that answers its n-th call with a distinct force (so holds are visible)."""

    def __init__(self, force: float) -> None:
        self.force, self.calls = force, 0

    def reset(self) -> None:
        self.calls = 0

    def act(self, y: float) -> float:
        self.calls += 1
        return self.force * ((self.calls % 5) - 2) / 2.0


def _stage(seed: int) -> tuple[Rig, Operation]:
    spec = draw(seed)
    return Rig(spec.params, spec.imperfections, seed=seed), spec.operation()


def test_a_stage_decides_at_its_pace_and_holds_the_command_in_between() -> None:
    rig, op = _stage(4)
    assert op.every > 1 and op.hold is not None
    ctl = Counting(0.2 * rig.params.F)
    steps = 10 * op.every + 3
    t = stepwise(ctl, plant_model(rig.params).kernel, conditions(rig, 0.0, op=op), np.zeros(steps), None,
                 (0.0, 0.0), True, 0)
    assert ctl.calls == -(-steps // op.every)
    for k in range(steps):
        assert t.command[0, k] == t.command[0, k - k % op.every]
    assert len(set(t.command[0, :: op.every])) > 1


def test_the_hold_loops_force_is_added_to_every_command_from_the_measured_position() -> None:
    rig, op = _stage(4)
    assert op.hold is not None
    ctl = Counting(0.2 * rig.params.F)
    steps = 6 * op.every
    t = stepwise(ctl, plant_model(rig.params).kernel, conditions(rig, 0.0, op=op), np.zeros(steps), None,
                 (0.05 * rig.params.L, 0.0), True, 0)
    y, u = t.y[0], t.command[0]
    last = np.concatenate([[y[0]], y[:-1]])
    loop = -op.hold.stiffness * (y - op.hold.held) - op.hold.damping / rig.params.dt * (y - last)
    want = np.clip(u + loop, -rig.params.F, rig.params.F)
    assert np.allclose(t.force[0], want, rtol=1e-12, atol=1e-9 * rig.params.F)
    assert not np.allclose(t.force[0], np.clip(u, -rig.params.F, rig.params.F))


def test_a_bare_rig_sends_each_sample_its_own_command_and_nothing_else() -> None:
    """No operation: every sample decided, the force the (clipped) command exactly, as before holds and
    loops existed (the default and scaled families' runs are unchanged bit for bit)."""
    rig, _ = _stage(4)
    cond = conditions(rig, 0.01, op=BARE)
    assert (cond.every, cond.hold_kp, cond.hold_kd, cond.held) == (1, 0.0, 0.0, 0.0)
    assert cond == conditions(rig, 0.01)
    ctl = Counting(0.7 * rig.params.F)
    noise = np.random.default_rng(2).standard_normal(500) * 1e-4
    t = stepwise(ctl, plant_model(rig.params).kernel, cond, noise, None, (0.0, 0.0), True, 5)
    assert ctl.calls == 500
    assert np.array_equal(t.force[0], np.clip(t.command[0], -rig.params.F, rig.params.F))


@pytest.mark.parametrize("seed", [0, 1])
def test_under_its_hold_loop_a_stage_left_alone_stays_near_its_held_position(seed: int) -> None:
    """The loop holds a stage against its offset force and friction; with nothing commanded the
    stage rests inside a few per cent of its stroke, where a bare stage with an offset beyond its
    friction would coast to a stop (test_stage_family: open loop it walks into one)."""
    rig, op = _stage(seed)
    rng = np.random.default_rng(seed)
    zero = Counting(0.0)
    r = run_controller_on_rig(rig, zero, 0.0, 20 * op.every * 50, rng, op=op)
    assert r.rest.still
    assert np.max(np.abs(r.x)) < 0.05 * rig.params.L
    assert np.all(np.abs(r.effort) <= rig.params.F * (1 + 1e-12))
