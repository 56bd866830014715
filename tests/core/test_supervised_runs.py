"""Validation behind the supervisor in-process: the node's path, bit for bit.

Two references, each written independently of :func:`closed_loop.supervised_runs`:
a design's own compiled rollout (when nothing is overridden the supervisor must
not change a sample) and the rig emulator (:meth:`Rig.step`) driven through the
stepwise :class:`Supervisor` a node holds, sample by sample here, with overrides;
``adversaries.run_on_rig`` (the compiled loop on the rig) must equal that too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from msd_bench.core.baselines import designs
from msd_bench.core.errors import InvalidInputError
from msd_bench.core.evaluation.closed_loop import Conditions, supervised_runs
from msd_bench.core.evaluation.robustness import conditions
from msd_bench.core.evaluation.scenarios import parse
from msd_bench.core.physics.model import plant_model
from msd_bench.core.physics.plant import PlantParams
from msd_bench.core.physics.sensor import sensor_rng
from msd_bench.core.rigs.rig import Rig, RigImperfections, lag_samples
from msd_bench.core.safety.adversaries import Adversary, Runs, adversary, command, run_on_rig
from msd_bench.core.safety.supervisor import ENVELOPE, NONE, S_ABORT, Supervisor, SupervisorOptions
from msd_bench.io.storage.artifacts import load_model

P = PlantParams()
PLANT = plant_model(P).kernel
PINNED = Path(__file__).resolve().parents[1] / "data" / "pinned"
SCENARIO = parse("noise=0.002,delay=1,disturbance=2@5")
LENIENT = SupervisorOptions(envelope=2.4, margin=0.05, brake_share=1.0, mass_factor=1.0, v_margin=0.0)
"""Limits a good baseline never meets (the test checks that it did not)."""


@pytest.mark.parametrize(("name", "surrogate"), [("pid", "glm"), ("lqr", "greybox")])
def test_with_nothing_overridden_the_run_is_the_designs_own_rollout(name: str, surrogate: str) -> None:
    d = designs.make(name, load_model(PINNED / f"{surrogate}.json"), 1.0, P.F, P.dt)
    cond = conditions(SCENARIO, P.dt)
    noise = 0.002 * np.random.default_rng(3).standard_normal((1, 1500))
    xs, us = designs.entry(name).rollout(PLANT, d, cond, noise)
    r = supervised_runs([designs.entry(name).controller(d)], PLANT, cond, noise, LENIENT.limits(P))
    assert not r.reason.any() and r.aborts[0] == NONE
    np.testing.assert_array_equal(r.x, xs)
    np.testing.assert_array_equal(r.command, us)
    np.testing.assert_array_equal(r.force, us)


def _node_path(imp: RigImperfections, sup: Supervisor, adv: Adversary, steps: int, seed: int) -> Runs:
    """The rig node's path, written out: the rig emulator stepped by the supervisor node's filter on
    the measured y_k (the first is the rest position), the adversary on the same y_k."""
    rig = Rig(P, imp, seed)
    sup.reset()
    out = np.empty((4, steps))
    reasons = np.zeros(steps, dtype=np.int64)
    y, y_prev = 0.0, 0.0
    for k in range(steps):
        u = float(command(adv, 0, k, y, y_prev, 1.0, P.dt))
        d = sup.step(y, 1.0, u)
        reasons[k] = d.reason
        row = rig.step(d.force)
        out[:, k] = (row.x, row.v, u, d.force)
        y_prev, y = y, row.measured_next
    return Runs(out[0][None], out[1][None], out[2][None], out[3][None], reasons[None],
                np.array([int(sup.state[S_ABORT])], dtype=np.int64))


class _Adversary:
    """An adversary of ``core/safety/adversaries.py`` as a stepwise controller (what an agent node runs)."""

    def __init__(self, adv: Adversary, reference: float) -> None:
        self.adv, self.reference = adv, reference
        self.reset()

    def reset(self) -> None:
        self.k, self.y_prev = 0, 0.0

    def act(self, y: float) -> float:
        u = float(command(self.adv, 0, self.k, y, self.y_prev, self.reference, P.dt))
        self.k, self.y_prev = self.k + 1, y
        return u


@pytest.mark.parametrize("name", ["turncoat", "bang_bang"])
def test_in_process_runs_equal_the_stepwise_supervisor_on_the_rig_emulator(name: str) -> None:
    steps, seed = 2000, 4
    imp = RigImperfections(sensor_noise=0.002, sensor_quant=0.0, delay_samples=1, actuator_tau=0.02,
                           friction=0.0, jitter=0.0)
    adv = adversary(name, P, steps)
    opts = SupervisorOptions()
    ref = _node_path(imp, Supervisor(opts, P), adv, steps, seed)
    compiled = run_on_rig(P, imp, opts.limits(P), adv, steps, seed=seed)
    for name in Runs._fields:
        np.testing.assert_array_equal(getattr(compiled, name), getattr(ref, name))
    noise = imp.sensor_noise * sensor_rng(seed).standard_normal((1, steps))
    cond = Conditions(1.0, 0.0, imp.delay_samples, 0.0, 0, 0.0, lag_samples(imp.actuator_tau, P.dt))
    got = supervised_runs([_Adversary(adv, 1.0)], PLANT, cond, noise, opts.limits(P))
    assert (ref.reason == ENVELOPE).sum() > 10  # the supervisor really worked in this run
    np.testing.assert_array_equal(got.reason, ref.reason)
    np.testing.assert_array_equal(got.force, ref.force)
    np.testing.assert_array_equal(got.x, ref.x)
    np.testing.assert_array_equal(got.aborts, ref.aborts)


def test_one_controller_per_noise_row() -> None:
    with pytest.raises(InvalidInputError, match="one controller per noise row"):
        supervised_runs([], PLANT, conditions(SCENARIO, P.dt), np.zeros((1, 10)),
                        SupervisorOptions().limits(P))
