"""The robust agent on a held rig: its commands carry the stated loop's force at the set-point and leave
out its force-bias estimate there, and only there."""

from __future__ import annotations

from dataclasses import replace

from msd_bench.core.learning import q_kernels
from msd_bench.core.learning.qconfig import packed
from msd_bench.core.rigs.hold import HoldLoop
from msd_bench.designs import Drive
from msd_bench.designs.qlearning import for_actuator, for_drive, learner_config

LOOP = HoldLoop(stiffness=200.0, damping=30.0, held=0.1)


def test_only_a_held_drive_switches_the_change_on() -> None:
    robust = learner_config("glm+robust", 10, 100, 10.0)
    bare = for_drive(robust, Drive(2, 0.01))
    assert bare == for_actuator(robust, 2)  # the default and scaled families: unchanged, bit for bit
    assert not bare.obs_bias_feedforward and bare.hold_stiffness == 0.0
    held = for_drive(robust, Drive(2, 0.01, hold=LOOP))
    assert held == replace(for_actuator(robust, 2), obs_bias_feedforward=True, hold_stiffness=200.0,
                           hold_position=0.1)
    improved = learner_config("glm+improved", 10, 100, 10.0)
    assert for_drive(improved, Drive(0, 0.0, hold=LOOP)) == improved  # no observer: nothing to carry


def test_the_command_carries_the_loop_force_at_the_set_point_less_the_bias_estimate() -> None:
    robust = learner_config("glm+robust", 10, 100, 10.0)
    target = 0.6
    held = for_drive(robust, Drive(0, 0.0, hold=LOOP))
    for cfg, expected in ((robust, 5.0), (held, 5.0 + 200.0 * (target - 0.1) - 1.5)):
        lr = packed(cfg)
        ost = q_kernels.observer_state(lr)
        ost[ost.size - 1] = 1.5  # the observer believes in a 1.5 N push the model does not know
        assert q_kernels.commanded(lr, ost, 5.0, target) == expected
