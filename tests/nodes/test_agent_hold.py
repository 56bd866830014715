"""The agent node's hold (issue 37 item 3): between decisions the command is held over the samples."""

from __future__ import annotations

import pytest

from msd_bench.nodes.agent_node import _Drive, _Learn

pytestmark = pytest.mark.ros


class _Counting:
    """A controller (and a stepwise learner) that answers with how often it was asked."""

    def __init__(self) -> None:
        self.asked: list[float] = []
        self.learned: list[float] = []

    def reset(self) -> None:
        self.asked.clear()

    def act(self, y: float | None = None) -> float:
        self.asked.append(0.0 if y is None else y)
        return float(len(self.asked))

    def start_episode(self, x0: float) -> None:
        self.asked.clear()

    def learn(self, x: float) -> None:
        self.learned.append(x)


@pytest.mark.parametrize("hold", [1, 3])
def test_the_drive_asks_every_hold_samples_and_holds_the_command(hold: int) -> None:
    ctl = _Counting()
    drive = _Drive(ctl, 1.0, lambda _t: None, disturbance=0.5, disturbance_step=4, hold=hold)
    drive.start(0.0)
    commands = []
    for k in range(9):
        commands.append(drive.act())
        drive.observe(float(k + 1))
    decisions = [float(i // hold + 1) for i in range(9)]
    assert commands == [d + (0.5 if k >= 4 else 0.0) for k, d in enumerate(decisions)]
    assert ctl.asked == [0.0, *[float(k) for k in range(hold, 9, hold)]]  # the latest position at each


def test_a_learner_on_the_node_decides_and_learns_once_per_decision() -> None:
    learner = _Counting()
    learn = _Learn(learner, hold=3)  # type: ignore[arg-type]
    learn.start(0.0)
    commands = []
    for k in range(9):
        commands.append(learn.act())
        learn.observe(float(k + 1))
    assert commands == [1.0] * 3 + [2.0] * 3 + [3.0] * 3
    assert learner.learned == [3.0, 6.0, 9.0]  # the position a decision later
